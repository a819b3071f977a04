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
    batch, _, height, width = images.shape
    cameras = (
        [cameras] * batch
        if isinstance(cameras, Camera)
        else _transforms._sequence(cameras, "cameras", "a fishcam.Camera or a sequence of them")
    )
    changes = _transforms._sequence(changes, "changes", "a sequence of fishcam.ViewpointChange")
    if len(cameras) != batch or len(changes) != batch:
        raise Error(f"cameras, changes: expected one per image ({batch}), got {len(cameras)} and {len(changes)}")
    if masks is not None and (not isinstance(masks, torch.Tensor) or tuple(masks.shape) != (batch, height, width)):
        raise Error(
            f"masks: expected a ({batch}, {height}, {width}) tensor, got "
            f"{getattr(masks, 'shape', type(masks).__name__)}"
        )
    if masks is not None and masks.device != images.device:
        raise Error(f"masks: on {masks.device} but the images are on {images.device}")
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
    device = images.device
    grids, valid = grids.to(device), valid.to(device)
    floating = images if images.is_floating_point() else images.float()
    sampled = torch.nn.functional.grid_sample(
        floating, grids.to(floating.dtype), mode="bilinear", padding_mode="border", align_corners=True
    )
    sampled = torch.where(
        valid[:, None], sampled, torch.as_tensor(float(image_fill), dtype=sampled.dtype, device=device)
    )
    if not images.is_floating_point():
        info = torch.iinfo(images.dtype)
        sampled = sampled.round_().clamp_(info.min, info.max)
    out_masks = None
    if masks is not None:
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
        out_masks = torch.where(valid, picked, torch.as_tensor(float(fill_mask), device=device)).to(masks.dtype)
    return WarpedBatch(sampled.to(images.dtype), out_masks, valid)


def collate(batch: typing.Sequence[typing.Any]) -> typing.Any:
    """torch's default collate, but fishcam.Camera objects (and other non-tensors the
    default cannot stack: names, change records) are gathered into lists."""
    if isinstance(batch[0], dict):
        return {key: collate([item[key] for item in batch]) for key in batch[0]}
    if isinstance(batch[0], (Camera, str)) or not isinstance(batch[0], (torch.Tensor, np.ndarray, int, float)):
        return list(batch)
    return torch.utils.data.default_collate(list(batch))
