"""The options every adapter of a transform shares -- the numpy transforms
(fishcam.transforms), the torchvision ones (fishcam.torch) and the albumentations
ones (fishcam.albumentations) -- defined once per kind of transform: a TypedDict
(``ViewpointOptions``, ``AffineOptions``: what mypy checks at a call), the defaults
(``VIEWPOINT_DEFAULTS``, ``AFFINE_DEFAULTS``) and one text per option. Each
constructor takes them as ``**options`` beside its own extras; its signature
(``inspect.signature``, ``help()``: ``takes_options``) and the arguments section of
its docstring (``docstring``) are made from these, never written out again. One dict
of options serves the three alike:

    options: fishcam.ViewpointOptions = {"preset": "train", "fill_mask": 255}
    fishcam.transforms.RandomViewpoint(camera, **options)
    fishcam.torch.RandomViewpoint(camera, **options)
    fishcam.albumentations.RandomViewpoint(camera, **options)
"""

import inspect
import sys
import textwrap
import types
import typing

from .fill import Fill

if sys.version_info >= (3, 11):
    from typing import Unpack
else:  # pragma: no cover - Python 3.9, 3.10
    from typing_extensions import Unpack

__all__ = [
    "ViewpointOptions",
    "AffineOptions",
    "VIEWPOINT_DEFAULTS",
    "AFFINE_DEFAULTS",
    "Unpack",
]


class ViewpointOptions(typing.TypedDict, total=False):
    """The options of RandomViewpoint, the same in the numpy, torch and albumentations
    transforms (each adds its own extras: numpy ``rng``, torch ``min_visibility`` and
    ``boxes``); any subset, the rest taking their defaults (VIEWPOINT_DEFAULTS)."""

    preset: typing.Optional[str]
    max_rotation_deg: typing.Optional[float]
    max_translation: typing.Optional[float]
    depth: str
    p: float
    fill: Fill
    fill_mask: int
    sampling: str
    depth_values: str


class AffineOptions(typing.TypedDict, total=False):
    """The options of RandomAffine (the paper's affine baseline), the same in the
    numpy, torch and albumentations transforms (each adds its own extras, as
    RandomViewpoint's); any subset, the rest taking their defaults (AFFINE_DEFAULTS)."""

    preset: typing.Optional[str]
    max_rotation_deg: typing.Optional[float]
    max_translation: typing.Optional[float]
    scale_range: typing.Optional[tuple[float, float]]
    p: float
    fill: Fill
    fill_mask: int


# The defaults, in the order of the fields above (the order of every signature).
VIEWPOINT_DEFAULTS: typing.Mapping[str, typing.Any] = types.MappingProxyType(
    {
        "preset": "train",
        "max_rotation_deg": None,
        "max_translation": None,
        "depth": "source-sphere",
        "p": 1.0,
        "fill": 0,
        "fill_mask": 0,
        "sampling": "grid",
        "depth_values": "range",
    }
)
AFFINE_DEFAULTS: typing.Mapping[str, typing.Any] = types.MappingProxyType(
    {
        "preset": "train",
        "max_rotation_deg": None,
        "max_translation": None,
        "scale_range": None,
        "p": 1.0,
        "fill": 0,
        "fill_mask": 0,
    }
)

# One text per option: the docstrings of the options types and of every constructor
# are made of these.
_P = (
    "probability of applying a change (else the identity, still recorded); the decision "
    "follows from the seed too, so a seed reproduces it. The albumentations transforms "
    "hand it to albumentations (its generator decides)."
)
_FILL = (
    "the value where the new view has no source: a number, the images' (one their dtype "
    "holds: an integer in range for integer images), or a dict by target, "
    '{"image": 0, "mask": 255} in the numpy and albumentations transforms, '
    "{tv_tensors.Image: 0, tv_tensors.Mask: 255} in the torch ones (either key may be "
    'left out; any other key, torchvision\'s "others" included, is refused).'
)
_FILL_MASK = (
    "the semantic masks' label there, e.g. the loss's ignore_index: an integer in "
    "0..65535 that fits the mask's dtype, or fill's mask key (given both ways, they must "
    "agree). Instance masks get 0 (False) whatever it says: bool masks, and those an "
    'adapter knows for instances (fishcam.transforms\' docstring, "Fill").'
)
VIEWPOINT_TEXTS: typing.Mapping[str, str] = types.MappingProxyType(
    {
        "preset": '"small", "medium", "large" or "train" (the paper\'s ranges; the default), '
        "or its fishcam.Preset; set aside when max_rotation_deg and max_translation are given.",
        "max_rotation_deg": "with max_translation (both or neither), the ranges instead of a "
        "preset: each rotation angle uniform in [-max, max] degrees, max in [0, 180].",
        "max_translation": "each translation component uniform in [-max, max], max >= 0, in "
        "the units of the depth prior: the unit sphere's, or the depth map's.",
        "depth": "where a pixel's scene point is assumed to be when the camera moves (or its "
        'fishcam.DepthSource): "source-sphere" (the default), "target-sphere", "infinity" '
        "(rotations only: the change's translation is dropped from the image, the returned "
        'camera and the record alike), or "map": at the sample\'s own depth map (numpy: '
        "depth_map=; torch: its fishcam.torch.DepthMap; albumentations: the depth target), "
        "in the units of the change's translation; exact, and pixels the source never saw "
        "get no source.",
        "p": _P,
        "fill": _FILL,
        "fill_mask": _FILL_MASK,
        "sampling": '"grid" (the default: maps interpolated from grid nodes, within 1/32 px '
        'of the per-pixel map, as fishcam augment) or "exact" (or its fishcam.Sampling).',
        "depth_values": 'what depth maps hold, "range" (along the ray; the default) or "z" '
        "(or its fishcam.DepthValues).",
    }
)
AFFINE_TEXTS: typing.Mapping[str, str] = types.MappingProxyType(
    {
        "preset": '"train" (the default; the paper\'s ranges: 30 deg, 0.3 of the image size, '
        'scale [0.5, 1.5]), "large" (the same), "medium" or "small" (2/3 and 1/3 of them), '
        "or its fishcam.Preset; set aside when the three ranges below are given.",
        "max_rotation_deg": "with max_translation and scale_range (all three or none), the "
        "ranges instead of a preset: the rotation about the image centre, uniform in "
        "[-max, max] degrees.",
        "max_translation": "the translation per axis, a fraction of the image size, uniform in [-max, max].",
        "scale_range": "(low, high): the isotropic scale, uniform in [low, high].",
        "p": _P,
        "fill": _FILL,
        "fill_mask": _FILL_MASK,
    }
)
# The extras of the numpy transforms.
RNG_TEXT = "a numpy Generator to draw seeds from (default: numpy's global generator)."

_Options = typing.TypeVar("_Options", ViewpointOptions, AffineOptions)
_F = typing.TypeVar("_F", bound=typing.Callable[..., typing.Any])


def checked(options: _Options, defaults: typing.Mapping[str, typing.Any], owner: str) -> _Options:
    """``options`` as given, after refusing a name that is not one of ``defaults``'
    as Python refuses an unknown keyword (TypeError; ``owner``: the class's name)."""
    for name in options:
        if name not in defaults:
            raise TypeError(f"{owner}.__init__() got an unexpected keyword argument '{name}'")
    return options


def resolved(options: _Options, defaults: typing.Mapping[str, typing.Any], owner: str) -> _Options:
    """Every option: those given (``checked``), the defaults for the rest."""
    return typing.cast(_Options, {**defaults, **checked(options, defaults, owner)})


def takes_options(options_type: type, defaults: typing.Mapping[str, typing.Any]) -> typing.Callable[[_F], _F]:
    """Decorates ``__init__(self, ..., *, extras, **options: Unpack[options_type])``:
    its ``__signature__`` (what inspect.signature and help() show of the class)
    lists the leading arguments, then each option, keyword-only, with its type and
    default, then the extras."""
    hints = typing.get_type_hints(options_type)

    def decorate(init: _F) -> _F:
        real = inspect.signature(init)
        given = [p for p in real.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
        shared = [
            inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=default, annotation=hints[name])
            for name, default in defaults.items()
        ]
        leading = [p for p in given if p.kind is not inspect.Parameter.KEYWORD_ONLY]
        extras = [p for p in given if p.kind is inspect.Parameter.KEYWORD_ONLY]
        setattr(init, "__signature__", real.replace(parameters=[*leading, *shared, *extras]))  # noqa: B010
        return init

    return decorate


def arguments(texts: typing.Mapping[str, str], heading: str = "Args:") -> str:
    """An "Args:" section (or another ``heading``): one entry per name, its text wrapped."""
    lines = [heading]
    for name, text in texts.items():
        lines += textwrap.wrap(f"{name}: {text}", width=88, initial_indent="    ", subsequent_indent="        ")
    return "\n".join(lines)


def docstring(intro: str, *sections: typing.Mapping[str, str], heading: str = "Args:") -> str:
    """A class docstring: ``intro`` (dedented), then one "Args:" section of the
    texts of ``sections`` in order (the leading arguments, the options, the extras)."""
    texts: dict[str, str] = {}
    for section in sections:
        texts.update(section)
    return inspect.cleandoc(intro) + "\n\n" + arguments(texts, heading)


ViewpointOptions.__doc__ = docstring(ViewpointOptions.__doc__ or "", VIEWPOINT_TEXTS, heading="Keys:")
AffineOptions.__doc__ = docstring(AffineOptions.__doc__ or "", AFFINE_TEXTS, heading="Keys:")
