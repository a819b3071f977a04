"""SampleChange, one drawn change and what it does to each target of a sample, and
the numpy transforms' call: every target of the call under one SampleChange."""

import typing

import numpy as np

from .. import Camera, Error
from .checks import Array, Record, _image_array, _points_array, _sequence
from .fill import _check_image_fill, _labels_for_warp
from .geometry import Forward, _subdivided, _transformed_boxes


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

    def instance_masks(self, masks: Array, what: str = "masks") -> Array:
        """N instance masks (N, H, W) resampled as ``mask(..., instance=True)`` resamples
        each (0 / False where there is no source, dtype kept). Masks of two values (0 and
        one other: bool, 0/1, 0/255) travel 16 to a pass as the bits of one uint16 label
        map: nearest neighbour takes every bit of a pixel from the same source pixel, so
        each comes back as it would alone, for a sixteenth of the passes."""
        if not isinstance(masks, np.ndarray) or masks.ndim != 3:
            raise Error(f"{what}: expected an NxHxW numpy array, got {getattr(masks, 'shape', type(masks).__name__)}")
        binary: list[tuple[int, typing.Any]] = []  # (index, its one nonzero value)
        alone: list[int] = []
        for i, mask in enumerate(masks):
            top = mask.max() if mask.size else 0
            if mask.dtype == np.bool_ or (top >= 0 and bool(np.all((mask == 0) | (mask == top)))):
                binary.append((i, top))
            else:
                alone.append(i)
        planes: dict[int, Array] = {i: self.mask(masks[i], f"{what}[{i}]", instance=True) for i in alone}
        for start in range(0, len(binary), 16):
            group = binary[start : start + 16]
            packed = np.zeros(masks.shape[1:], np.uint16)
            for bit, (i, _) in enumerate(group):
                packed |= (masks[i] != 0).astype(np.uint16) << np.uint16(bit)
            warped = self._resample(image=None, labels=packed, label_fill=0)["labels"]
            for bit, (i, top) in enumerate(group):
                bits = ((warped >> np.uint16(bit)) & 1).astype(np.bool_)
                planes[i] = bits if masks.dtype == np.bool_ else np.where(bits, top, 0).astype(masks.dtype)
        if not planes:
            return masks.copy()
        return np.stack([planes[i] for i in range(len(masks))])

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
        return _transformed_boxes(self._forward, self.size, boxes, clip)

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


# The targets of a call besides image, mask and camera, in the order they are
# applied: each gives the entries of the output it makes.
_TARGETS: dict[str, typing.Callable[[SampleChange, typing.Any], dict[str, typing.Any]]] = {
    "images": lambda change, images: {
        "images": [change.image(x, f"images[{i}]") for i, x in enumerate(_sequence(images, "images"))]
    },
    "depth_map": lambda change, depth_map: {"depth_map": change.depth_map(depth_map)},
    "keypoints": lambda change, points: dict(zip(("keypoints", "keypoints_visible"), change.points(points))),
    "boxes": lambda change, boxes: dict(zip(("boxes", "boxes_visibility"), change.boxes(boxes))),
    "polygons": lambda change, polygons: {
        "polygons": [change.polygon(x, f"polygons[{i}]") for i, x in enumerate(_sequence(polygons, "polygons"))]
    },
}


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
    for name, apply in _TARGETS.items():
        if targets.get(name) is not None:
            out.update(apply(sample_change, targets[name]))
    if camera is not None:
        out["camera"] = sample_change.camera(camera)
    return out
