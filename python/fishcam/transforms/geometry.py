"""The geometry of a change on points, boxes and polygons: a change's forward
direction (source pixels to output pixels) applied to the outlines of boxes,
sampled adaptively, and to the edges of polygons, subdivided until they follow the
curved image (docs/python.md, "Targets")."""

import typing

import numpy as np

from .checks import Array

# (N, 2) source pixels -> (pixels (N, 2), visible (N,)): a change's forward direction.
Forward = typing.Callable[[Array], tuple[Array, Array]]

# The largest distance (px) a subdivided polygon edge keeps from the true curve,
# and the most halvings one edge gets.
POLYGON_TOLERANCE_PX = 0.5
_MAX_SUBDIVISIONS = 16


# Box outlines (SampleChange.boxes): at most BOX_MAX_POINTS mapped points a box; an
# outline is sampled at first _BOX_FIRST_STEPS intervals a side, then each interval
# halved while the image of its midpoint lies farther than _BOX_TOLERANCE_PX from the
# chord (or the outline leaves the field of view in it), down to _BOX_MIN_STEP_PX.
BOX_MAX_POINTS = 4096
_BOX_FIRST_STEPS = 16
_BOX_TOLERANCE_PX = 0.05
_BOX_MIN_STEP_PX = 0.25
_BOX_INTERIOR_LINES = 15  # a direction, across a box whose outline partly has no image


def _transformed_boxes(forward: Forward, size: tuple[int, int], boxes: Array, clip: bool) -> tuple[Array, Array]:
    """(boxes (N, 4), visible fraction (N,)) of the boxes (N, 4) x_min, y_min, x_max,
    y_max (pixel edges, checked) under ``forward``, for an output of ``size`` =
    (width, height): SampleChange.boxes."""
    width, height = size
    # Pixel edges -> pixel centres at integers, within the image plus one image size.
    low, high = np.array([-width, -height]) - 0.5, np.array([2 * width, 2 * height]) - 0.5
    corners = np.clip(boxes.reshape(-1, 2, 2) - 0.5, low, high)
    # The outline leaves the interior lines' first samples of the budget.
    first = (4 + 2 * _BOX_INTERIOR_LINES) * (_BOX_FIRST_STEPS + 1)
    lo, hi, missed, used = _mapped_extents(
        forward, *_box_lines(corners), len(boxes), np.full(len(boxes), BOX_MAX_POINTS - first)
    )
    if missed.any():  # the content that stays in view: lines across the box's part of the image
        inner = np.clip(corners[missed], -0.5, np.array([width, height]) - 0.5)
        seen = (inner[:, 1] >= inner[:, 0]).all(axis=1)
        owners = np.flatnonzero(missed)[seen]
        starts, ends, owner = _box_lines(inner[seen], _BOX_INTERIOR_LINES)
        more_lo, more_hi, _, _ = _mapped_extents(
            forward, starts, ends, owners[owner], len(boxes), BOX_MAX_POINTS - used
        )
        lo, hi = np.fmin(lo, more_lo), np.fmax(hi, more_hi)
    found = np.isfinite(lo).all(axis=1)
    lo, hi = lo + 0.5, hi + 0.5
    extent = np.array([width, height], dtype=np.float64)
    clipped_lo, clipped_hi = np.maximum(lo, 0), np.minimum(hi, extent)
    area = np.prod(hi - lo, axis=1)
    inside = np.prod(np.maximum(clipped_hi - clipped_lo, 0), axis=1)
    point_inside = (clipped_hi >= clipped_lo).all(axis=1).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        visibility = np.where(area > 0, inside / np.where(area > 0, area, 1), point_inside)
    out = (
        np.concatenate([np.minimum(clipped_lo, extent), np.maximum(clipped_hi, 0)], axis=1)
        if clip
        else np.concatenate([lo, hi], axis=1)
    )
    out[~found] = 0
    visibility[~found] = 0
    return out, visibility


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
