"""fishcam: calibration-aware fisheye camera models and exact viewpoint augmentation.

The compute lives in C++ (fishcam._fishcam); this package adds the Python-side
conveniences. Every error is a ``fishcam.Error`` (a ``ValueError``) carrying the
library's one-line message. See docs/python.md.
"""

import os as _os
import typing as _typing

import numpy as _np
import numpy.typing as _npt

from . import _fishcam
from ._fishcam import (  # noqa: F401  (re-exported API)
    AngleBin,
    Calibration,
    Camera,
    Comparison,
    Conversion,
    DisplacementStats,
    Error,
    FieldOfView,
    FitReport,
    ModelComparison,
    RigCalibration,
    ValidDomain,
    ViewpointChange,
    ViewpointWarp,
    __version__,
    calibrate,
    calibrate_rig,
    dataset_fidelity,
    dataset_model_fidelity,
    derive_seed,
    get_num_threads,
    random_change_in,
    read_corners,
    render,
    reprojection_error_map,
    woodscape_classes,
)

__all__ = [
    "AngleBin",
    "Calibration",
    "Camera",
    "RigCalibration",
    "calibrate",
    "calibrate_rig",
    "read_corners",
    "Comparison",
    "Conversion",
    "DisplacementStats",
    "FitReport",
    "ModelComparison",
    "ValidDomain",
    "FieldOfView",
    "Error",
    "ViewpointChange",
    "ViewpointWarp",
    "compare",
    "convert",
    "reprojection_error_map",
    "derive_seed",
    "get_num_threads",
    "random_change",
    "render",
    "woodscape_classes",
    "dataset_fidelity",
    "dataset_model_fidelity",
    "set_num_threads",
    "presets",
    "change_to_dict",
    "DepthSource",
    "Sampling",
    "DepthValues",
    "Preset",
    "BoxMode",
    "ViewpointOptions",
    "AffineOptions",
    "__version__",
]

DEPTH_PRIORS = tuple(_fishcam.depth_priors())  # the library's names


def _shown(value: object, limit: int = 40) -> str:
    """repr(value) on one line, shortened for a message (a 400-digit integer, an array...)."""
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else f"{text[: limit // 2]}... ({len(text)} characters)"


# The largest camera file the library reads (lib/io/src/document.hpp, kMaxDocumentBytes).
_MAX_CAMERA_FILE_BYTES = 16 << 20


def _check_regular_file(path: str, what: str) -> None:
    """fishcam.Error unless ``path`` is a regular file: a FIFO would block a reader, a
    device (/dev/zero) be read without end; refused in one line before any read."""
    if not _os.path.isfile(path):
        missing = not _os.path.exists(path)
        raise Error(f"{path}: {'missing' if missing else 'not a regular file'} (expected {what})")


def _read_regular_file(path: str, max_bytes: int, what: str) -> bytes:
    """The bytes of ``path``, a regular file (``_check_regular_file``) of at most ``max_bytes``."""
    _check_regular_file(path, what)
    try:
        with open(path, "rb") as f:
            data = f.read(max_bytes + 1)
    except OSError as e:
        raise Error(f"{path}: cannot be read ({e.strerror or type(e).__name__})") from None
    if len(data) > max_bytes:
        raise Error(f"{path}: larger than {max_bytes >> 20} MiB, not {what}")
    return data


def convert(
    camera: Camera,
    to: str,
    method: str = "lsq",
    max_angle: _typing.Optional[float] = None,
    fit_center: bool = False,
    fit_aspect: bool = False,
) -> Conversion:
    """Fits model ``to`` to ``camera`` as ``fishcam convert`` does (method "lsq" or
    "paper"; max_angle in degrees; fit_center / fit_aspect free the principal point
    and a_y, which a camera with tangential terms always has fitted).

    Returns a ``fishcam.Conversion``: ``camera`` (the fitted one), ``report`` (a
    ``FitReport``: rms_px, p99_px, max_px, the rays below 90 degrees, by_angle),
    ``widest_theta_deg``, ``non_radial_px`` (for a source that is not radially
    symmetric: the rms and max pixels no radial model gets below) and ``to_json()`` (what
    ``fishcam convert --json`` prints);
    it unpacks as ``camera, report = fishcam.convert(...)``.
    """
    return _fishcam.convert(camera, to, method, max_angle, fit_center, fit_aspect)


ModelArgument = _typing.Union[str, Camera, tuple[str, Camera]]


def compare(
    camera: Camera,
    models: _typing.Union[ModelArgument, _typing.Sequence[ModelArgument]] = (
        "equidistant",
        "stereographic",
        "kannala-brandt",
    ),
    method: str = "lsq",
    preset: str = "train",
    samples: int = 8,
    seed: int = 0,
    depth: str = "source-sphere",
    labels: _typing.Optional[_typing.Mapping[str, "_npt.NDArray[_typing.Any]"]] = None,
) -> Comparison:
    """What ``fishcam compare`` measures: a ``fishcam.Comparison`` (its ``models``, one
    ``ModelComparison`` each: displacement, by_angle, validity and label differences,
    the mean displacement per pixel as an array; ``to_json()``: the CLI's ``--json``).

    models: model names (fitted to ``camera`` as ``convert`` does; ``method="paper"``
    uses eqs. 13-14 for equidistant and stereographic), camera files, fishcam.Camera
    objects or ``(name, Camera)`` pairs. labels: ``{name: HxW uint8/uint16 array}``
    of the camera's size, compared under both augmentations (the CLI adds its
    rendered scene as "scene"). See docs/comparison.md.
    """
    listed: list[_typing.Any] = [models] if isinstance(models, (str, Camera)) else list(models)
    if isinstance(seed, bool) or not isinstance(seed, (int, _np.integer)) or seed < 0:
        raise Error(f"seed: expected a non-negative integer, got {_shown(seed)}")
    if isinstance(samples, bool) or not isinstance(samples, (int, _np.integer)):
        raise Error(f"samples: expected an integer, got {_shown(samples)}")
    return _fishcam.compare(camera, listed, method, preset, int(samples), int(seed), depth, dict(labels or {}))


def random_change(preset: str, seed: int) -> ViewpointChange:
    """The viewpoint change of the CLI's ``--preset PRESET --seed SEED``."""
    seed = _check_seed(seed)
    return _fishcam.random_change(preset, seed)


def _check_seed(seed: object) -> int:
    if isinstance(seed, (bool, _np.bool_)) or not isinstance(seed, (int, _np.integer)):
        raise Error(f"seed: expected an integer, got {type(seed).__name__}")
    value = int(seed)
    if not 0 <= value < 2**64:
        raise Error(f"seed: must be in [0, 2^64), got {value}")
    return value


def presets() -> dict[str, tuple[float, float]]:
    """The pose presets: name -> (max_rotation_deg, max_translation)."""
    return _fishcam.presets()


def set_num_threads(n: int) -> None:
    """The threads fishcam's compute uses.

    fishcam runs on the thread pool of the OpenCV it links (Debian's libopencv).
    Debian's ``cv2`` (python3-opencv) is that OpenCV, so this also sets its
    ``cv2.setNumThreads``; the opencv-python wheels from PyPI (which albumentations
    installs) carry an OpenCV and a pool of their own, which this leaves alone.
    """
    if isinstance(n, bool) or not isinstance(n, (int, _np.integer)):
        raise Error(f"set_num_threads: expected an integer, got {type(n).__name__}")
    _fishcam.set_num_threads(int(n))


def change_to_dict(
    change: ViewpointChange, seed: _typing.Optional[int] = None, depth: str = "source-sphere"
) -> dict[str, _typing.Any]:
    """A change as the manifest records it: method, seed, rotation_deg, translation, depth (JSON-able)."""
    return {
        "method": "viewpoint",
        "seed": seed,
        "rotation_deg": [float(x) for x in change.rotation_deg],
        "translation": [float(x) for x in change.translation],
        "depth": depth,
    }


# Submodules that need the names above (``fishcam.metrics`` without a separate import).
from . import metrics  # noqa: E402,F401
from .options import BoxMode, DepthSource, DepthValues, Preset, Sampling  # noqa: E402,F401
from .transforms.options import AffineOptions, ViewpointOptions  # noqa: E402,F401
