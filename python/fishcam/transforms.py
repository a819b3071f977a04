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

Fill (where the moved view has no source): ``fill`` is a number, the images' value,
or a dict by target, ``{"image": 0, "mask": 255}`` (either key may be left out; any
other key is refused). Semantic masks (HxW labels of an integer dtype) get the mask
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

from . import Camera, Error, ViewpointChange, ViewpointWarp, _check_seed, _fishcam, change_to_dict

__all__ = ["RandomViewpoint", "RandomAffine", "SampleChange", "POLYGON_TOLERANCE_PX", "affine_to_dict", "draw_seed"]


Array = npt.NDArray[typing.Any]
Record = typing.Dict[str, typing.Any]
# (N, 2) source pixels -> (pixels (N, 2), visible (N,)): a change's forward direction.
Forward = typing.Callable[[Array], typing.Tuple[Array, Array]]


def draw_seed(rng: typing.Optional[np.random.Generator] = None) -> int:
    """One 64-bit seed from ``rng`` (a numpy Generator) or numpy's global generator."""
    if rng is not None:
        return int(rng.integers(0, 2**64, dtype=np.uint64))
    hi = int(np.random.randint(0, 2**32, dtype=np.uint64))
    lo = int(np.random.randint(0, 2**32, dtype=np.uint64))
    return (hi << 32) | lo


def _number(value: object, what: str) -> float:
    """value as a float, or fishcam.Error naming the argument."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise Error(f"{what}: expected a number, got {type(value).__name__}")
    return float(value)


def _integer(value: object, what: str) -> int:
    """value as an int, or fishcam.Error naming the argument."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise Error(f"{what}: expected an integer, got {type(value).__name__}")
    return int(value)


def _check_p(p: float) -> None:
    if not (0 <= _number(p, "p") <= 1):
        raise Error(f"p: must be in [0, 1], got {p}")


# What ``fill`` takes: a number (the images' fill) or a dict by target.
Fill = typing.Union[float, typing.Mapping[typing.Any, float]]
_LABEL_MAX = 65535  # the largest label the warp takes (uint16)


def _key_name(key: object) -> str:
    if isinstance(key, type):
        return ("tv_tensors." if key.__module__.startswith("torchvision.tv_tensors") else "") + key.__name__
    return repr(key)


def _split_fill(fill: object, fill_mask: object, image_key: object = "image", mask_key: object = "mask",
                finite: bool = True, label_range: typing.Optional[typing.Tuple[int, int]] = (0, _LABEL_MAX),
                ) -> typing.Tuple[typing.Any, int]:
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


def _labels_for_warp(mask: Array, fill_mask: int,
                     what: str = "mask") -> typing.Tuple[Array, typing.Callable[[Array], Array]]:
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
        raise Error(f"{what}: shape {image.shape} looks channels-first (CHW); numpy images are HxWxC "
                    "(np.moveaxis(image, 0, -1))")
    if image.dtype == np.float64:
        raise Error(f"{what}: float64 images are not resampled; pass float32 (image.astype(np.float32))")
    return image


def _points_array(points: object, what: str, k: int = 2) -> Array:
    """(N, k) float64 from any array-like of numbers, or fishcam.Error naming it."""
    try:
        array = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise Error(f"{what}: expected an array of numbers") from None
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

    def __init__(self, record: Record, forward: Forward,
                 resample: typing.Callable[..., typing.Dict[str, Array]],
                 depth_map: typing.Callable[[Array], Array], camera: typing.Callable[[Camera], Camera],
                 size: typing.Tuple[int, int], fill_mask: int) -> None:
        self.record = record
        self._fill_mask = fill_mask  # the semantic masks' no-source label
        self._forward = forward      # (N, 2) source pixels -> (pixels, visible)
        self._resample = resample    # (image, labels, label_fill) -> dict of the warp's outputs
        self._depth_map = depth_map  # (depth map) -> depth map
        self._camera = camera        # Camera -> Camera
        self.size = size             # (width, height) of the output

    def image(self, image: Array, what: str = "image") -> Array:
        """An image resampled bilinearly (dtype and channels kept)."""
        return self._resample(image=_image_array(image, what), labels=None, label_fill=0)["image"]

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

    def image_and_mask(self, image: Array, mask: Array, instance: bool = False) -> typing.Tuple[Array, Array]:
        """Both in one pass (the maps are computed once): (image, mask); the mask's fill as ``mask()``'s."""
        image = _image_array(image, "image")
        if not isinstance(mask, np.ndarray) or mask.ndim != 2:
            raise Error(f"mask: expected an HxW numpy array, got {getattr(mask, 'shape', type(mask).__name__)}")
        fill = self.mask_fill(mask, instance)
        labels, restore = _labels_for_warp(mask, fill)
        out = self._resample(image=image, labels=labels, label_fill=fill)
        return out["image"], restore(out["labels"])

    def depth_map(self, depth_map: Array, what: str = "depth_map") -> Array:
        """A depth map (HxW float32) seen from the moved camera (see RandomViewpoint)."""
        if not isinstance(depth_map, np.ndarray) or depth_map.dtype != np.float32 or depth_map.ndim != 2:
            got = f"{depth_map.dtype} {depth_map.shape}" if isinstance(depth_map, np.ndarray) else type(depth_map).__name__
            raise Error(f"{what}: expected an HxW float32 array, got {got}")
        return self._depth_map(depth_map)

    def points(self, points: object, what: str = "keypoints") -> typing.Tuple[Array, Array]:
        """(N, 2) pixels -> (new pixels (N, 2) float64, visible (N,) bool). Exact; NaN
        where a point has no image; not visible where it left the view or is hidden."""
        return self._forward(_points_array(points, what))

    def boxes(self, boxes: object, what: str = "boxes", clip: bool = True) -> typing.Tuple[Array, Array]:
        """(N, 4) x_min, y_min, x_max, y_max (pixel edges) -> (boxes (N, 4), visible
        fraction (N,)): the tight box of the densely transformed outline, clipped to
        the image unless ``clip=False``; the fraction of it inside the image (0, and
        an empty box, where nothing maps)."""
        boxes = _points_array(boxes, what, 4)
        out = np.zeros_like(boxes)
        visibility = np.zeros(len(boxes))
        width, height = self.size
        for i, (x0, y0, x1, y1) in enumerate(boxes):
            if not (x1 >= x0 and y1 >= y0):
                raise Error(f"{what}[{i}]: expected x_min <= x_max and y_min <= y_max, got {boxes[i].tolist()}")
            outline = _box_outline(x0 - 0.5, y0 - 0.5, x1 - 0.5, y1 - 0.5)  # pixel centres at integers
            mapped, _ = self._forward(outline)
            mapped = mapped[np.isfinite(mapped).all(axis=1)] + 0.5
            if len(mapped) == 0:
                continue
            lo, hi = mapped.min(axis=0), mapped.max(axis=0)
            clipped_lo, clipped_hi = np.maximum(lo, 0), np.minimum(hi, (width, height))
            area = np.prod(hi - lo)
            inside = np.prod(np.maximum(clipped_hi - clipped_lo, 0))
            visibility[i] = inside / area if area > 0 else float(inside >= 0 and (clipped_hi >= clipped_lo).all())
            out[i] = [*np.minimum(clipped_lo, (width, height)), *np.maximum(clipped_hi, 0)] if clip else [*lo, *hi]
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


def _box_outline(x0: float, y0: float, x1: float, y1: float, step: float = 0.25) -> Array:
    """Points every `step` px around the box (corners included)."""
    nx = max(int(np.ceil((x1 - x0) / step)), 1)
    ny = max(int(np.ceil((y1 - y0) / step)), 1)
    xs = np.linspace(x0, x1, nx + 1)
    ys = np.linspace(y0, y1, ny + 1)
    return np.concatenate([np.stack([xs, np.full_like(xs, y0)], 1), np.stack([xs, np.full_like(xs, y1)], 1),
                           np.stack([np.full_like(ys, x0), ys], 1), np.stack([np.full_like(ys, x1), ys], 1)])


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
        self._warps: typing.Dict[bytes, ViewpointWarp] = {}
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

    def __getstate__(self) -> typing.Dict[str, int]:
        return {"limit": self._limit}  # warps are rebuilt on demand after unpickling

    def __setstate__(self, state: typing.Dict[str, int]) -> None:
        self._warps = {}
        self._limit = state["limit"]


class RandomViewpoint:
    """A random viewpoint change per call (the paper's eq. 7), applied exactly.

    camera: the fishcam.Camera of the images (or None: then every call passes camera=).
    preset: "small", "medium", "large" or "train"; or give max_rotation_deg and
        max_translation instead (uniform per axis in [-max, max]).
    depth: the depth prior, "source-sphere" (default), "target-sphere" or "infinity":
        where a pixel's scene point is assumed to be when the camera moves; or "map":
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

    def __init__(self, camera: typing.Optional[Camera] = None, preset: typing.Optional[str] = "train",
                 max_rotation_deg: typing.Optional[float] = None, max_translation: typing.Optional[float] = None,
                 depth: str = "source-sphere", p: float = 1.0, fill: Fill = 0, fill_mask: int = 0,
                 rng: typing.Optional[np.random.Generator] = None, sampling: str = "grid",
                 depth_values: str = "range") -> None:
        if sampling not in _fishcam.sampling_names():
            raise Error(f"sampling: expected {' or '.join(_fishcam.sampling_names())}, got {sampling!r}")
        if depth_values not in _fishcam.depth_values_names():
            raise Error(f"depth_values: expected {' or '.join(_fishcam.depth_values_names())}, got {depth_values!r}")
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
            _fishcam.check_preset(str(preset))
        if depth not in _fishcam.depth_priors_and_map():
            raise Error(f"depth: expected {', '.join(_fishcam.depth_priors_and_map())}, got {depth!r}")
        _check_p(p)
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

    def draw(self, camera: typing.Optional[Camera] = None, seed: typing.Optional[int] = None,
             depth_map: typing.Optional[Array] = None) -> SampleChange:
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
        warp = self._warps.get(camera)
        if self.depth == "map":
            if depth_map is None:
                raise Error("depth='map' needs the sample's depth map (depth_map=, HxW float32)")
            if not isinstance(depth_map, np.ndarray) or depth_map.dtype != np.float32 or depth_map.ndim != 2:
                got = f"{depth_map.dtype} {depth_map.shape}" if isinstance(depth_map, np.ndarray) else type(depth_map).__name__
                raise Error(f"depth_map: expected an HxW float32 array, got {got}")
        maps_depth = depth_map if self.depth == "map" else None

        def resample(image: typing.Optional[Array], labels: typing.Optional[Array],
                     label_fill: int) -> typing.Dict[str, Array]:
            return warp.warp(image=image, labels=labels, change=change, depth=self.depth, fill=self.fill,
                             label_fill=label_fill, sampling=self.sampling, depth_map=maps_depth,
                             depth_values=self.depth_values)

        return SampleChange(
            record=change_to_dict(change, seed, self.depth),
            forward=lambda points: warp.forward(points, change, self.depth, depth_map=maps_depth,
                                                depth_values=self.depth_values),
            resample=resample,
            depth_map=lambda depth_map: warp.warp_depth(depth_map, change, self.depth, self.depth_values),
            camera=lambda c: c.augmented(change),
            size=(camera.width, camera.height),
            fill_mask=self.fill_mask)

    def __call__(self, image: typing.Optional[Array] = None, mask: typing.Optional[Array] = None,
                 camera: typing.Optional[Camera] = None, seed: typing.Optional[int] = None,
                 **targets: typing.Any) -> typing.Dict[str, typing.Any]:
        """One change for every target given (module docstring); a dict with the same
        keys, ``change`` (the record) and the visibility of keypoints and boxes."""
        # The augmented camera is returned for a camera given with the sample.
        return _apply(self.draw(camera, seed, targets.get("depth_map")), image, mask, camera, targets)

    def __repr__(self) -> str:
        what = (f"preset={self.preset!r}" if self.preset is not None else
                f"max_rotation_deg={self.max_rotation_deg}, max_translation={self.max_translation}")
        return (f"RandomViewpoint({what}, depth={self.depth!r}, p={self.p}, fill={self.fill}, "
                f"fill_mask={self.fill_mask}, sampling={self.sampling!r}, depth_values={self.depth_values!r})")


_TARGETS = ("images", "depth_map", "keypoints", "boxes", "polygons")


def _apply(sample_change: SampleChange, image: typing.Optional[Array], mask: typing.Optional[Array],
           camera: typing.Optional[Camera], targets: typing.Dict[str, typing.Any]) -> typing.Dict[str, typing.Any]:
    """The numpy transforms' call: every given target under one SampleChange; a dict
    with the same keys, plus ``change`` (the record) and, for keypoints and boxes,
    ``keypoints_visible`` and ``boxes_visibility``."""
    unknown = sorted(set(targets) - set(_TARGETS))
    if unknown:
        raise Error(f"unknown target {unknown[0]!r} (expected image, mask, camera, {', '.join(_TARGETS)})")
    if image is None and mask is None and not any(v is not None for v in targets.values()):
        raise Error("nothing to transform: pass image= and/or mask= (or another target)")
    out: typing.Dict[str, typing.Any] = {"change": sample_change.record}
    if image is not None and mask is not None:
        out["image"], out["mask"] = sample_change.image_and_mask(image, mask)
    elif image is not None:
        out["image"] = sample_change.image(image)
    elif mask is not None:
        out["mask"] = sample_change.mask(mask)
    if targets.get("images") is not None:
        out["images"] = [sample_change.image(x, f"images[{i}]") for i, x in enumerate(targets["images"])]
    if targets.get("depth_map") is not None:
        out["depth_map"] = sample_change.depth_map(targets["depth_map"])
    if targets.get("keypoints") is not None:
        out["keypoints"], out["keypoints_visible"] = sample_change.points(targets["keypoints"])
    if targets.get("boxes") is not None:
        out["boxes"], out["boxes_visibility"] = sample_change.boxes(targets["boxes"])
    if targets.get("polygons") is not None:
        out["polygons"] = [sample_change.polygon(x, f"polygons[{i}]") for i, x in enumerate(targets["polygons"])]
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

    def __init__(self, preset: typing.Optional[str] = "train", max_rotation_deg: typing.Optional[float] = None,
                 max_translation: typing.Optional[float] = None,
                 scale_range: typing.Optional[typing.Tuple[float, float]] = None, p: float = 1.0, fill: Fill = 0,
                 fill_mask: int = 0, rng: typing.Optional[np.random.Generator] = None) -> None:
        custom = (max_rotation_deg, max_translation, scale_range)
        if any(v is not None for v in custom) and not all(v is not None for v in custom):
            raise Error("max_rotation_deg, max_translation and scale_range go together")
        self.scale_range: typing.Optional[typing.Tuple[float, float]] = None
        if max_rotation_deg is not None:
            preset = None
            try:
                low, high = (float(v) for v in typing.cast(typing.Iterable[float], scale_range))
            except (TypeError, ValueError):
                raise Error(f"scale_range: expected (low, high), got {scale_range!r}") from None
            # The library checks the ranges (one message for every binding).
            _fishcam.random_affine_in(max_rotation_deg, _number(max_translation, "max_translation"), low, high, 0)
            self.scale_range = (low, high)
        elif preset not in _fishcam.affine_presets():
            _fishcam.random_affine(str(preset), 0)  # raises naming the presets
        _check_p(p)
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

    def draw(self, size: typing.Tuple[int, int], seed: typing.Optional[int] = None) -> SampleChange:
        """The SampleChange of one call for images of ``size`` = (width, height)."""
        try:
            width, height = (_integer(v, "size") for v in size)
        except TypeError:
            raise Error(f"size: expected (width, height), got {size!r}") from None
        if seed is None:
            seed = draw_seed(self.rng)
        seed = _check_seed(seed)
        change = self.change_for(seed) if _applies(self.p, seed) else _fishcam.AffineChange()

        def resample(image: typing.Optional[Array], labels: typing.Optional[Array],
                     label_fill: int) -> typing.Dict[str, Array]:
            given = image if image is not None else labels
            assert given is not None
            if given.shape[:2] != (height, width):
                raise Error(f"{'image' if image is not None else 'mask'}: is {given.shape[1]}x{given.shape[0]} "
                            f"but the sample is {width}x{height}")
            return _fishcam.affine_warp(image=image, labels=labels, change=change, fill=self.fill,
                                        label_fill=label_fill)

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
            fill_mask=self.fill_mask)

    def __call__(self, image: typing.Optional[Array] = None, mask: typing.Optional[Array] = None,
                 camera: typing.Optional[Camera] = None, seed: typing.Optional[int] = None,
                 **targets: typing.Any) -> typing.Dict[str, typing.Any]:
        """As RandomViewpoint's; ``camera`` is passed on unchanged (the baseline has no
        camera model), depth maps keep their values (sampled as masks)."""
        given = next((x for x in (image, mask, targets.get("depth_map")) if x is not None), None)
        if given is None and targets.get("images"):
            given = targets["images"][0]
        if given is None:
            raise Error("nothing to transform: pass image= and/or mask= (or images=, depth_map=)")
        if not isinstance(given, np.ndarray) or given.ndim < 2:
            raise Error(f"image: expected an HxW or HxWxC numpy array, got {type(given).__name__}")
        return _apply(self.draw((given.shape[1], given.shape[0]), seed), image, mask, camera, targets)

    def __repr__(self) -> str:
        what = (f"preset={self.preset!r}" if self.preset is not None else
                f"max_rotation_deg={self.max_rotation_deg}, max_translation={self.max_translation}, "
                f"scale_range={self.scale_range}")
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
