"""Every target of a sample under one change, each against an independent reference:
keypoints against the published formula (eq. 7 through the camera's own project /
unproject), boxes against the transformed instance mask, depth maps against the
moved scene, polygons against the densely mapped true curve; bad input refused."""

import os

import fishcam
import numpy as np
import pytest
from conftest import DATA
from fishcam.transforms import POLYGON_TOLERANCE_PX, RandomAffine, RandomViewpoint

SEEDS = range(6)


@pytest.fixture(scope="module")
def cam():
    return fishcam.Camera.read(os.path.join(DATA, "woodscape_front.json")).resized(320, 242)


def forward_reference(cam, change, points):
    """Source pixels under the source-sphere prior: P = unproject(p) on the unit
    sphere, P' = R P + t, projected (the paper's eq. 7, written out here)."""
    rays, ok = cam.unproject(points)
    moved = rays @ np.asarray(change.rotation).T + np.asarray(change.translation)
    pixels, ok2 = cam.project(moved)
    return pixels, ok & ok2


@pytest.mark.parametrize("seed", SEEDS)
def test_keypoints_follow_the_formula_and_the_maps(cam, seed):
    t = RandomViewpoint(cam, preset="large")
    rng = np.random.default_rng(seed)
    points = rng.uniform((0, 0), (cam.width - 1, cam.height - 1), (200, 2))
    out = t(keypoints=points, seed=seed)
    change = t.change_for(seed)
    expected, ok = forward_reference(cam, change, points)
    visible = out["keypoints_visible"]
    assert visible.sum() > 50
    np.testing.assert_allclose(out["keypoints"][ok], expected[ok], atol=1e-9)
    # Visible points land where the exact inverse map finds them again (within the
    # map's one-pixel grid: the map is sampled at the nearest output pixel).
    map_x, map_y, valid = fishcam.ViewpointWarp(cam).maps(change, exact=True)
    for (x, y), source, seen in zip(out["keypoints"], points, visible):
        if not seen:
            continue
        u, v = int(round(x)), int(round(y))
        assert valid[v, u]
        assert np.hypot(map_x[v, u] - source[0], map_y[v, u] - source[1]) < 1.5
    # Points that left the view are flagged, not dropped.
    inside = ((out["keypoints"] >= -0.5) & (out["keypoints"] < (cam.width - 0.5, cam.height - 0.5))).all(axis=1)
    assert not (visible & ~inside).any()


@pytest.mark.parametrize("seed", SEEDS)
def test_boxes_are_the_tight_box_of_the_transformed_object(cam, seed):
    """An instance (a filled rectangle) warped as a mask: its box, transformed from
    the outline alone, contains every pixel of the warped instance and is tight to
    1 px on each side that lies inside the image."""
    t = RandomViewpoint(cam, preset="medium")
    rng = np.random.default_rng(seed)
    x0, y0 = rng.integers(40, 200), rng.integers(30, 150)
    x1, y1 = x0 + rng.integers(10, 80), y0 + rng.integers(10, 60)
    instance = np.zeros((cam.height, cam.width), np.uint8)
    instance[y0:y1, x0:x1] = 1  # pixels x0..x1-1: the box x0, y0, x1, y1 in pixel edges
    out = t(mask=instance, boxes=[[x0, y0, x1, y1]], seed=seed)
    ys, xs = np.nonzero(out["mask"])
    if len(xs) == 0:
        assert out["boxes_visibility"][0] == 0 or np.ptp(out["boxes"][0]) >= 0
        return
    bx0, by0, bx1, by1 = out["boxes"][0]
    mask_box = np.array([xs.min(), ys.min(), xs.max() + 1, ys.max() + 1], dtype=float)
    # Contains: nearest sampling may take a pixel whose centre maps within half a pixel outside.
    assert bx0 <= mask_box[0] + 0.5 and by0 <= mask_box[1] + 0.5
    assert bx1 >= mask_box[2] - 0.5 and by1 >= mask_box[3] - 0.5
    # Tight.
    np.testing.assert_allclose(out["boxes"][0], mask_box, atol=1.0)
    assert 0 < out["boxes_visibility"][0] <= 1


def test_depth_maps_match_the_moved_scene_for_rotations(cam):
    """A plane z = 2 in front of the camera: its z map under a rotation equals the z of
    the plane seen from the rotated camera (computed from the output rays); a sphere
    of radius 3 keeps its range."""
    rays, ok = cam.unproject(
        np.stack(np.meshgrid(np.arange(cam.width), np.arange(cam.height)), -1).reshape(-1, 2).astype(float)
    )
    rays = rays.reshape(cam.height, cam.width, 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        plane_z = np.where(rays[..., 2] > 0.05, 2.0, np.nan).astype(np.float32)
    rotation_only = fishcam.ViewpointChange(rotation_deg=(12, -20, 7))
    warp = fishcam.ViewpointWarp(cam)
    out = warp.warp_depth(plane_z, rotation_only, values="z")
    # Reference: the plane z_source = 2 seen along the output ray d: X' = lam d with
    # (R^T X')_z = 2, so z' = lam d_z.
    rotation = np.asarray(rotation_only.rotation)
    source_z = rays @ rotation  # (R^T d) per pixel, as rows
    lam = 2.0 / source_z[..., 2]
    expected = lam * rays[..., 2]
    seen = np.isfinite(out)
    assert seen.sum() > 0.3 * out.size
    np.testing.assert_allclose(out[seen], expected[seen], rtol=2e-6)
    sphere = np.full((cam.height, cam.width), 3.0, np.float32)
    ranges = warp.warp_depth(sphere, rotation_only)
    assert np.all(np.abs(ranges[np.isfinite(ranges)] - 3.0) < 1e-5)
    # No-depth markers stay markers; no source -> the fill.
    marked = sphere.copy()
    marked[:, : cam.width // 2] = 0
    marked_out = warp.warp_depth(marked, rotation_only, fill=-1)
    assert set(np.unique(marked_out[(marked_out != 3) & (np.abs(marked_out - 3) > 1e-5)])) <= {0.0, -1.0}


@pytest.mark.parametrize("seed", SEEDS)
def test_polygons_stay_within_half_a_pixel_of_the_true_curve(cam, seed):
    t = RandomViewpoint(cam, preset="large")
    rng = np.random.default_rng(seed)
    centre = rng.uniform((80, 60), (240, 180))
    polygon = centre + rng.uniform(-60, 60, (5, 2))
    out = t(polygons=[polygon], seed=seed)["polygons"][0]
    assert len(out) >= len(polygon)
    change = t.change_for(seed)
    dense = np.concatenate(
        [np.linspace(a, b, 200, endpoint=False) for a, b in zip(polygon, np.roll(polygon, -1, axis=0))]
    )
    curve, ok = forward_reference(cam, change, dense)
    curve = curve[ok & np.isfinite(curve).all(axis=1)]
    chain = np.concatenate([out, out[:1]])
    finite = np.isfinite(chain).all(axis=1)
    a, b = chain[:-1][finite[:-1] & finite[1:]], chain[1:][finite[:-1] & finite[1:]]
    # Distance of every true curve point to the nearest segment of the output.
    ab = b - a
    tt = np.clip(
        np.einsum("sj,csj->cs", ab, curve[:, None, :] - a[None]) / np.maximum(np.einsum("sj,sj->s", ab, ab), 1e-12),
        0,
        1,
    )
    nearest = a[None] + tt[..., None] * ab[None]
    distance = np.linalg.norm(nearest - curve[:, None, :], axis=2).min(axis=1)
    assert distance.max() <= POLYGON_TOLERANCE_PX, distance.max()


def test_the_camera_moves_with_the_change(cam):
    t = RandomViewpoint(cam, preset="large")
    out = t(image=np.zeros((cam.height, cam.width), np.uint8), camera=cam, seed=4)
    rotation, translation = out["camera"].pose
    change = t.change_for(4)
    # p_new = R p_cam + t, so p_reference = R_c R^T p_new + (t_c - R_c R^T t).
    r_c, t_c = cam.pose
    r, t_change = np.asarray(change.rotation), np.asarray(change.translation)
    np.testing.assert_allclose(rotation, r_c @ r.T, atol=1e-12)
    np.testing.assert_allclose(translation, t_c - r_c @ r.T @ t_change, atol=1e-12)

    assert out["camera"].parameters == cam.parameters and out["camera"].width == cam.width


def test_affine_targets_follow_the_affine_formula(cam):
    t = RandomAffine(preset="medium")
    image = np.zeros((cam.height, cam.width), np.uint8)
    out = t(image=image, keypoints=[[10, 20], [160, 121]], boxes=[[100, 100, 140, 130]], seed=2)
    change = t.change_for(2)
    a = np.radians(change.rotation_deg)
    c = np.array([(cam.width - 1) / 2, (cam.height - 1) / 2])
    rot = change.scale * np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])
    shift = np.array(change.translation) * (cam.width, cam.height)
    expected = (np.array([[10, 20], [160, 121]]) - c) @ rot.T + c + shift
    np.testing.assert_allclose(out["keypoints"], expected, atol=1e-9)
    corners = np.array([[99.5, 99.5], [139.5, 99.5], [99.5, 129.5], [139.5, 129.5]])
    moved = (corners - c) @ rot.T + c + shift + 0.5
    np.testing.assert_allclose(out["boxes"][0], [*moved.min(0), *moved.max(0)], atol=0.3)


def test_bad_targets_are_refused_in_one_line(cam):
    t = RandomViewpoint(cam)
    chw = np.zeros((3, cam.height, cam.width), np.uint8)
    cases = [
        (dict(image=chw), "channels-first"),
        (dict(image=np.zeros((cam.height, cam.width), np.float64)), "float64"),
        (dict(image=[[1, 2]]), "expected a numpy array"),
        (dict(mask=np.zeros((cam.height, cam.width), np.float32)), "dtype float32"),
        (dict(depth_map=np.zeros((cam.height, cam.width), np.float64)), "float32"),
        (dict(keypoints=np.zeros((3, 3))), r"shape \(N, 2\)"),
        (dict(boxes=[[10, 10, 5, 20]]), "x_min <= x_max"),
        (dict(polygons=[[["a", "b"]]]), "array of numbers"),
        (dict(points=[[1, 2]]), "unknown target 'points'"),
        (dict(), "nothing to transform"),
        (dict(image=np.zeros((10, 10), np.uint8)), "is 10x10 but the camera is 320x242"),
    ]
    for kwargs, message in cases:
        with pytest.raises(fishcam.Error, match=message) as error:
            t(seed=1, **kwargs)
        assert "\n" not in str(error.value)
    with pytest.raises(fishcam.Error, match="depth_values"):
        RandomViewpoint(cam, depth_values="disparity")


def dense_box(sample_change, box, step=0.25):
    """The tight box of the outline sampled every ``step`` px (what boxes() did before
    round 3 of issue 40): the reference for ordinary boxes."""
    x0, y0, x1, y1 = np.asarray(box, dtype=float) - 0.5
    xs = np.linspace(x0, x1, max(int(np.ceil((x1 - x0) / step)), 1) + 1)
    ys = np.linspace(y0, y1, max(int(np.ceil((y1 - y0) / step)), 1) + 1)
    outline = np.concatenate(
        [
            np.stack([xs, np.full_like(xs, y0)], 1),
            np.stack([xs, np.full_like(xs, y1)], 1),
            np.stack([np.full_like(ys, x0), ys], 1),
            np.stack([np.full_like(ys, x1), ys], 1),
        ]
    )
    mapped = sample_change.points(outline)[0]
    mapped = mapped[np.isfinite(mapped).all(axis=1)] + 0.5
    return np.concatenate([mapped.min(0), mapped.max(0)])


@pytest.mark.parametrize("seed", SEEDS)
def test_boxes_sampled_adaptively_match_the_dense_outline(cam, seed):
    """The adaptive outline (at most BOX_MAX_POINTS points a box) gives the dense
    outline's box within 0.02 px for ordinary boxes."""
    rng = np.random.default_rng(seed)
    corner = rng.uniform((0, 0), (cam.width - 20, cam.height - 20), (12, 2))
    boxes = np.concatenate([corner, corner + rng.uniform(1, 150, (12, 2))], axis=1)
    change = RandomViewpoint(cam, preset="large").draw(seed=seed)
    out, _ = change.boxes(boxes, clip=False)
    for box, got in zip(boxes, out):
        np.testing.assert_allclose(got, dense_box(change, box), atol=0.02)


@pytest.mark.parametrize("size", [1e4, 1e6, 1e7, 1e300, np.inf])
def test_huge_boxes_are_clipped_before_their_outline_is_sampled(cam, size):
    """A box far larger than the image costs a bounded number of mapped points (it
    took 1.2 GB and 7.7 s at 1e6 px, and exhausted memory at 1e7), and, reaching
    past the image on every side, keeps the content in view rather than becoming
    [0, 0, 0, 0] where its outline leaves the field of view."""
    import time

    sample_change = RandomViewpoint(cam, preset="large").draw(seed=1)
    counted = []
    forward = sample_change._forward
    sample_change._forward = lambda points: (counted.append(len(points)), forward(points))[1]
    start = time.perf_counter()
    out, visibility = sample_change.boxes([[-size, -size, size, size], [-size, 10, 20, 30]])
    assert time.perf_counter() - start < 2 and sum(counted) <= 2 * fishcam.transforms.BOX_MAX_POINTS
    valid = fishcam.ViewpointWarp(cam).maps(RandomViewpoint(cam, preset="large").change_for(1))[2] != 0
    ys, xs = np.nonzero(valid)
    assert out[0][0] <= xs.min() + 1 and out[0][1] <= ys.min() + 1
    assert out[0][2] >= xs.max() and out[0][3] >= ys.max() and visibility[0] > 0
    identity = RandomViewpoint(cam, preset="large", p=0).draw(seed=1)
    np.testing.assert_array_equal(identity.boxes([[-size, -size, size, size]])[0], [[0, 0, cam.width, cam.height]])


def test_depth_at_infinity_drops_the_translation_everywhere(cam):
    """depth="infinity" ignores the translation in the image; the returned camera and
    the record say so too (issue 37, item 3: they kept it, 19 px apart at 5 m)."""
    t = fishcam.transforms.RandomViewpoint(cam, preset="large", depth="infinity")
    full = t.change_for(5)
    assert np.abs(full.translation).max() > 0.1, "the preset's change has a translation to drop"
    image = (np.arange(cam.height * cam.width * 3) % 251).astype(np.uint8).reshape(cam.height, cam.width, 3)
    out = t(image=image, camera=cam, seed=5)
    assert out["change"]["translation"] == [0.0, 0.0, 0.0]
    assert out["change"]["rotation_deg"] == pytest.approx(full.rotation_deg.ravel().tolist(), abs=0)
    rotation_only = fishcam.ViewpointChange(rotation_deg=full.rotation_deg.ravel(), translation=(0, 0, 0))
    assert out["camera"] == cam.augmented(rotation_only)
    # The image: what the warp gives the full change at infinity (translation ignored there too).
    warp = fishcam.ViewpointWarp(cam)
    reference = warp.warp(image=image, change=full, depth="infinity")["image"]
    assert np.array_equal(out["image"], reference)
