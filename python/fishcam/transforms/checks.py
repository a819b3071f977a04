"""The argument checks of the transforms and their adapters: numbers, integers,
names, presets, probabilities, generators, sequences, image sizes, images and point
arrays, each refusing what it cannot take with one line of fishcam.Error naming the
argument."""

import typing

import numpy as np
import numpy.typing as npt

from .. import Error, _shown
from .. import options as _options

Array = npt.NDArray[typing.Any]
Record = dict[str, typing.Any]  # a change as the manifest records it
_MAX_SIDE = 2**31 - 1  # the largest image side (OpenCV's int)


def _number(value: object, what: str) -> float:
    """value as a float, or fishcam.Error naming the argument (an integer past float64 too)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise Error(f"{what}: expected a number, got {type(value).__name__}")
    try:
        return float(value)
    except OverflowError:
        raise Error(f"{what}: {_shown(value)} is out of range (past float64)") from None


def _integer(value: object, what: str) -> int:
    """value as an int, or fishcam.Error naming the argument."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise Error(f"{what}: expected an integer, got {type(value).__name__}")
    return int(value)


def _choice(value: object, choices: typing.Sequence[str], what: str, separator: str = " or ") -> str:
    """value (a name, or its enum member from fishcam.options: the plain name is
    returned), one of the names ``choices``, or fishcam.Error listing them."""
    value = _options.plain(value)
    if not isinstance(value, str) or value not in choices:
        raise Error(f"{what}: expected {separator.join(choices)}, got {_shown(value)}")
    return value


def _preset_name(preset: object, presets: typing.Mapping[str, typing.Any]) -> str:
    """preset (or its fishcam.Preset member) as a plain string (the library refuses
    unknown names), else fishcam.Error."""
    preset = _options.plain(preset)
    if not isinstance(preset, str):
        raise Error(f"preset: expected a name ({', '.join(presets)}), got {_shown(preset)}")
    return preset


def _check_p(p: float) -> None:
    if not (0 <= _number(p, "p") <= 1):
        raise Error(f"p: must be in [0, 1], got {p}")


def _check_rng(rng: object) -> None:
    if rng is not None and not isinstance(rng, np.random.Generator):
        raise Error(f"rng: expected a numpy.random.Generator or None, got {type(rng).__name__}")


def _sequence(value: object, what: str, expected: str = "a list of arrays") -> list[typing.Any]:
    """A list given as any iterable (images=, polygons=, ...) as a list, or fishcam.Error."""
    if (
        isinstance(value, (str, bytes, typing.Mapping))
        or not isinstance(value, typing.Iterable)
        or getattr(value, "ndim", 1) == 0
    ):  # a 0-dimensional array or tensor does not iterate
        raise Error(f"{what}: expected {expected}, got {type(value).__name__}")
    return list(value)


def _image_size(size: object) -> tuple[int, int]:
    """size = (width, height), each in 1.._MAX_SIDE, or fishcam.Error."""
    sides = [_integer(v, "size") for v in _sequence(size, "size", "(width, height)")]
    if len(sides) != 2 or not all(1 <= v <= _MAX_SIDE for v in sides):
        raise Error(f"size: expected (width, height), each in 1..{_MAX_SIDE}, got {_shown(size)}")
    return sides[0], sides[1]


def _image_array(image: object, what: str) -> Array:
    """image as the warp takes it (HxW or HxWxC, C <= 4), or fishcam.Error with a layout hint."""
    if not isinstance(image, np.ndarray):
        raise Error(f"{what}: expected a numpy array, got {type(image).__name__}")
    if image.ndim == 3 and image.shape[0] in (1, 3, 4) and image.shape[2] > 4:
        raise Error(
            f"{what}: shape {image.shape} looks channels-first (CHW); numpy images are HxWxC "
            "(np.moveaxis(image, 0, -1))"
        )
    if image.dtype == np.float64:
        raise Error(f"{what}: float64 images are not resampled; pass float32 (image.astype(np.float32))")
    if image.ndim not in (2, 3):
        raise Error(f"{what}: expected an HxW or HxWxC array, got shape {image.shape}")
    return image


def _points_array(points: object, what: str, k: int = 2) -> Array:
    """(N, k) float64 from any array-like of numbers, or fishcam.Error naming it."""
    try:
        array = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise Error(f"{what}: expected an array of numbers (float64)") from None
    if array.size == 0:
        return array.reshape(0, k)
    if array.ndim != 2 or array.shape[1] != k:
        raise Error(f"{what}: expected shape (N, {k}), got {array.shape}")
    return array


def _camera_matches(camera: typing.Any, size: tuple[int, int]) -> None:
    """fishcam.Error unless the camera's image is ``size`` (width, height): a transform
    before this one changed the images without the camera."""
    if (camera.width, camera.height) != size:
        raise Error(
            f"camera: {camera.width}x{camera.height} but the images are {size[0]}x{size[1]} "
            "(a transform before this one changed them without the camera)"
        )
