"""fishcam: calibration-aware fisheye camera models and exact viewpoint augmentation.

The compute lives in C++ (fishcam._fishcam); this package adds the Python-side
conveniences. Every error is a ``fishcam.Error`` (a ``ValueError``) carrying the
library's one-line message. See docs/python.md.
"""

import functools as _functools
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


_F = _typing.TypeVar("_F", bound=_typing.Callable[..., _typing.Any])


def _require_initialised(obj: _typing.Any, name: str) -> None:
    """cls.__new__(cls) alone leaves the C++ object unmade: refused before a method or
    property reads it (it read garbage or crashed)."""
    if not _fishcam._initialised(obj):
        raise Error(
            f"{name}: an object made without __init__ (cls.__new__ alone): make it with its constructor, "
            "a reader or pickle"
        )


# How to make the objects of classes without a constructor (pybind11's TypeError
# "No constructor defined!" says nothing of it).
_MADE_BY = {"Camera": "fishcam.Camera.read(path) or fishcam.Camera.from_json(text)"}


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


def _first_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[0] if lines else ""


def _one_line_argument_errors(function: _F, name: str, bound: bool = False) -> _F:
    """pybind11 reports arguments of the wrong type as a multi-line TypeError, and
    the conversions of arguments raise TypeError or OverflowError (an integer past
    64 bits, a float past float64); fishcam's errors are one-line fishcam.Error
    naming the call."""
    # A method (not a constructor, whose name has no ".", nor __setstate__, which makes the object).
    initialised = bound and "." in name and not name.endswith(".__setstate__")

    @_functools.wraps(function)
    def call(*args: _typing.Any, **kwargs: _typing.Any) -> _typing.Any:
        if initialised and args:
            _require_initialised(args[0], name)
        try:
            return function(*args, **kwargs)
        except Error as e:
            if "\n" not in str(e):
                raise
            # The promise is one line: a name given with a line break is quoted raw in some messages.
            raise Error(str(e).replace("\r", "\\r").replace("\n", "\\n")) from None
        except (TypeError, OverflowError) as e:
            text = str(e)
            given = ", ".join(
                [type(a).__name__ for a in args[1 if bound else 0 :]]
                + [f"{k}={type(v).__name__}" for k, v in kwargs.items()]
            )
            if "incompatible function arguments" in text or "incompatible constructor arguments" in text:
                lines = [line.strip() for line in text.splitlines() if line.strip()]
                expected = next((line.split(". ", 1)[1] for line in lines if line[:1].isdigit() and ". " in line), "")
                raise Error(f"{name}: arguments of the wrong type or range ({given}); expected {expected}") from None
            if "No constructor defined" in text:
                made_by = _MADE_BY.get(name, "its static methods")
                raise Error(f"{name}: has no constructor; make one with {made_by}") from None
            raise Error(f"{name}: arguments of the wrong type or range ({given}): {_first_line(text)}") from None

    return _typing.cast(_F, call)


def _wrap_public_callables(cls: type) -> None:
    for attribute, value in list(vars(cls).items()):
        if attribute.startswith("_") and attribute not in ("__init__", "__call__", "__setstate__"):
            continue
        if isinstance(value, property) and value.fget is not None:
            getter = value.fget
            name = f"{cls.__name__}.{attribute}"

            def checked(self: _typing.Any, getter: _typing.Any = getter, name: str = name) -> _typing.Any:
                _require_initialised(self, name)
                return getter(self)

            setattr(cls, attribute, property(checked, value.fset, value.fdel, value.__doc__))
            continue
        static = isinstance(value, staticmethod)
        function = value.__func__ if static else value
        if not callable(function) or isinstance(value, property):
            continue
        wrapped = _one_line_argument_errors(
            function, f"{cls.__name__}.{attribute.replace('__init__', '')}".rstrip("."), bound=not static
        )
        setattr(cls, attribute, staticmethod(wrapped) if static else wrapped)


for _cls in (Camera, ViewpointWarp, ViewpointChange, _fishcam.ConfusionMatrix, _fishcam.AffineChange):
    _wrap_public_callables(_cls)
for _name, _function in list(vars(_fishcam).items()):
    if not _name.startswith("_") and type(_function).__name__ == "builtin_function_or_method":
        setattr(_fishcam, _name, _one_line_argument_errors(_function, _name))


def _restore(cls: type, state: _typing.Any) -> _typing.Any:
    """Unpickles an extension object: its state through the class's __setstate__."""
    restored = cls.__new__(cls)  # type: ignore[call-overload]
    restored.__setstate__(state)
    return restored


def _reduce(self: _typing.Any) -> tuple[_typing.Any, ...]:
    # One reduction for every protocol: pybind11's own needs protocol 2 (0 and 1
    # abort the interpreter in copyreg with "no registered base types").
    return (_restore, (type(self), self.__getstate__()))


for _pickled in (Camera, ViewpointWarp, ViewpointChange, _fishcam.AffineChange):
    _pickled.__reduce__ = _reduce  # type: ignore[method-assign]
# The names imported above, rebound to the wrapped functions (one-line errors).
derive_seed = _fishcam.derive_seed  # noqa: F811
random_change_in = _fishcam.random_change_in  # noqa: F811


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
