"""What the transforms put where the moved view has no source: the ``fill``
argument (a number, or a dict by target) split into the images' and the semantic
masks' values, and the checks that a target's dtype can hold its fill ("Fill" in
fishcam.transforms' docstring)."""

import typing

import numpy as np

from .. import Error, _shown
from .checks import Array, _integer, _number

# What ``fill`` takes: a number (the images' fill) or a dict by target.
Fill = typing.Union[float, typing.Mapping[typing.Any, float]]
_LABEL_MAX = 65535  # the largest label the warp takes (uint16)


def _key_name(key: object) -> str:
    if isinstance(key, type):
        return ("tv_tensors." if key.__module__.startswith("torchvision.tv_tensors") else "") + key.__name__
    return repr(key)


def _split_fill(
    fill: object,
    fill_mask: object,
    image_key: object = "image",
    mask_key: object = "mask",
    finite: bool = True,
    label_range: typing.Optional[tuple[int, int]] = (0, _LABEL_MAX),
) -> tuple[typing.Any, int]:
    """(the images' fill, the semantic masks' fill) from ``fill`` (a number, or a
    dict with ``image_key`` and/or ``mask_key``) and ``fill_mask``; fishcam.Error,
    one line, for anything else: unknown keys (torchvision's "others" too: here a
    number covers the images only), both mask fills given and disagreeing, values
    that are not numbers (images; finite unless ``finite=False``) or integers in
    ``label_range`` (masks)."""
    mask_fill = _integer(fill_mask, "fill_mask")
    if isinstance(fill, typing.Mapping):
        names = {image_key: f"fill[{_key_name(image_key)}]", mask_key: f"fill[{_key_name(mask_key)}]"}
        expected = f"{_key_name(image_key)} and/or {_key_name(mask_key)}"
        for key in fill:
            if key not in names:
                why = " ('others' is ambiguous here: name the targets)" if key == "others" else ""
                raise Error(f"fill: unknown key {_key_name(key)}{why}; expected {expected}")
        image_fill = fill.get(image_key, 0)
        image_name = names[image_key]
        if mask_key in fill:
            given = _integer(fill[mask_key], names[mask_key])
            if mask_fill not in (0, given):
                raise Error(f"{names[mask_key]}={given} and fill_mask={mask_fill} disagree: give the masks' fill once")
            mask_fill, mask_name = given, names[mask_key]
        else:
            mask_name = "fill_mask"
    else:
        image_fill, image_name, mask_name = fill, "fill", "fill_mask"
    value = _number(image_fill, image_name)
    if finite and not np.isfinite(value):
        raise Error(f"{image_name}: must be finite")
    if label_range is not None and not label_range[0] <= mask_fill <= label_range[1]:
        raise Error(f"{mask_name}: {mask_fill} outside {label_range[0]}..{label_range[1]} (the labels a mask can hold)")
    return image_fill, mask_fill


def _check_image_fill(fill: float, dtype: "np.dtype[typing.Any]", what: str) -> None:
    """Refuses an images' fill that ``dtype`` cannot hold: for integer images an
    integer in the dtype's range (300 or -1 for uint8, 1.5 for anything; OpenCV
    would saturate, round, or wrap past 2^31), for float images one within the
    dtype's finite range (NaN passes)."""
    value = float(fill)
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        if not (value.is_integer() and info.min <= fill <= info.max):
            raise Error(
                f"{what}: the no-source fill {_shown(fill)} is not a value of dtype {dtype} "
                f"(integers {info.min}..{info.max})"
            )
    elif dtype.kind == "f" and np.isfinite(value) and abs(value) > float(np.finfo(dtype).max):
        raise Error(f"{what}: the no-source fill {_shown(fill)} is past the range of dtype {dtype}")


def _labels_for_warp(mask: Array, fill_mask: int, what: str = "mask") -> tuple[Array, typing.Callable[[Array], Array]]:
    """The mask as the warp takes it (uint8 or uint16: labels are sampled, never
    blended) and a function giving the warped mask its original dtype back. bool,
    int32 and int64 masks (torch's default for class ids) with values in 0..65535
    are taken as uint16 and returned in their dtype; other values are refused, and
    so is a fill the mask's dtype cannot hold (bool masks: only 0)."""
    if mask is None or not isinstance(mask, np.ndarray):
        return mask, lambda out: out
    if mask.dtype == np.bool_:
        if fill_mask != 0:
            raise Error(f"{what}: a bool mask's no-source fill is False, got {fill_mask}")
        return mask.view(np.uint8), lambda out: out.astype(np.bool_)
    if mask.dtype.kind not in "iu":
        raise Error(f"mask: expected an integer or bool label array, got dtype {mask.dtype}")
    info = np.iinfo(mask.dtype)
    low, high = max(int(info.min), 0), min(int(info.max), _LABEL_MAX)
    if not low <= fill_mask <= high:
        raise Error(f"{what}: the no-source fill {fill_mask} does not fit dtype {mask.dtype} ({low}..{high})")
    if mask.dtype in (np.uint8, np.uint16):
        return mask, lambda out: out
    if mask.size and (mask.min() < 0 or mask.max() > 65535):
        raise Error(f"mask: values {mask.min()}..{mask.max()} outside 0..65535 cannot be warped as labels")
    dtype = mask.dtype
    return mask.astype(np.uint16), lambda out: out.astype(dtype)
