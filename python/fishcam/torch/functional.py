"""The functional form of fishcam's v2 transforms, as torchvision's ``v2.functional``:
a drawn change applied to one input, dispatched by the input's type to the kernel
registered for it.

    change = fishcam.ViewpointChange(rotation_deg=(10, 0, -5), translation=(0.1, 0, 0))
    image = F.viewpoint(image, change, camera, depth="source-sphere", fill=0)
    mask = F.viewpoint(mask, change, camera, fill_mask=255)

``viewpoint`` and ``affine`` take an explicit change (a ``fishcam.ViewpointChange``,
an affine change from ``fishcam.transforms.RandomAffine.change_for``);
``apply_change`` takes a ``fishcam.transforms.SampleChange`` (what the transforms
draw: ``RandomViewpoint.draw``, ``sample_change``) and is what the transforms call
for every input of a sample. ``register_kernel(input_type)`` adds a kernel for a
type of one's own, as torchvision's ``register_kernel`` does for its functionals.
"""

import typing

import numpy as np
import torch
from torchvision import tv_tensors
from torchvision.transforms import v2

from .. import Camera, Error, ViewpointChange
from .. import transforms as _transforms
from .targets import (
    _MASK_DTYPES,
    DepthMap,
    Fill,
    Polygon,
    _cpu,
    _image_to_numpy,
    _numpy,
    _numpy_to_image,
    _split_fill,
    _wrapped_like,
    is_instance_mask,
)

__all__ = ["apply_change", "viewpoint", "affine", "register_kernel", "ChangeOptions"]


class ChangeOptions(typing.NamedTuple):
    """What a kernel needs of the transform besides the change: whether a mask is an
    instance mask (None: tell by is_instance_mask), the share of a box that must stay
    seen (min_visibility), and the instance masks whose tight boxes replace the boxes
    (boxes="from_masks"; None: each box from its own outline)."""

    instance: typing.Optional[bool] = None
    min_visibility: float = 0.0
    instance_masks: typing.Optional[torch.Tensor] = None


Kernel = typing.Callable[[typing.Any, _transforms.SampleChange, ChangeOptions], typing.Any]
_KERNELS: dict[type, Kernel] = {}
_K = typing.TypeVar("_K", bound=Kernel)


def register_kernel(input_type: type) -> typing.Callable[[_K], _K]:
    """Decorates ``kernel(inpt, change, options) -> output`` as the kernel of
    ``input_type`` (and its subclasses without a kernel of their own) for every
    fishcam transform and functional."""

    def register(kernel: _K) -> _K:
        _KERNELS[input_type] = kernel
        return kernel

    return register


def _kernel_for(input_type: type) -> Kernel:
    for cls in input_type.__mro__:
        if cls in _KERNELS:
            return _KERNELS[cls]
        if cls is tv_tensors.TVTensor:  # a tv_tensor of another library is not a plain tensor
            break
    raise Error(f"{input_type.__name__}: not a target fishcam's transforms know")


def apply_change(
    inpt: typing.Any, change: _transforms.SampleChange, options: typing.Optional[ChangeOptions] = None
) -> typing.Any:
    """``inpt`` under a drawn change, by the kernel of its type: images (CxHxW or
    BxCxHxW tensors, tv_tensors.Image), masks, boxes, keypoints, polygons, depth maps
    and cameras, as the transforms' docstrings say."""
    return _kernel_for(type(inpt))(inpt, change, options if options is not None else ChangeOptions())


# One functional's transform per set of options (each keeps its warps: a warp per
# camera costs milliseconds to build).
_VIEWPOINTS: dict[str, _transforms.RandomViewpoint] = {}


def viewpoint(
    inpt: typing.Any,
    change: ViewpointChange,
    camera: Camera,
    *,
    depth: str = "source-sphere",
    fill: Fill = 0,
    fill_mask: int = 0,
    sampling: str = "grid",
    depth_values: str = "range",
    depth_map: typing.Optional[torch.Tensor] = None,
    instance: typing.Optional[bool] = None,
) -> typing.Any:
    """``inpt`` (of the images of ``camera``) under the viewpoint ``change``, as
    fishcam.torch.RandomViewpoint applies its draws; the arguments as its own. With
    depth="map", ``depth_map`` (HxW float32) places the scene points."""
    if isinstance(fill, typing.Mapping):
        fill, fill_mask = _split_fill(fill, fill_mask)
    key = repr((depth, fill, fill_mask, sampling, depth_values))
    transform = _VIEWPOINTS.get(key)
    if transform is None:
        if len(_VIEWPOINTS) >= 16:
            _VIEWPOINTS.pop(next(iter(_VIEWPOINTS)))
        transform = _VIEWPOINTS[key] = _transforms.RandomViewpoint(
            depth=depth, fill=fill, fill_mask=fill_mask, sampling=sampling, depth_values=depth_values
        )
    plane = None if depth_map is None else _numpy(_cpu(depth_map, "depth_map"), "depth_map", "HxW float32")
    return apply_change(inpt, transform.sample_change(camera, change, depth_map=plane), ChangeOptions(instance))


def affine(
    inpt: typing.Any,
    change: typing.Any,
    size: tuple[int, int],
    *,
    fill: Fill = 0,
    fill_mask: int = 0,
    instance: typing.Optional[bool] = None,
) -> typing.Any:
    """``inpt`` (of images of ``size`` = (width, height)) under the affine ``change``
    (``fishcam.transforms.RandomAffine.change_for``), as fishcam.torch.RandomAffine
    applies its draws."""
    if isinstance(fill, typing.Mapping):
        fill, fill_mask = _split_fill(fill, fill_mask)
    transform = _transforms.RandomAffine(fill=fill, fill_mask=fill_mask)
    return apply_change(inpt, transform.sample_change(size, change), ChangeOptions(instance))


# ---------------------------------------------------------------- the kernels


@register_kernel(Camera)
def _camera(camera: Camera, change: _transforms.SampleChange, options: ChangeOptions) -> Camera:
    return change.camera(camera)


@register_kernel(torch.Tensor)
def _images(image: torch.Tensor, change: _transforms.SampleChange, options: ChangeOptions) -> torch.Tensor:
    if image.ndim == 4:  # a batch of images sharing the camera
        return torch.stack([_images(x, change, options) for x in image])
    return _numpy_to_image(change.image(_image_to_numpy(image, "image")), image)


register_kernel(tv_tensors.Image)(_images)
register_kernel(tv_tensors.Video)(_images)


def warped_masks(mask: torch.Tensor, change: _transforms.SampleChange, instance: bool) -> torch.Tensor:
    """HxW or NxHxW masks resampled (each plane on its own); where there is no
    source, 0 (False) for instance masks, else the semantic masks' fill."""
    tensor = _cpu(mask, "mask")
    if tensor.ndim == 2:
        return torch.from_numpy(change.mask(_numpy(tensor, "mask", _MASK_DTYPES), instance=instance))
    if tensor.ndim == 3 and instance and len(tensor):  # instance masks (N, H, W): 16 to a pass
        return torch.from_numpy(change.instance_masks(_numpy(tensor, "mask", _MASK_DTYPES), "mask"))
    if tensor.ndim == 3:  # a 1xHxW label map: each plane on its own
        planes = [
            change.mask(_numpy(plane, f"mask[{i}]", _MASK_DTYPES), f"mask[{i}]", instance)
            for i, plane in enumerate(tensor)
        ]
        return torch.from_numpy(np.stack(planes)) if planes else tensor.clone()
    raise Error(f"mask: expected HxW or NxHxW, got shape {tuple(tensor.shape)}")


@register_kernel(tv_tensors.Mask)
def _mask(mask: tv_tensors.Mask, change: _transforms.SampleChange, options: ChangeOptions) -> tv_tensors.Mask:
    instance = options.instance if options.instance is not None else is_instance_mask(mask)
    return typing.cast(tv_tensors.Mask, _wrapped_like(warped_masks(mask, change, instance), mask))


@register_kernel(tv_tensors.KeyPoints)
def _keypoints(
    points: tv_tensors.KeyPoints, change: _transforms.SampleChange, options: ChangeOptions
) -> tv_tensors.KeyPoints:
    mapped, _ = change.points(_cpu(points, "keypoints").reshape(-1, 2).double().numpy())
    return tv_tensors.wrap(torch.from_numpy(mapped).to(points.dtype).reshape(points.shape), like=points)


@register_kernel(Polygon)
def _polygon(polygon: Polygon, change: _transforms.SampleChange, options: ChangeOptions) -> Polygon:
    mapped = change.polygon(_cpu(polygon, "polygon").double().numpy())
    return typing.cast(Polygon, tv_tensors.wrap(torch.from_numpy(mapped).to(polygon.dtype), like=polygon))


@register_kernel(DepthMap)
def _depth_map(depth: DepthMap, change: _transforms.SampleChange, options: ChangeOptions) -> DepthMap:
    tensor = _cpu(depth, "depth map")
    flat = tensor.reshape(tensor.shape[-2:]) if tensor.ndim == 3 and tensor.shape[0] == 1 else tensor
    if flat.ndim != 2 or flat.dtype != torch.float32:
        raise Error(f"depth map: expected HxW or 1xHxW float32, got {tuple(tensor.shape)} {tensor.dtype}")
    out = torch.from_numpy(change.depth_map(flat.numpy())).reshape(tensor.shape)
    return typing.cast(DepthMap, tv_tensors.wrap(out, like=depth))


@register_kernel(tv_tensors.BoundingBoxes)
def _boxes(
    boxes: tv_tensors.BoundingBoxes, change: _transforms.SampleChange, options: ChangeOptions
) -> tv_tensors.BoundingBoxes:
    fmt = boxes.format
    if "ROTATED" in str(fmt).upper() or "XYXYXYXY" in str(fmt).upper():
        raise Error(f"boxes: rotated boxes ({fmt}) are not supported; use keypoints for their corners")
    xyxy = v2.functional.convert_bounding_box_format(
        boxes.as_subclass(torch.Tensor), old_format=fmt, new_format=tv_tensors.BoundingBoxFormat.XYXY
    )
    # Each box's own outline, densely transformed: its place and, in both modes, its
    # visibility (the share of the transformed box inside the image).
    mapped, seen = change.boxes(_cpu(xyxy, "boxes").double().numpy())
    out, visibility = torch.from_numpy(mapped), torch.from_numpy(seen)
    if options.instance_masks is not None:  # from_masks: the tight box of mask i (no-source pixels: in none)
        warped = warped_masks(options.instance_masks, change, instance=True)
        out = torch.zeros((len(warped), 4), dtype=torch.float64)
        for i, plane in enumerate(warped):
            ys, xs = torch.nonzero(plane, as_tuple=True)
            if len(xs):
                out[i] = torch.tensor([xs.min(), ys.min(), xs.max() + 1, ys.max() + 1], dtype=torch.float64)
            else:
                visibility[i] = 0  # the instance left the image
    # Boxes seen too little collapse to nothing: v2.SanitizeBoundingBoxes drops them.
    out[visibility < options.min_visibility] = 0
    out = v2.functional.convert_bounding_box_format(
        out.to(boxes.dtype), old_format=tv_tensors.BoundingBoxFormat.XYXY, new_format=fmt
    )
    return tv_tensors.wrap(out, like=boxes)
