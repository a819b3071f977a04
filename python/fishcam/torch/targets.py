"""The targets fishcam's transforms take beside torchvision's: DepthMap and Polygon
tv_tensors, instance masks, and the conversions between tensors and the numpy arrays the
library computes on."""

import contextvars
import typing

import torch
from torchvision import tv_tensors

from .. import Error
from .. import transforms as _transforms

Sample = typing.Any  # anything torchvision.transforms.v2 takes: a tensor, a tuple, a dict, ...
Params = dict[str, typing.Any]


def _tensor_of(
    cls: type[tv_tensors.TVTensor],
    data: typing.Any,
    dtype: typing.Optional[torch.dtype],
    device: typing.Optional[torch.device],
    requires_grad: typing.Optional[bool],
) -> torch.Tensor:
    """torch's tensor of ``data`` for a fishcam tv_tensor, or fishcam.Error naming the class."""
    try:
        return typing.cast(torch.Tensor, cls._to_tensor(data, dtype=dtype, device=device, requires_grad=requires_grad))
    except (TypeError, ValueError, RuntimeError, OverflowError) as error:
        raise Error(
            f"{cls.__name__}: not a tensor of numbers ({type(data).__name__}): "
            f"{str(error).splitlines()[0] if str(error) else type(error).__name__}"
        ) from None


class DepthMap(tv_tensors.TVTensor):
    """A depth map (HxW or 1xHxW float32): the range along each pixel's ray, or its
    z (the transform's ``depth_values``). fishcam's transforms sample it without
    blending and re-express its values in the moved camera; torchvision's own
    transforms do not know it and pass it through unchanged (a flip or crop after
    fishcam's transform would leave it behind)."""

    @classmethod
    def _wrap(cls, tensor: torch.Tensor) -> "DepthMap":
        return tensor.as_subclass(cls)

    def __new__(
        cls,
        data: typing.Any,
        *,
        dtype: typing.Optional[torch.dtype] = None,
        device: typing.Optional[torch.device] = None,
        requires_grad: typing.Optional[bool] = None,
    ) -> "DepthMap":
        return cls._wrap(_tensor_of(cls, data, dtype, device, requires_grad))


class Polygon(tv_tensors.TVTensor):
    """One closed polygon, (K, 2) float pixels x, y (pixel centres at integers), e.g.
    a WoodScape instance outline. fishcam's transforms map its vertices and subdivide
    its edges so that they follow the curved image within 0.5 px (K changes); put
    several in a list. torchvision's own transforms pass it through."""

    @classmethod
    def _wrap(cls, tensor: torch.Tensor) -> "Polygon":
        return tensor.as_subclass(cls)

    def __new__(
        cls,
        data: typing.Any,
        *,
        dtype: typing.Optional[torch.dtype] = None,
        device: typing.Optional[torch.device] = None,
        requires_grad: typing.Optional[bool] = None,
    ) -> "Polygon":
        tensor = _tensor_of(cls, data, dtype, device, requires_grad)
        if tensor.ndim != 2 or tensor.shape[-1] != 2:
            raise Error(f"Polygon: expected shape (K, 2), got {tuple(tensor.shape)}")
        return cls._wrap(tensor)


def _cpu(tensor: torch.Tensor, what: str) -> torch.Tensor:
    """A plain, detached view of a CPU tensor: a tv_tensor's own torch calls each go
    through its __torch_function__ (~10 us apiece, a tenth of a small sample's warp)."""
    plain = tensor if type(tensor) is torch.Tensor else tensor.as_subclass(torch.Tensor)
    if plain.device.type != "cpu":
        raise Error(f"{what}: fishcam runs on the CPU; got a tensor on {plain.device} (move it with .cpu())")
    return plain.detach()


def _numpy(tensor: torch.Tensor, what: str, expected: str) -> _transforms.Array:
    """A CPU tensor as numpy (a view), or fishcam.Error naming ``expected`` for a
    dtype numpy has not (bfloat16, complex32, float8, quantized...)."""
    tensor = _cpu(tensor, what).resolve_conj().resolve_neg()
    try:
        array: _transforms.Array = tensor.numpy()
    except (TypeError, RuntimeError):
        raise Error(f"{what}: expected {expected}, got dtype {tensor.dtype}") from None
    return array


_IMAGE_DTYPES = "dtype uint8, uint16 or float32 (float64 is taken as float32)"
_MASK_DTYPES = "an integer or bool dtype"


def _image_to_numpy(tensor: torch.Tensor, what: str) -> _transforms.Array:
    """CHW (or HW) tensor -> HWC numpy (a view; the warp copies if it must), refusing
    what the warp cannot take with the layout in the message."""
    tensor = _cpu(tensor, what)
    if tensor.ndim not in (2, 3):
        raise Error(f"{what}: expected CxHxW or HxW, got shape {tuple(tensor.shape)}")
    if tensor.dtype == torch.float64:
        tensor = tensor.float()
    array = _numpy(tensor, what, _IMAGE_DTYPES)
    return array.transpose(1, 2, 0) if array.ndim == 3 else array


def _numpy_to_image(array: _transforms.Array, like: torch.Tensor) -> torch.Tensor:
    # CHW as a view of the HWC result (as the dataset's own images are): no copy.
    out = torch.from_numpy(array)
    out = out.permute(2, 0, 1) if out.ndim == 3 else out
    out = out.to(like.dtype) if out.dtype != like.dtype else out
    return _wrapped_like(out, like)


def _wrapped_like(tensor: torch.Tensor, like: torch.Tensor) -> torch.Tensor:
    """``tensor`` as the type of ``like`` (tv_tensors.wrap; a plain tensor stays plain).
    Images, videos and masks carry no metadata: a cast, without wrap's guard against
    torch.compile (~10 us a call, per sample)."""
    if type(like) in (tv_tensors.Image, tv_tensors.Video, tv_tensors.Mask):
        return tensor.as_subclass(type(like))
    return tv_tensors.wrap(tensor, like=like) if isinstance(like, tv_tensors.TVTensor) else tensor


# The fill by target: a number (the images') or a dict keyed by tv_tensors.Image and/or tv_tensors.Mask.
Fill = _transforms.Fill

# The key under which a detection target ({"boxes", "labels", "masks"}, Mask R-CNN's)
# holds its instance masks; and the ids of the masks found under it in the sample
# being transformed (set by _FishcamTransform.forward for its make_params).
_INSTANCE_MASKS_KEY = "masks"
_instance_mask_ids: "contextvars.ContextVar[frozenset[int]]" = contextvars.ContextVar(
    "fishcam_instance_mask_ids", default=frozenset()
)


def _split_fill(fill: object, fill_mask: object) -> tuple[typing.Any, int]:
    """(the images' fill, the semantic masks' fill) of a torch transform's arguments."""
    return _transforms._split_fill(fill, fill_mask, tv_tensors.Image, tv_tensors.Mask)


def _masks_under_instance_keys(
    structure: typing.Any, inside: bool = False, found: typing.Optional[set[int]] = None
) -> set[int]:
    """The ids of the tv_tensors.Mask leaves of ``structure`` held under the key
    "masks" of a dict, at any depth (the sample's own or a target's)."""
    found = set() if found is None else found
    if isinstance(structure, tv_tensors.Mask):
        if inside:
            found.add(id(structure))
    elif isinstance(structure, typing.Mapping):
        for key, value in structure.items():
            _masks_under_instance_keys(value, inside or key == _INSTANCE_MASKS_KEY, found)
    elif isinstance(structure, (list, tuple)):
        for value in structure:
            _masks_under_instance_keys(value, inside, found)
    return found


def is_instance_mask(mask: torch.Tensor, under_masks_key: bool = False) -> bool:
    """Whether fishcam's torch transforms take ``mask`` for instance masks (0 / False
    where there is no source, whatever ``fill_mask`` says) rather than a semantic
    label map (``fill_mask``): a bool mask, an NxHxW mask with N >= 2, or any mask
    under the key "masks" of a dict in the sample (``under_masks_key``: a detection
    target, ``{"boxes", "labels", "masks"}``). HxW and 1xHxW masks of an integer
    dtype elsewhere are semantic."""
    return under_masks_key or mask.dtype == torch.bool or (mask.ndim == 3 and mask.shape[0] >= 2)


def _size_of(flat_inputs: list[typing.Any]) -> tuple[int, int]:
    """(width, height) of the sample's images, masks or depth maps (or plain tensors
    of 2 or more dimensions, taken for images), else of its boxes or keypoints."""
    for x in flat_inputs:
        if isinstance(x, (tv_tensors.Image, tv_tensors.Mask, DepthMap)) or (
            isinstance(x, torch.Tensor) and not isinstance(x, tv_tensors.TVTensor)
        ):
            if x.ndim < 2:
                if isinstance(x, tv_tensors.TVTensor):
                    raise Error(f"{type(x).__name__}: expected 2 or more dimensions, got shape {tuple(x.shape)}")
                continue  # a plain scalar or vector (a label, an id): not an image
            return int(x.shape[-1]), int(x.shape[-2])
        if isinstance(x, (tv_tensors.BoundingBoxes, tv_tensors.KeyPoints)):
            return int(x.canvas_size[1]), int(x.canvas_size[0])
    raise Error("nothing to size the change by: the sample has no image, mask, depth map, boxes or keypoints")
