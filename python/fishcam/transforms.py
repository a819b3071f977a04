"""Viewpoint augmentation (and the affine baseline, RandomAffine) as numpy transforms,
framework-free, with albumentations' call convention: one change per call, applied
to every target of the sample.

    t = RandomViewpoint(camera, preset="train")
    out = t(image=image, mask=labels)            # dict: image, mask, change
    out = t(image=image, mask=labels, seed=7)    # reproducible: the CLI's --preset train --seed 7
    out = t(image=image, depth_map=depth, keypoints=xy, boxes=xyxy, polygons=[p0, p1], camera=cam)

Targets (docs/python.md, "Targets"): images HxW or HxWxC (uint8, uint16, float32;
bilinear); masks HxW of any integer or bool dtype (nearest, dtype kept; where
there is no source, the label ``fill_mask``, but False for bool masks: "Fill"
below); depth maps HxW float32 (nearest, values re-expressed in the moved camera);
keypoints (N, 2) pixels with a visibility flag; boxes (N, 4) x_min, y_min, x_max,
y_max in pixel-edge coordinates (the tight box of the transformed outline) with the
visible fraction; polygons (K, 2) with edges subdivided to stay within 0.5 px of
the curved image; the camera (its pose moved by the change). Pixel coordinates put
pixel centres at integers (keypoints, polygons; as torchvision and albumentations
do), boxes span pixel edges (the whole image is 0, 0, W, H).

Fill (where the moved view has no source): ``fill`` is a number, the images' value
(one their dtype holds: an integer in range for uint8 and uint16 images, refused at
the call otherwise, rather than saturated or wrapped), or a dict by target,
``{"image": 0, "mask": 255}`` (either key may be left out; any other key is
refused). Semantic masks (HxW labels of an integer dtype) get the mask
value, ``fill_mask`` or ``fill["mask"]``, e.g. the loss's ``ignore_index``: an
integer in 0..65535 that fits the mask's dtype (a non-zero ``fill_mask`` and a
``fill["mask"]`` that disagree are refused). Instance masks get 0 (False) whatever
the mask value says, so that no-source pixels never join an instance: bool masks,
and wherever an adapter knows a mask is an instance's (torch: NxHxW with N >= 2 and
the "masks" of a detection target; albumentations: the ``masks`` target);
``SampleChange.mask(..., instance=True)`` asks for it.

Randomness: no generator lives inside the transform (or any C++ object). Without
``seed=``, one 64-bit seed is drawn per call from the ``rng`` given to the
constructor (a ``numpy.random.Generator``) or else from numpy's global generator,
which PyTorch reseeds in every DataLoader worker; the change then follows from
that seed exactly as the CLI's ``--seed`` does. ``draw(...)`` gives the
``SampleChange`` of one seed, which the torch and albumentations adapters apply to
their targets.
"""

import typing

import numpy as np
import numpy.typing as npt

from . import Camera, Error, ViewpointChange, ViewpointWarp, _check_seed, _fishcam, _shown, change_to_dict
from . import options as _options

__all__ = [
    "RandomViewpoint",
    "RandomAffine",
    "SampleChange",
    "POLYGON_TOLERANCE_PX",
    "BOX_MAX_POINTS",
    "affine_to_dict",
    "draw_seed",
]


Array = npt.NDArray[typing.Any]
Record = dict[str, typing.Any]
# (N, 2) source pixels -> (pixels (N, 2), visible (N,)): a change's forward direction.
Forward = typing.Callable[[Array], tuple[Array, Array]]


def draw_seed(rng: typing.Optional[np.random.Generator] = None) -> int:
    """One 64-bit seed from ``rng`` (a numpy Generator) or numpy's global generator."""
    if rng is not None:
        return int(rng.integers(0, 2**64, dtype=np.uint64))
    hi = int(np.random.randint(0, 2**32, dtype=np.uint64))
    lo = int(np.random.randint(0, 2**32, dtype=np.uint64))
    return (hi << 32) | lo


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


# What ``fill`` takes: a number (the images' fill) or a dict by target.
Fill = typing.Union[float, typing.Mapping[typing.Any, float]]
_LABEL_MAX = 65535  # the largest label the warp takes (uint16)
_MAX_SIDE = 2**31 - 1  # the largest image side (OpenCV's int)


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


# The largest distance (px) a subdivided polygon edge keeps from the true curve,
# and the most halvings one edge gets.
POLYGON_TOLERANCE_PX = 0.5
_MAX_SUBDIVISIONS = 16


class SampleChange:
    """One drawn change and what it does to each target of a sample (one draw for all).

    Made by ``RandomViewpoint.draw`` / ``RandomAffine.draw``; ``record`` is the
    change as the manifest records it. Methods take numpy arrays in the layouts of
    the module docstring and return new ones.
    """

    def __init__(
        self,
        record: Record,
        forward: Forward,
        resample: typing.Callable[..., dict[str, Array]],
        depth_map: typing.Callable[[Array], Array],
        camera: typing.Callable[[Camera], Camera],
        size: tuple[int, int],
        fill_mask: int,
        fill: float = 0,
    ) -> None:
        self.record = record
        self._fill = fill  # the images' no-source value
        self._fill_mask = fill_mask  # the semantic masks' no-source label
        self._forward = forward  # (N, 2) source pixels -> (pixels, visible)
        self._resample = resample  # (image, labels, label_fill) -> dict of the warp's outputs
        self._depth_map = depth_map  # (depth map) -> depth map
        self._camera = camera  # Camera -> Camera
        self.size = size  # (width, height) of the output

    def image(self, image: Array, what: str = "image") -> Array:
        """An image resampled bilinearly (dtype and channels kept); fishcam.Error for
        a fill the image's dtype cannot hold (``_check_image_fill``)."""
        image = _image_array(image, what)
        _check_image_fill(self._fill, image.dtype, what)
        return self._resample(image=image, labels=None, label_fill=0)["image"]

    def mask_fill(self, mask: Array, instance: bool = False) -> int:
        """The no-source value of ``mask``: 0 for an instance's mask (``instance``, or
        any bool mask), else the semantic masks' fill (``fill_mask``)."""
        return 0 if instance or (isinstance(mask, np.ndarray) and mask.dtype == np.bool_) else self._fill_mask

    def mask(self, mask: Array, what: str = "mask", instance: bool = False) -> Array:
        """A label or instance-id mask resampled by nearest neighbour (never blended; dtype
        kept); where there is no source, ``mask_fill(mask, instance)``: the semantic
        fill, or 0 (False) for an instance's mask (``instance=True``, or bool)."""
        if not isinstance(mask, np.ndarray):
            raise Error(f"{what}: expected a numpy array, got {type(mask).__name__}")
        if mask.ndim != 2:
            raise Error(f"{what}: expected an HxW array, got shape {mask.shape}")
        fill = self.mask_fill(mask, instance)
        labels, restore = _labels_for_warp(mask, fill, what)
        return restore(self._resample(image=None, labels=labels, label_fill=fill)["labels"])

    def image_and_mask(self, image: Array, mask: Array, instance: bool = False) -> tuple[Array, Array]:
        """Both in one pass (the maps are computed once): (image, mask); the mask's fill as ``mask()``'s."""
        image = _image_array(image, "image")
        _check_image_fill(self._fill, image.dtype, "image")
        if not isinstance(mask, np.ndarray) or mask.ndim != 2:
            raise Error(f"mask: expected an HxW numpy array, got {getattr(mask, 'shape', type(mask).__name__)}")
        fill = self.mask_fill(mask, instance)
        labels, restore = _labels_for_warp(mask, fill)
        out = self._resample(image=image, labels=labels, label_fill=fill)
        return out["image"], restore(out["labels"])

    def depth_map(self, depth_map: Array, what: str = "depth_map") -> Array:
        """A depth map (HxW float32) seen from the moved camera (see RandomViewpoint)."""
        if not isinstance(depth_map, np.ndarray) or depth_map.dtype != np.float32 or depth_map.ndim != 2:
            got = (
                f"{depth_map.dtype} {depth_map.shape}"
                if isinstance(depth_map, np.ndarray)
                else type(depth_map).__name__
            )
            raise Error(f"{what}: expected an HxW float32 array, got {got}")
        return self._depth_map(depth_map)

    def points(self, points: object, what: str = "keypoints") -> tuple[Array, Array]:
        """(N, 2) pixels -> (new pixels (N, 2) float64, visible (N,) bool). Exact; NaN
        where a point has no image; not visible where it left the view or is hidden."""
        return self._forward(_points_array(points, what))

    def boxes(self, boxes: object, what: str = "boxes", clip: bool = True) -> tuple[Array, Array]:
        """(N, 4) x_min, y_min, x_max, y_max (pixel edges) -> (boxes (N, 4), visible
        fraction (N,)): the tight box of the transformed box, clipped to the image
        unless ``clip=False``; the fraction of it inside the image (0, and an empty
        box, where nothing maps). A box is first clipped to the image plus one image
        size on each side (what lies past that never comes into view); its outline is
        then sampled adaptively, at most BOX_MAX_POINTS points a box (``_mapped_extents``),
        and where part of it has no image (past the camera's field of view), lines
        across the box's part of the image find the content that stays in view."""
        boxes = _points_array(boxes, what, 4)
        bad = np.flatnonzero(~((boxes[:, 2] >= boxes[:, 0]) & (boxes[:, 3] >= boxes[:, 1])))
        if len(bad):
            raise Error(f"{what}[{bad[0]}]: expected x_min <= x_max and y_min <= y_max, got {boxes[bad[0]].tolist()}")
        width, height = self.size
        # Pixel edges -> pixel centres at integers, within the image plus one image size.
        low, high = np.array([-width, -height]) - 0.5, np.array([2 * width, 2 * height]) - 0.5
        corners = np.clip(boxes.reshape(-1, 2, 2) - 0.5, low, high)
        # The outline leaves the interior lines' first samples of the budget.
        first = (4 + 2 * _BOX_INTERIOR_LINES) * (_BOX_FIRST_STEPS + 1)
        lo, hi, missed, used = _mapped_extents(
            self._forward, *_box_lines(corners), len(boxes), np.full(len(boxes), BOX_MAX_POINTS - first)
        )
        if missed.any():  # the content that stays in view: lines across the box's part of the image
            inner = np.clip(corners[missed], -0.5, np.array([width, height]) - 0.5)
            seen = (inner[:, 1] >= inner[:, 0]).all(axis=1)
            owners = np.flatnonzero(missed)[seen]
            starts, ends, owner = _box_lines(inner[seen], _BOX_INTERIOR_LINES)
            more_lo, more_hi, _, _ = _mapped_extents(
                self._forward, starts, ends, owners[owner], len(boxes), BOX_MAX_POINTS - used
            )
            lo, hi = np.fmin(lo, more_lo), np.fmax(hi, more_hi)
        found = np.isfinite(lo).all(axis=1)
        lo, hi = lo + 0.5, hi + 0.5
        size = np.array([width, height], dtype=np.float64)
        clipped_lo, clipped_hi = np.maximum(lo, 0), np.minimum(hi, size)
        area = np.prod(hi - lo, axis=1)
        inside = np.prod(np.maximum(clipped_hi - clipped_lo, 0), axis=1)
        point_inside = (clipped_hi >= clipped_lo).all(axis=1).astype(np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            visibility = np.where(area > 0, inside / np.where(area > 0, area, 1), point_inside)
        out = (
            np.concatenate([np.minimum(clipped_lo, size), np.maximum(clipped_hi, 0)], axis=1)
            if clip
            else np.concatenate([lo, hi], axis=1)
        )
        out[~found] = 0
        visibility[~found] = 0
        return out, visibility

    def polygon(self, polygon: object, what: str = "polygon") -> Array:
        """(K, 2) vertices of a closed polygon -> (M, 2) vertices of its image, the
        edges subdivided until each stays within POLYGON_TOLERANCE_PX of the true curve."""
        vertices = _points_array(polygon, what)
        if len(vertices) < 2:
            return self._forward(vertices)[0]
        edges_from = vertices
        edges_to = np.roll(vertices, -1, axis=0)
        return _subdivided(self._forward, edges_from, edges_to)

    def camera(self, camera: Camera) -> Camera:
        """The camera of the augmented sample."""
        return self._camera(camera)


# Box outlines (SampleChange.boxes): at most BOX_MAX_POINTS mapped points a box; an
# outline is sampled at first _BOX_FIRST_STEPS intervals a side, then each interval
# halved while the image of its midpoint lies farther than _BOX_TOLERANCE_PX from the
# chord (or the outline leaves the field of view in it), down to _BOX_MIN_STEP_PX.
BOX_MAX_POINTS = 4096
_BOX_FIRST_STEPS = 16
_BOX_TOLERANCE_PX = 0.05
_BOX_MIN_STEP_PX = 0.25
_BOX_INTERIOR_LINES = 15  # a direction, across a box whose outline partly has no image


def _box_lines(corners: Array, interior: int = 0) -> tuple[Array, Array, Array]:
    """The sides of boxes ((N, 2, 2): (x0, y0), (x1, y1)), and ``interior`` lines
    across each in both directions: (starts (L, 2), ends (L, 2), box of each (L,))."""
    (x0, y0), (x1, y1) = corners[:, 0].T, corners[:, 1].T
    starts = [np.stack(p, axis=1) for p in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))]
    ends = [np.stack(p, axis=1) for p in ((x1, y0), (x1, y1), (x0, y1), (x0, y0))]
    for k in range(1, interior + 1):
        x, y = x0 + (x1 - x0) * k / (interior + 1), y0 + (y1 - y0) * k / (interior + 1)
        starts += [np.stack((x0, y), axis=1), np.stack((x, y0), axis=1)]
        ends += [np.stack((x1, y), axis=1), np.stack((x, y1), axis=1)]
    owner = np.tile(np.arange(len(corners)), len(starts))
    return np.concatenate(starts), np.concatenate(ends), owner


def _mapped_extents(
    forward: Forward, starts: Array, ends: Array, owner: Array, count: int, budget: Array
) -> tuple[Array, Array, Array, Array]:
    """The bounding boxes (lo (count, 2), hi (count, 2); NaN where nothing maps) of
    the images of the straight lines starts[k] -> ends[k], line k belonging to box
    owner[k]; whether a sample of a box's lines had no image (count,); the points
    mapped a box (count,). Each line is sampled adaptively (the constants above): at
    first _BOX_FIRST_STEPS + 1 points, then at most ``budget[box]`` points a box in
    all: where that runs out, the intervals bending most are halved first."""
    lo = np.full((count, 2), np.inf)
    hi = np.full((count, 2), -np.inf)
    missed = np.zeros(count, dtype=bool)
    used = np.zeros(count, dtype=np.int64)

    def record(mapped: Array, boxes: Array) -> Array:
        finite: Array = np.isfinite(mapped).all(axis=1)
        np.minimum.at(lo, boxes[finite], mapped[finite])
        np.maximum.at(hi, boxes[finite], mapped[finite])
        missed[boxes[~finite]] = True
        np.add.at(used, boxes, 1)
        return finite

    steps = np.linspace(0.0, 1.0, _BOX_FIRST_STEPS + 1)[None, :, None]
    points = starts[:, None] + (ends - starts)[:, None] * steps  # (L, S + 1, 2)
    if len(points):
        mapped = forward(points.reshape(-1, 2))[0].reshape(points.shape)
        record(mapped.reshape(-1, 2), np.repeat(owner, points.shape[1]))
    else:
        mapped = points
    a, b = points[:, :-1].reshape(-1, 2), points[:, 1:].reshape(-1, 2)
    fa, fb = mapped[:, :-1].reshape(-1, 2), mapped[:, 1:].reshape(-1, 2)
    box = np.repeat(owner, _BOX_FIRST_STEPS)
    priority = np.full(len(a), np.inf)
    while len(a):
        # Halve what is long enough, within each box's budget, the most bent first.
        keep = np.flatnonzero(np.hypot(*(b - a).T) >= 2 * _BOX_MIN_STEP_PX)
        order = keep[np.lexsort((-priority[keep], box[keep]))]
        first = np.searchsorted(box[order], box[order], side="left")
        order = order[np.arange(len(order)) - first < (budget - used)[box[order]]]
        if len(order) == 0:
            break
        a, b, fa, fb, box = a[order], b[order], fa[order], fb[order], box[order]
        m = (a + b) / 2
        fm = forward(m)[0]
        finite_m = record(fm, box)
        finite_a, finite_b = np.isfinite(fa).all(axis=1), np.isfinite(fb).all(axis=1)
        with np.errstate(invalid="ignore"):
            bend = np.hypot(*(fm - (fa + fb) / 2).T)
        # Where the line leaves (or enters) the field of view: halved down to the finest step.
        edge = (finite_a != finite_b) | (finite_a & finite_b & ~finite_m) | (~finite_a & ~finite_b & finite_m)
        split = edge | (finite_a & finite_b & finite_m & (bend > _BOX_TOLERANCE_PX))
        level = np.where(edge, np.inf, np.nan_to_num(bend))[split]
        a, b = np.concatenate([a[split], m[split]]), np.concatenate([m[split], b[split]])
        fa, fb = np.concatenate([fa[split], fm[split]]), np.concatenate([fm[split], fb[split]])
        box = np.concatenate([box[split], box[split]])
        priority = np.concatenate([level, level])
    lo[~np.isfinite(lo).all(axis=1)] = np.nan
    hi[~np.isfinite(hi).all(axis=1)] = np.nan
    return lo, hi, missed, used


def _subdivided(forward: Forward, starts: Array, ends: Array) -> Array:
    """The images of the closed chain of edges starts[i] -> ends[i], each edge halved
    until the image of its midpoint lies within POLYGON_TOLERANCE_PX of the chord
    between its ends' images (a curve bending less than that in between)."""
    mapped_starts, _ = forward(starts)
    pieces = []
    for a, b, fa in zip(starts, ends, mapped_starts):
        # Depth-first on one edge, in order: the stack holds (a, b, f(a), f(b), depth).
        fb = forward(b[None])[0][0]
        out = [fa]
        stack = [(a, b, fa, fb, 0)]
        while stack:
            p, q, fp, fq, depth = stack.pop()
            m = (p + q) / 2
            fm = forward(m[None])[0][0]
            chord = (fp + fq) / 2
            bent = not np.all(np.isfinite(fm)) or np.linalg.norm(fm - chord) > POLYGON_TOLERANCE_PX / 2
            if bent and depth < _MAX_SUBDIVISIONS and np.all(np.isfinite(fp)) and np.all(np.isfinite(fq)):
                stack.append((m, q, fm, fq, depth + 1))
                stack.append((p, m, fp, fm, depth + 1))
            else:
                out.append(fq)
        pieces.append(np.array(out[:-1]))  # the end is the next edge's start
    return np.concatenate(pieces) if pieces else np.zeros((0, 2))


def _applies(p: float, seed: int) -> bool:
    """Whether a transform with probability p changes the sample of this seed: the
    decision follows from the seed too, so seed= reproduces it."""
    return p >= 1 or np.random.default_rng(seed).random() < p


class _WarpCache:
    """One ViewpointWarp per distinct calibration (intrinsics + size): building one
    unprojects every pixel, so it is kept, not rebuilt per sample. Keyed by
    Camera.parameters_key (microseconds; to_json() cost more than a warp)."""

    def __init__(self, limit: int = 64) -> None:
        self._warps: dict[bytes, ViewpointWarp] = {}
        self._warps = {}
        self._limit = limit

    def get(self, camera: Camera) -> ViewpointWarp:
        key = camera.parameters_key(with_pose=False)  # a warp depends on the intrinsics and size only
        warp = self._warps.get(key)
        if warp is None:
            if len(self._warps) >= self._limit:
                self._warps.pop(next(iter(self._warps)))
            warp = ViewpointWarp(camera)
            self._warps[key] = warp
        return warp

    def __getstate__(self) -> dict[str, int]:
        return {"limit": self._limit}  # warps are rebuilt on demand after unpickling

    def __setstate__(self, state: dict[str, int]) -> None:
        self._warps = {}
        self._limit = state["limit"]


class RandomViewpoint:
    """A random viewpoint change per call (the paper's eq. 7), applied exactly.

    camera: the fishcam.Camera of the images (or None: then every call passes camera=).
    preset: "small", "medium", "large" or "train"; or give max_rotation_deg and
        max_translation instead (uniform per axis in [-max, max]).
    depth: the depth prior, "source-sphere" (default), "target-sphere" or "infinity":
        where a pixel's scene point is assumed to be when the camera moves ("infinity"
        sees rotations only: the change's translation is dropped, from the image, the
        returned camera and the record alike); or "map":
        at the sample's own depth map (``depth_map=``, in the units of the change's
        translation; exact, and pixels the source never saw get no source).
    p: probability of applying a change (else the identity, still reported).
    fill: where the new view has no source: the images' value (a number), or a dict
        by target, ``{"image": 0, "mask": 255}``.
    fill_mask: the semantic masks' label there (an integer in 0..65535 that fits the
        mask's dtype; or ``fill["mask"]``). bool masks get False whatever it says
        (the module docstring, "Fill").
    rng: a numpy Generator to draw seeds from (default: numpy's global generator).
    sampling: "grid" (default: maps interpolated from grid nodes, within 1/32 px of
        the per-pixel map, as ``fishcam augment``) or "exact".
    depth_values: what depth maps hold, "range" (along the ray; default) or "z".
    """

    def __init__(
        self,
        camera: typing.Optional[Camera] = None,
        preset: typing.Optional[str] = "train",
        max_rotation_deg: typing.Optional[float] = None,
        max_translation: typing.Optional[float] = None,
        depth: str = "source-sphere",
        p: float = 1.0,
        fill: Fill = 0,
        fill_mask: int = 0,
        rng: typing.Optional[np.random.Generator] = None,
        sampling: str = "grid",
        depth_values: str = "range",
    ) -> None:
        sampling = _choice(sampling, _fishcam.sampling_names(), "sampling")
        depth_values = _choice(depth_values, _fishcam.depth_values_names(), "depth_values")
        if camera is not None and not isinstance(camera, Camera):
            raise Error(f"camera: expected a fishcam.Camera, got {type(camera).__name__}")
        if (max_rotation_deg is None) != (max_translation is None):
            raise Error("max_rotation_deg and max_translation go together")
        if max_rotation_deg is not None:
            preset = None
            rotation = _number(max_rotation_deg, "max_rotation_deg")
            if not (np.isfinite(rotation) and 0 <= rotation <= 180):
                raise Error(f"max_rotation_deg: must be in [0, 180], got {max_rotation_deg}")
            translation = _number(max_translation, "max_translation")
            if not (np.isfinite(translation) and translation >= 0):
                raise Error(f"max_translation: must be finite and >= 0, got {max_translation}")
        else:
            preset = _preset_name(preset, _fishcam.presets())
            _fishcam.check_preset(preset)
        depth = _choice(depth, _fishcam.depth_priors_and_map(), "depth", ", ")
        _check_p(p)
        _check_rng(rng)
        self.fill, self.fill_mask = _split_fill(fill, fill_mask)  # the images', the semantic masks'
        self.camera = camera
        self.preset = preset
        self.max_rotation_deg = max_rotation_deg
        self.max_translation = max_translation
        self.depth = depth
        self.p = float(p)
        self.rng = rng
        self.sampling = sampling
        self.depth_values = depth_values
        self._warps = _WarpCache()

    def change_for(self, seed: int) -> ViewpointChange:
        """The change this transform applies for ``seed`` (what the CLI's --seed gives)."""
        seed = _check_seed(seed)
        if self.preset is not None:
            return _fishcam.random_change(self.preset, seed)
        assert self.max_rotation_deg is not None and self.max_translation is not None
        return _fishcam.random_change_in(self.max_rotation_deg, self.max_translation, seed)

    def draw(
        self,
        camera: typing.Optional[Camera] = None,
        seed: typing.Optional[int] = None,
        depth_map: typing.Optional[Array] = None,
    ) -> SampleChange:
        """The SampleChange of one call: the change of ``seed`` (drawn when None) for
        images of ``camera`` (default: the constructor's); with depth="map", the
        sample's depth map (HxW float32) places every pixel's scene point."""
        camera = camera if camera is not None else self.camera
        if camera is None:
            raise Error("camera: none given (pass camera= to the constructor or the call)")
        if not isinstance(camera, Camera):
            raise Error(f"camera: expected a fishcam.Camera, got {type(camera).__name__}")
        if seed is None:
            seed = draw_seed(self.rng)
        seed = _check_seed(seed)
        change = self.change_for(seed) if _applies(self.p, seed) else _fishcam.ViewpointChange()
        return self.sample_change(camera, change, seed, depth_map)

    def sample_change(
        self,
        camera: Camera,
        change: ViewpointChange,
        seed: typing.Optional[int] = None,
        depth_map: typing.Optional[Array] = None,
    ) -> SampleChange:
        """The SampleChange of a given ``change`` for images of ``camera``, under this
        transform's depth, fill and sampling (``seed``: what the record says; the
        functional API, fishcam.torch.functional, comes here)."""
        if not isinstance(camera, Camera):
            raise Error(f"camera: expected a fishcam.Camera, got {type(camera).__name__}")
        if not isinstance(change, ViewpointChange):
            raise Error(f"change: expected a fishcam.ViewpointChange, got {type(change).__name__}")
        if self.depth == "infinity":
            # The prior at infinity sees no translation: the image gets the rotation
            # alone, and so do the returned camera and the record (what the image got).
            change = ViewpointChange(rotation_deg=change.rotation_deg.ravel(), translation=(0.0, 0.0, 0.0))
        warp = self._warps.get(camera)
        if self.depth == "map":
            if depth_map is None:
                raise Error("depth='map' needs the sample's depth map (depth_map=, HxW float32)")
            if not isinstance(depth_map, np.ndarray) or depth_map.dtype != np.float32 or depth_map.ndim != 2:
                got = (
                    f"{depth_map.dtype} {depth_map.shape}"
                    if isinstance(depth_map, np.ndarray)
                    else type(depth_map).__name__
                )
                raise Error(f"depth_map: expected an HxW float32 array, got {got}")
        maps_depth = depth_map if self.depth == "map" else None

        def resample(
            image: typing.Optional[Array], labels: typing.Optional[Array], label_fill: int
        ) -> dict[str, Array]:
            return warp.warp(
                image=image,
                labels=labels,
                change=change,
                depth=self.depth,
                fill=self.fill,
                label_fill=label_fill,
                sampling=self.sampling,
                depth_map=maps_depth,
                depth_values=self.depth_values,
            )

        return SampleChange(
            record=change_to_dict(change, seed, self.depth),
            forward=lambda points: warp.forward(
                points, change, self.depth, depth_map=maps_depth, depth_values=self.depth_values
            ),
            resample=resample,
            depth_map=lambda depth_map: warp.warp_depth(depth_map, change, self.depth, self.depth_values),
            camera=lambda c: c.augmented(change),
            size=(camera.width, camera.height),
            fill_mask=self.fill_mask,
            fill=self.fill,
        )

    def __call__(
        self,
        image: typing.Optional[Array] = None,
        mask: typing.Optional[Array] = None,
        camera: typing.Optional[Camera] = None,
        seed: typing.Optional[int] = None,
        **targets: typing.Any,
    ) -> dict[str, typing.Any]:
        """One change for every target given (module docstring); a dict with the same
        keys, ``change`` (the record) and the visibility of keypoints and boxes."""
        # The augmented camera is returned for a camera given with the sample.
        return _apply(self.draw(camera, seed, targets.get("depth_map")), image, mask, camera, targets)

    def __repr__(self) -> str:
        what = (
            f"preset={self.preset!r}"
            if self.preset is not None
            else f"max_rotation_deg={self.max_rotation_deg}, max_translation={self.max_translation}"
        )
        return (
            f"RandomViewpoint({what}, depth={self.depth!r}, p={self.p}, fill={self.fill}, "
            f"fill_mask={self.fill_mask}, sampling={self.sampling!r}, depth_values={self.depth_values!r})"
        )


_TARGETS = ("images", "depth_map", "keypoints", "boxes", "polygons")


def _apply(
    sample_change: SampleChange,
    image: typing.Optional[Array],
    mask: typing.Optional[Array],
    camera: typing.Optional[Camera],
    targets: dict[str, typing.Any],
) -> dict[str, typing.Any]:
    """The numpy transforms' call: every given target under one SampleChange; a dict
    with the same keys, plus ``change`` (the record) and, for keypoints and boxes,
    ``keypoints_visible`` and ``boxes_visibility``."""
    unknown = sorted(set(targets) - set(_TARGETS))
    if unknown:
        raise Error(f"unknown target {unknown[0]!r} (expected image, mask, camera, {', '.join(_TARGETS)})")
    if image is None and mask is None and not any(v is not None for v in targets.values()):
        raise Error("nothing to transform: pass image= and/or mask= (or another target)")
    out: dict[str, typing.Any] = {"change": sample_change.record}
    if image is not None and mask is not None:
        out["image"], out["mask"] = sample_change.image_and_mask(image, mask)
    elif image is not None:
        out["image"] = sample_change.image(image)
    elif mask is not None:
        out["mask"] = sample_change.mask(mask)
    if targets.get("images") is not None:
        out["images"] = [
            sample_change.image(x, f"images[{i}]") for i, x in enumerate(_sequence(targets["images"], "images"))
        ]
    if targets.get("depth_map") is not None:
        out["depth_map"] = sample_change.depth_map(targets["depth_map"])
    if targets.get("keypoints") is not None:
        out["keypoints"], out["keypoints_visible"] = sample_change.points(targets["keypoints"])
    if targets.get("boxes") is not None:
        out["boxes"], out["boxes_visibility"] = sample_change.boxes(targets["boxes"])
    if targets.get("polygons") is not None:
        out["polygons"] = [
            sample_change.polygon(x, f"polygons[{i}]") for i, x in enumerate(_sequence(targets["polygons"], "polygons"))
        ]
    if camera is not None:
        out["camera"] = sample_change.camera(camera)
    return out


class RandomAffine:
    """The paper's affine baseline (§V.C.2): rotation about the image centre,
    translation, isotropic scale; no camera model (``camera=`` is accepted and
    ignored, so it can stand where RandomViewpoint does).

    preset: "train" (default; the paper's ranges: 30 deg, 0.3 of the image size,
        scale [0.5, 1.5]), "large" (the same), "medium" and "small" (2/3 and 1/3 of
        them); or give max_rotation_deg, max_translation and scale_range=(lo, hi).
    p, fill, fill_mask, rng: as RandomViewpoint. Resampled as RandomViewpoint does
    (bilinear images, nearest labels, the fills where there is no source); the same
    seed gives the same change as ``fishcam augment --method affine --seed``.
    """

    def __init__(
        self,
        preset: typing.Optional[str] = "train",
        max_rotation_deg: typing.Optional[float] = None,
        max_translation: typing.Optional[float] = None,
        scale_range: typing.Optional[tuple[float, float]] = None,
        p: float = 1.0,
        fill: Fill = 0,
        fill_mask: int = 0,
        rng: typing.Optional[np.random.Generator] = None,
    ) -> None:
        custom = (max_rotation_deg, max_translation, scale_range)
        if any(v is not None for v in custom) and not all(v is not None for v in custom):
            raise Error("max_rotation_deg, max_translation and scale_range go together")
        self.scale_range: typing.Optional[tuple[float, float]] = None
        if max_rotation_deg is not None:
            preset = None
            scales = [_number(v, "scale_range") for v in _sequence(scale_range, "scale_range", "(low, high)")]
            if len(scales) != 2:
                raise Error(f"scale_range: expected (low, high), got {_shown(scale_range)}")
            low, high = scales
            # The library checks the ranges (one message for every binding).
            _fishcam.random_affine_in(
                _number(max_rotation_deg, "max_rotation_deg"), _number(max_translation, "max_translation"), low, high, 0
            )
            self.scale_range = (low, high)
        elif (preset := _preset_name(preset, _fishcam.affine_presets())) not in _fishcam.affine_presets():
            _fishcam.random_affine(preset, 0)  # raises naming the presets
        _check_p(p)
        _check_rng(rng)
        self.fill, self.fill_mask = _split_fill(fill, fill_mask)  # the images', the semantic masks'
        self.preset = preset
        self.max_rotation_deg = max_rotation_deg
        self.max_translation = max_translation
        self.p = float(p)
        self.rng = rng

    def change_for(self, seed: int) -> _fishcam.AffineChange:
        """The change this transform applies for ``seed`` (what the CLI's --seed gives)."""
        seed = _check_seed(seed)
        if self.preset is not None:
            return _fishcam.random_affine(self.preset, seed)
        assert self.max_rotation_deg is not None and self.max_translation is not None and self.scale_range
        return _fishcam.random_affine_in(self.max_rotation_deg, self.max_translation, *self.scale_range, seed)

    def draw(self, size: tuple[int, int], seed: typing.Optional[int] = None) -> SampleChange:
        """The SampleChange of one call for images of ``size`` = (width, height)."""
        sides = [_integer(v, "size") for v in _sequence(size, "size", "(width, height)")]
        if len(sides) != 2 or not all(1 <= v <= _MAX_SIDE for v in sides):
            raise Error(f"size: expected (width, height), each in 1..{_MAX_SIDE}, got {_shown(size)}")
        width, height = sides
        if seed is None:
            seed = draw_seed(self.rng)
        seed = _check_seed(seed)
        change = self.change_for(seed) if _applies(self.p, seed) else _fishcam.AffineChange()
        return self.sample_change((width, height), change, seed)

    def sample_change(
        self, size: tuple[int, int], change: _fishcam.AffineChange, seed: typing.Optional[int] = None
    ) -> SampleChange:
        """The SampleChange of a given ``change`` for images of ``size`` = (width,
        height), under this transform's fill (``seed``: what the record says)."""
        sides = [_integer(v, "size") for v in _sequence(size, "size", "(width, height)")]
        if len(sides) != 2 or not all(1 <= v <= _MAX_SIDE for v in sides):
            raise Error(f"size: expected (width, height), each in 1..{_MAX_SIDE}, got {_shown(size)}")
        width, height = sides
        if not isinstance(change, _fishcam.AffineChange):
            raise Error(f"change: expected a fishcam AffineChange, got {type(change).__name__}")

        def resample(
            image: typing.Optional[Array], labels: typing.Optional[Array], label_fill: int
        ) -> dict[str, Array]:
            given = image if image is not None else labels
            assert given is not None
            if given.shape[:2] != (height, width):
                raise Error(
                    f"{'image' if image is not None else 'mask'}: is {given.shape[1]}x{given.shape[0]} "
                    f"but the sample is {width}x{height}"
                )
            return _fishcam.affine_warp(
                image=image, labels=labels, change=change, fill=self.fill, label_fill=label_fill
            )

        def depth_map(values: Array) -> Array:
            if values.shape != (height, width):
                raise Error(f"depth_map: is {values.shape[1]}x{values.shape[0]} but the sample is {width}x{height}")
            return _fishcam.affine_warp_depth(values, change)

        return SampleChange(
            record=affine_to_dict(change, seed),
            forward=lambda points: _fishcam.affine_forward(points, change, width, height),
            resample=resample,
            depth_map=depth_map,
            camera=lambda c: c,  # no camera model: the camera is passed on as it is
            size=(width, height),
            fill_mask=self.fill_mask,
            fill=self.fill,
        )

    def __call__(
        self,
        image: typing.Optional[Array] = None,
        mask: typing.Optional[Array] = None,
        camera: typing.Optional[Camera] = None,
        seed: typing.Optional[int] = None,
        **targets: typing.Any,
    ) -> dict[str, typing.Any]:
        """As RandomViewpoint's; ``camera`` is passed on unchanged (the baseline has no
        camera model), depth maps keep their values (sampled as masks)."""
        given = next((x for x in (image, mask, targets.get("depth_map")) if x is not None), None)
        if given is None and targets.get("images") is not None:
            given = next(iter(_sequence(targets["images"], "images")), None)
        if given is None:
            raise Error("nothing to transform: pass image= and/or mask= (or images=, depth_map=)")
        if not isinstance(given, np.ndarray) or given.ndim < 2:
            raise Error(f"image: expected an HxW or HxWxC numpy array, got {type(given).__name__}")
        return _apply(self.draw((given.shape[1], given.shape[0]), seed), image, mask, camera, targets)

    def __repr__(self) -> str:
        what = (
            f"preset={self.preset!r}"
            if self.preset is not None
            else f"max_rotation_deg={self.max_rotation_deg}, max_translation={self.max_translation}, "
            f"scale_range={self.scale_range}"
        )
        return f"RandomAffine({what}, p={self.p})"


def affine_to_dict(change: _fishcam.AffineChange, seed: typing.Optional[int] = None) -> Record:
    """An affine change as the manifest records it (``augment-dataset --method affine``)."""
    return {
        "method": "affine",
        "seed": seed,
        "rotation_deg": float(change.rotation_deg),
        "translation": [float(x) for x in change.translation],
        "scale": float(change.scale),
    }
