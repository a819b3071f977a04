"""The names users type for fishcam's options, as enums: accepted wherever the names
are (an enum member is its name, a ``str``), so ``depth=fishcam.DepthSource.MAP`` and
``depth="map"`` are the same argument. Each enum's values are the library's own list
of names (python/tests/test_options.py checks), so neither can drift from the other."""

import enum


class _Name(str, enum.Enum):
    """A member is its name: in messages, records and JSON alike."""

    def __str__(self) -> str:
        return str(self.value)


class DepthSource(_Name):
    """Where a source pixel's scene point lies when the camera moves (C++ DepthSource:
    a prior, or the sample's own depth map; docs/augmentation.md)."""

    SOURCE_SPHERE = "source-sphere"  # on the source camera's unit sphere (the paper)
    TARGET_SPHERE = "target-sphere"  # at distance 1 along the output ray (mrcal's)
    INFINITY = "infinity"  # at infinity: rotation only
    MAP = "map"  # at the sample's own depth map's value


class Sampling(_Name):
    """How the viewpoint warp resamples (C++ Sampling)."""

    GRID = "grid"  # maps interpolated from grid nodes, within 1/32 px of the per-pixel map
    EXACT = "exact"  # the per-pixel maps


class DepthValues(_Name):
    """What a depth map's values are (C++ DepthValues)."""

    RANGE = "range"  # along the pixel's ray
    Z = "z"  # along the optical axis


class Preset(_Name):
    """The ranges of the paper's viewpoint and affine changes (fishcam.presets())."""

    SMALL = "small"
    MEDIUM = "medium"
    LARGE = "large"
    TRAIN = "train"


class BoxMode(_Name):
    """How the torchvision transforms move BoundingBoxes (fishcam.torch.RandomViewpoint's boxes=)."""

    OUTLINE = "outline"  # each box from its own outline, densely transformed
    FROM_MASKS = "from_masks"  # the tight box of the instance mask of the same index


def plain(value: object) -> object:
    """An enum member as its name (a plain str); anything else as it is."""
    return value.value if isinstance(value, enum.Enum) else value
