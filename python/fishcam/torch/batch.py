"""Batched tensors: warp_batch (torch's grid_sample on any device) and collate."""

import typing

import numpy as np
import torch
from torchvision import tv_tensors

from .. import Camera, Error, ViewpointChange
from .. import transforms as _transforms
from .targets import Fill


class WarpedBatch(typing.NamedTuple):
    """warp_batch's result: images (B, C, H, W), masks (B, H, W) or None, valid (B, H, W) bool."""

    images: torch.Tensor
    masks: typing.Optional[torch.Tensor]
    valid: torch.Tensor


_batch_warps = _transforms._WarpCache()


def warp_batch(
    images: torch.Tensor,
    cameras: typing.Union[Camera, typing.Sequence[Camera]],
    changes: typing.Sequence[ViewpointChange],
    masks: typing.Optional[torch.Tensor] = None,
    depth: str = "source-sphere",
    fill: Fill = 0.0,
    fill_mask: int = 0,
) -> WarpedBatch:
    """Viewpoint changes for a batch of tensors on any device.

    The maps come from fishcam on the CPU (the grid path, geometric: within 1/32 px
    of the per-pixel map), one per sample; the sampling is
    ``torch.nn.functional.grid_sample`` on the tensors' device (CPU or CUDA):
    bilinear for images, nearest for masks, in one call for the batch.

    Args:
        images: (B, C, H, W) tensor, uint8, uint16 or floating point, on any device.
        cameras: one fishcam.Camera for the batch, or a sequence of B (one per sample).
        changes: a sequence of B fishcam.ViewpointChange (e.g. ``fishcam.random_change``).
        masks: None or (B, H, W) integer or bool tensor on the images' device (nearest; dtype kept):
            one semantic label map per sample, or one bool mask per sample.
        depth: the depth prior ("source-sphere", "target-sphere", "infinity").
        fill: where the moved camera has no source: the images' value (a number: for
            integer images one of their dtype's values, for floating point ones any
            within its range, NaN too), or ``{tv_tensors.Image: ..., tv_tensors.Mask: ...}``
            as RandomViewpoint's.
        fill_mask: the masks' value there (or ``fill[tv_tensors.Mask]``): an integer
            the masks' dtype holds (within +-2^24); bool masks get False whatever it says.

    Returns:
        WarpedBatch(images, masks, valid): the images and masks in their dtypes and on
        their device; valid (B, H, W) bool, where the output has a source.
    """
    image_fill, fill_mask = _checked_fills(images, fill, fill_mask)
    batch, _, height, width = images.shape
    camera_list, change_list = _per_sample(cameras, changes, batch)
    _check_masks(masks, images)
    grids, valid = _sampling_grids(camera_list, change_list, depth, height, width)
    device = images.device
    grids, valid = grids.to(device), valid.to(device)
    sampled = _sample_images(images, grids, valid, image_fill)
    out_masks = None if masks is None else _sample_masks(masks, grids, valid, fill_mask)
    return WarpedBatch(sampled.to(images.dtype), out_masks, valid)


def _checked_fills(images: torch.Tensor, fill: Fill, fill_mask: int) -> tuple[float, int]:
    """(the images' fill, the masks' fill) of warp_batch's arguments, after checking
    that ``images`` is a (B, C, H, W) integer or floating point tensor whose dtype
    holds the images' fill; fishcam.Error otherwise."""
    if not isinstance(images, torch.Tensor) or images.ndim != 4:
        raise Error(f"images: expected a (B, C, H, W) tensor, got {getattr(images, 'shape', type(images).__name__)}")
    if images.dtype == torch.bool or images.is_complex():
        raise Error(f"images: expected an integer or floating point tensor, got {images.dtype}")
    image_fill: typing.Any = fill  # a number (NaN included, for float images)
    if isinstance(fill, typing.Mapping):
        image_fill, fill_mask = _transforms._split_fill(
            fill, fill_mask, tv_tensors.Image, tv_tensors.Mask, finite=False, label_range=None
        )
    image_fill = _transforms._number(image_fill, "fill")
    fill_mask = _transforms._integer(fill_mask, "fill_mask")
    if images.is_floating_point():
        if np.isfinite(image_fill) and abs(image_fill) > torch.finfo(images.dtype).max:
            raise Error(f"images: the no-source fill {image_fill} is past the range of dtype {images.dtype}")
    else:
        info = torch.iinfo(images.dtype)
        if not (image_fill.is_integer() and info.min <= image_fill <= info.max):
            raise Error(
                f"images: the no-source fill {image_fill} is not a value of dtype {images.dtype} "
                f"(integers {info.min}..{info.max})"
            )
    return image_fill, fill_mask


def _per_sample(
    cameras: typing.Union[Camera, typing.Sequence[Camera]], changes: typing.Sequence[ViewpointChange], batch: int
) -> tuple[list[typing.Any], list[typing.Any]]:
    """warp_batch's cameras and changes as lists of one per sample (a single camera
    repeated); fishcam.Error when either does not count ``batch``."""
    camera_list = (
        [cameras] * batch
        if isinstance(cameras, Camera)
        else _transforms._sequence(cameras, "cameras", "a fishcam.Camera or a sequence of them")
    )
    change_list = _transforms._sequence(changes, "changes", "a sequence of fishcam.ViewpointChange")
    if len(camera_list) != batch or len(change_list) != batch:
        raise Error(
            f"cameras, changes: expected one per image ({batch}), got {len(camera_list)} and {len(change_list)}"
        )
    return camera_list, change_list


def _check_masks(masks: typing.Optional[torch.Tensor], images: torch.Tensor) -> None:
    """Refuses masks that are not (B, H, W) tensors on the images' device; their dtype
    and values are checked by _sample_masks, after the cameras and changes."""
    batch, _, height, width = images.shape
    if masks is not None and (not isinstance(masks, torch.Tensor) or tuple(masks.shape) != (batch, height, width)):
        raise Error(
            f"masks: expected a ({batch}, {height}, {width}) tensor, got "
            f"{getattr(masks, 'shape', type(masks).__name__)}"
        )
    if masks is not None and masks.device != images.device:
        raise Error(f"masks: on {masks.device} but the images are on {images.device}")


def _sampling_grids(
    cameras: typing.Sequence[typing.Any], changes: typing.Sequence[typing.Any], depth: str, height: int, width: int
) -> tuple[torch.Tensor, torch.Tensor]:
    """(grids (B, H, W, 2) float32, valid (B, H, W) bool) on the CPU: each sample's
    grid_sample grid and where it has a source, from fishcam's grid path."""
    batch = len(cameras)
    grids = torch.empty((batch, height, width, 2), dtype=torch.float32)
    valid = torch.empty((batch, height, width), dtype=torch.bool)
    for i, (camera, change) in enumerate(zip(cameras, changes)):
        if not isinstance(camera, Camera):
            raise Error(f"cameras[{i}]: expected a fishcam.Camera, got {type(camera).__name__}")
        if not isinstance(change, ViewpointChange):
            raise Error(f"changes[{i}]: expected a fishcam.ViewpointChange, got {type(change).__name__}")
        if (camera.width, camera.height) != (width, height):
            raise Error(f"images: are {width}x{height} but cameras[{i}] is {camera.width}x{camera.height}")
        grid, ok = _batch_warps.get(camera).sampling_grid(change, depth)
        grids[i] = torch.from_numpy(grid)
        valid[i] = torch.from_numpy(ok)
    return grids, valid


def _sample_images(images: torch.Tensor, grids: torch.Tensor, valid: torch.Tensor, fill: float) -> torch.Tensor:
    """The images sampled bilinearly at ``grids``, ``fill`` where not ``valid``: in
    floating point (integer images' values rounded and clamped to their dtype's)."""
    device = images.device
    floating = images if images.is_floating_point() else images.float()
    sampled = torch.nn.functional.grid_sample(
        floating, grids.to(floating.dtype), mode="bilinear", padding_mode="border", align_corners=True
    )
    sampled = torch.where(valid[:, None], sampled, torch.as_tensor(float(fill), dtype=sampled.dtype, device=device))
    if not images.is_floating_point():
        info = torch.iinfo(images.dtype)
        sampled = sampled.round_().clamp_(info.min, info.max)
    return sampled


def _sample_masks(masks: torch.Tensor, grids: torch.Tensor, valid: torch.Tensor, fill_mask: int) -> torch.Tensor:
    """The masks sampled nearest at ``grids``, ``fill_mask`` where not ``valid`` (False
    for bool masks), in their dtype; fishcam.Error for masks or a fill that float32
    cannot carry exactly."""
    if masks.is_floating_point() or masks.is_complex():
        raise Error(f"masks: expected an integer or bool tensor, got {masks.dtype}")
    # float32 holds integers exactly up to 2^24: labels and instance ids.
    if masks.numel() and (int(masks.min()) < 0 or int(masks.max()) >= 2**24):
        raise Error("masks: values outside 0..2^24 cannot be sampled exactly")
    if masks.dtype == torch.bool:
        fill_mask = 0  # a bool mask is an instance's: no source, not in it
    else:
        info = torch.iinfo(masks.dtype)
        low, high = max(info.min, -(2**24)), min(info.max, 2**24)
        if not low <= fill_mask <= high:
            raise Error(f"fill_mask: {fill_mask} does not fit the masks' dtype {masks.dtype} ({low}..{high})")
    picked = torch.nn.functional.grid_sample(
        masks[:, None].float(), grids, mode="nearest", padding_mode="border", align_corners=True
    )[:, 0]
    return torch.where(valid, picked, torch.as_tensor(float(fill_mask), device=masks.device)).to(masks.dtype)


def collate(batch: typing.Sequence[typing.Any]) -> typing.Any:
    """torch's default collate, but fishcam.Camera objects (and other non-tensors the
    default cannot stack: names, change records) are gathered into lists."""
    if isinstance(batch[0], dict):
        return {key: collate([item[key] for item in batch]) for key in batch[0]}
    if isinstance(batch[0], (Camera, str)) or not isinstance(batch[0], (torch.Tensor, np.ndarray, int, float)):
        return list(batch)
    return torch.utils.data.default_collate(list(batch))
