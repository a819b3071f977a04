"""fishcam.calibrate / calibrate_rig on synthetic boards, and what a calibrated Camera
knows about its data (projection uncertainty, observed angles) -- through Python."""

import json
import os
import pickle
from pathlib import Path
from typing import Any

import fishcam
import numpy as np
import pytest

DATA = Path(os.environ.get("FISHCAM_DATA_DIR", Path(__file__).resolve().parents[2] / "data"))
BOARD = (9, 6)
SPACING = 0.1


def lens() -> fishcam.Camera:
    return fishcam.Camera.read(str(DATA / "kannala_brandt.yaml")).resized(640, 483)


def rotation(yaw: float, pitch: float, roll: float) -> np.ndarray:
    cy, sy, cp, sp, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rx = np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])
    rz = np.array([[cr, -sr, 0], [sr, cr, 0], [0, 0, 1]])
    return ry @ rx @ rz


def board_points() -> np.ndarray:
    points = np.zeros((54, 3))
    points[:, 0] = np.tile(np.arange(9), 6) * SPACING
    points[:, 1] = np.repeat(np.arange(6), 9) * SPACING
    return points


def stereo_boards(
    camera: fishcam.Camera, baseline: float, count: int, noise: float, seed: int
) -> tuple[list[Any], list[Any]]:
    """Boards in front of a stereo pair (camera 1 at +baseline along x, turned 10 degrees):
    each camera observes the boards it sees whole, images named by instant."""
    random = np.random.default_rng(seed)
    right = rotation(np.radians(10), 0, 0)
    left_obs: list[Any] = []
    right_obs: list[Any] = []
    for i in range(count):
        r = rotation(*random.uniform(-0.6, 0.6, 3))
        centre = np.array([random.uniform(-1.2, 1.2), random.uniform(-0.8, 0.8), random.uniform(0.8, 1.6)])
        points = (board_points() - board_points().mean(axis=0)) @ r.T + centre
        for observations, transform in ((left_obs, lambda p: p), (right_obs, lambda p: (p - [baseline, 0, 0]) @ right)):
            pixels, ok = camera.project(transform(points))
            inside = ok & (pixels[:, 0] >= 0) & (pixels[:, 1] >= 0) & (pixels[:, 0] <= 639) & (pixels[:, 1] <= 482)
            if inside.all():
                observations.append((f"cam/{i:03d}.png", pixels + random.normal(0, noise, pixels.shape)))
    return left_obs, right_obs


def test_calibrate_recovers_the_lens_and_carries_its_record() -> None:
    camera = lens()
    left, _ = stereo_boards(camera, 0.2, 40, 0.2, 1)
    result = fishcam.calibrate(left, BOARD, SPACING, (640, 483), "kannala-brandt", threads=2)
    assert isinstance(result, fishcam.Calibration)
    assert result.rms_px == pytest.approx(0.2 * np.sqrt(2), rel=0.2)
    assert result.rms_per_coordinate_px == pytest.approx(result.rms_px / np.sqrt(2))
    truth = camera.parameters[0] * camera.pixel_scale[0]  # calibration gives a_x = 1
    assert abs(result.parameters["f"] - truth) < 4 * result.sigmas["f"]
    assert len(result.poses) == len(result.images) == len(result.per_image_rms_px)
    # Flat boards: the warp solved by default is within 4 sigma of none; held flat, none.
    assert result.board_warp is not None and result.board_warp_sigmas is not None
    assert all(abs(w) < 4 * s for w, s in zip(result.board_warp, result.board_warp_sigmas))
    flat = fishcam.calibrate(left, BOARD, SPACING, (640, 483), "kannala-brandt", board_warp=False)
    assert flat.board_warp is None and flat.board_warp_sigmas is None
    calibrated = result.camera
    assert calibrated.observed_theta_max_deg is not None
    sigma = calibrated.projection_uncertainty(np.array([[320.0, 241.0], [-300.0, 0.0]]), distance=1.0)
    assert 0 < sigma[0] < 0.2 and sigma[1] > 10 * sigma[0]  # far outside the data: extrapolated
    # The record survives pickling (DataLoader workers) and fishcam JSON, not other formats.
    assert pickle.loads(pickle.dumps(calibrated)).observed_theta_max_deg == calibrated.observed_theta_max_deg
    assert fishcam.Camera.from_json(calibrated.to_json()).observed_theta_max_deg == calibrated.observed_theta_max_deg
    with pytest.raises(fishcam.Error, match="no calibration"):
        camera.projection_uncertainty(np.array([[320.0, 241.0]]))


def test_limited_to_observed_unprojects_exactly_what_was_observed() -> None:
    camera = lens()
    left, _ = stereo_boards(camera, 0.2, 40, 0.2, 1)
    calibrated = fishcam.calibrate(left, BOARD, SPACING, (640, 483), "kannala-brandt", threads=2).camera
    assert calibrated.theta_limit_by_azimuth_deg is None
    limited = calibrated.limited_to_observed()
    limits = limited.theta_limit_by_azimuth_deg
    assert limits is not None and len(limits) == 24
    assert max(limits) == pytest.approx(limited.domain.theta_max_deg, abs=1e-12)
    u, v = np.meshgrid(np.arange(0, 640, 7.0), np.arange(0, 483, 7.0))
    pixels = np.stack([u.ravel(), v.ravel()], axis=1)
    rays, ok = calibrated.unproject(pixels)
    observed = np.zeros_like(ok)
    observed[ok] = calibrated.observed(rays[ok])
    limited_rays, limited_ok = limited.unproject(pixels)
    np.testing.assert_array_equal(limited_ok, observed)
    assert 0 < observed.sum() < ok.sum()
    assert np.isnan(limited_rays[~limited_ok]).all()
    # The limit travels with the camera: pickling, fishcam JSON, the cache key.
    for back in (pickle.loads(pickle.dumps(limited)), fishcam.Camera.from_json(limited.to_json())):
        assert back.theta_limit_by_azimuth_deg == pytest.approx(limits, abs=1e-12)
        np.testing.assert_array_equal(back.unproject(pixels)[1], limited_ok)
    text = json.loads(limited.to_json())
    smallest = int(np.argmin(limits))
    text["theta_limit_by_azimuth_deg"][smallest] += 1  # theta_limit_deg (the largest) unchanged
    other = fishcam.Camera.from_json(json.dumps(text))
    assert other.parameters_key() != limited.parameters_key() and other != limited
    wider = calibrated.limited_to_observed(margin_deg=5)
    assert wider.theta_limit_by_azimuth_deg == pytest.approx([min(a + 5, 180) for a in limits])


def test_calibrate_refuses_what_cannot_be_a_camera() -> None:
    left, _ = stereo_boards(lens(), 0.2, 40, 0.2, 2)
    with pytest.raises(fishcam.Error, match="pass --board 9x6"):
        fishcam.calibrate(left, (6, 9), SPACING, (640, 483), "kannala-brandt")
    with pytest.raises(fishcam.Error, match="at least 3"):
        fishcam.calibrate(left[:2], BOARD, SPACING, (640, 483), "kannala-brandt")
    with pytest.raises(fishcam.Error):
        fishcam.calibrate([("a.png", np.zeros((54, 3)))], BOARD, SPACING, (640, 483), "kannala-brandt")


def test_calibrate_rig_recovers_a_stereo_pair() -> None:
    camera = lens()
    left, right = stereo_boards(camera, 0.2, 60, 0.0, 3)
    assert len(set(n for n, _ in left) & set(n for n, _ in right)) >= 5
    rig = fishcam.calibrate_rig(
        [(left, (640, 483), "kannala-brandt"), (right, (640, 483), "kannala-brandt")], BOARD, SPACING, threads=2
    )
    assert isinstance(rig, fishcam.RigCalibration) and len(rig.cameras) == 2
    assert rig.rms_px < 1e-6
    r, t = rig.cameras[1].camera.pose  # camera 1 -> camera 0
    assert np.allclose(t, [0.2, 0, 0], atol=1e-5)
    assert np.allclose(r, rotation(np.radians(10), 0, 0), atol=1e-6)
    r0, t0 = rig.cameras[0].camera.pose
    assert np.allclose(r0, np.eye(3)) and np.allclose(t0, 0)
    assert rig.rotation_sigma_deg[0] == 0
    with pytest.raises(fishcam.Error, match="at least 2 cameras"):
        fishcam.calibrate_rig([(left, (640, 483), "kannala-brandt")], BOARD, SPACING)


def test_partial_boards_are_nan_rows_in_files_calibrations_and_rigs(tmp_path: Path) -> None:
    """A partial board (a ChArUco view cut by the image's edge, or mrcal-cull-corners'
    level '-') is its W*H rows with NaN for the corners not observed, read and given
    back alike; the rig's joint solve takes them too."""
    camera = lens()
    left, right = stereo_boards(camera, 0.2, 60, 0.0, 3)
    cut = []
    for k, (name, corners) in enumerate(right):
        corners = corners.copy()
        if k % 2 == 0:
            corners[: 9 * (1 + k % 3)] = np.nan  # the first one to three rows missing
        cut.append((name, corners))
    rig = fishcam.calibrate_rig(
        [(left, (640, 483), "kannala-brandt"), (cut, (640, 483), "kannala-brandt")], BOARD, SPACING, threads=2
    )
    assert rig.rms_px < 1e-6
    assert np.allclose(rig.cameras[1].camera.pose[1], [0.2, 0, 0], atol=1e-5)
    assert rig.cameras[1].corners == sum(int(np.isfinite(c[:, 0]).sum()) for _, c in cut)
    # The corners file: mrcal's "- - -" rows; a culled corner keeps x y with level '-'.
    rows = ["# filename x y level"]
    for name, corners in cut[:2]:
        rows += [f"{name} - - -" if np.isnan(x) else f"{name} {x!r} {y!r} 0" for x, y in corners]
    rows[1 + 20] = rows[1 + 20][: rows[1 + 20].rfind(" ")] + " -"  # corner 20 of the first image culled
    (tmp_path / "c.vnl").write_text("\n".join(rows) + "\n")
    back = fishcam.read_corners(str(tmp_path / "c.vnl"), BOARD)
    assert [b[1].shape for b in back] == [(54, 2), (54, 2)]
    assert np.isnan(back[0][1][:9]).all() and np.isnan(back[0][1][20]).all()
    assert np.isfinite(back[0][1][9:20]).all()
    assert np.array_equal(back[1][1], cut[1][1])
    with pytest.raises(fishcam.Error, match="a partial board \\(NaN rows\\) lists all 54 corners"):
        fishcam.calibrate([(n, c[:50]) for n, c in cut], BOARD, SPACING, (640, 483), "kannala-brandt")


def test_calibrate_rig_holds_a_given_cameras_intrinsics() -> None:
    """A Camera in place of a model name: its intrinsics held fixed (calibrate
    --fix-intrinsics FILE), only where it sits solved."""
    camera = lens()
    left, right = stereo_boards(camera, 0.2, 60, 0.0, 3)
    rig = fishcam.calibrate_rig([(left, (640, 483), "kannala-brandt"), (right, (640, 483), camera)], BOARD, SPACING)
    assert rig.fixed_intrinsics == [False, True]
    fixed = rig.cameras[1].camera
    assert list(fixed.parameters) == list(camera.parameters) and list(fixed.principal_point) == list(
        camera.principal_point
    )
    r, t = fixed.pose
    assert np.allclose(t, [0.2, 0, 0], atol=1e-5)
    assert np.allclose(r, rotation(np.radians(10), 0, 0), atol=1e-6)
    with pytest.raises(fishcam.Error, match=r"cameras\[1\]: expected a model name or a fishcam.Camera"):
        fishcam.calibrate_rig([(left, (640, 483), "kannala-brandt"), (right, (640, 483), 3)], BOARD, SPACING)


APRILGRID = "aprilgrid:6x5:0.1:0.3"  # Kalibr's: 6 x 5 tags of 0.1 m, 0.03 m between them


def aprilgrid_points() -> np.ndarray:
    """The grid's 12 x 10 corners in board order, written out independently of the
    library: each tag's two edges 0.1 apart, the tags 0.13 apart."""
    along = [(i // 2) * 0.13 + (i % 2) * 0.1 for i in range(12)]
    down = along[:10]
    return np.array([[x, y, 0.0] for y in down for x in along])


def aprilgrid_views(camera: fishcam.Camera, count: int, seed: int, baseline: float = 0.0) -> list[Any]:
    """Grids close to the camera and to the side (this lens sees past 90 degrees: a grid
    leaves the image when part of it is near or behind the camera's plane), seen from
    `baseline` metres to the right (the same grids for every baseline): the corners outside are NaN rows
    (what read_corners gives for a partial board)."""
    random = np.random.default_rng(seed)
    points = aprilgrid_points() - aprilgrid_points().mean(axis=0)
    views: list[Any] = []
    for i in range(count):
        r = rotation(*random.uniform(-0.7, 0.7, 3))
        centre = np.array([random.uniform(-1.5, 1.5), random.uniform(-1.2, 1.2), random.uniform(0.1, 0.4)])
        pixels, ok = camera.project(points @ r.T + centre - [baseline, 0, 0])
        inside = ok & (pixels[:, 0] >= 0) & (pixels[:, 1] >= 0) & (pixels[:, 0] <= 639) & (pixels[:, 1] <= 482)
        if inside.sum() >= 20:
            views.append((f"cam/{i:03d}.png", np.where(inside[:, None], pixels, np.nan)))
    return views


def test_aprilgrid_targets_calibrate_by_their_text(tmp_path: Path) -> None:
    """A target's text in place of (W, H) and a spacing (what `fishcam detect-corners
    --target` found): partial grids calibrate the lens exactly; the same corners taken
    for an evenly spaced chessboard are refused."""
    camera = lens()
    views = aprilgrid_views(camera, 60, 5)
    partial = sum(bool(np.isnan(c).any()) for _, c in views)
    assert len(views) >= 20 and partial >= 15, (len(views), partial)
    result = fishcam.calibrate(views, APRILGRID, None, (640, 483), "kannala-brandt", board_warp=False)
    # Every view and corner used (none left in a wrong basin as outliers), the lens
    # exact to past 90 degrees.
    assert result.rms_px < 1e-6 and not result.outliers and len(result.images) == len(views)
    assert result.corners == sum(int(np.isfinite(c[:, 0]).sum()) for _, c in views)
    theta, phi = np.meshgrid(np.radians(np.linspace(1, 95, 20)), np.radians(np.arange(0, 360, 15)))
    rays = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1).reshape(-1, 3)
    (truth, seen), (solved, solved_seen) = camera.project(rays), result.camera.project(rays)
    assert seen.all() and solved_seen.all() and np.abs(solved - truth).max() < 1e-6
    # The same corners taken for an evenly spaced chessboard: refused (the gaps break its grid).
    with pytest.raises(fishcam.Error, match="not in the board order of a 12x10 board"):
        fishcam.calibrate(views, (12, 10), 0.1, (640, 483), "kannala-brandt", board_warp=False)

    # A rig of two cameras looking at the same grids (camera 1 0.2 m to the right).
    right = aprilgrid_views(camera, 60, 5, baseline=0.2)
    rig = fishcam.calibrate_rig(
        [(views, (640, 483), "kannala-brandt"), (right, (640, 483), "kannala-brandt")], APRILGRID, None, threads=2
    )
    assert rig.rms_px < 1e-6 and np.allclose(rig.cameras[1].camera.pose[1], [0.2, 0, 0], atol=1e-6)

    # The corners file: read by the target's text, 120 rows a view, NaN where not seen.
    rows = ["# filename x y level"]
    for name, corners in views[:3]:
        rows += [f"{name} - - -" if np.isnan(x) else f"{name} {x!r} {y!r} 0" for x, y in corners]
    (tmp_path / "grid.vnl").write_text("\n".join(rows) + "\n")
    back = fishcam.read_corners(str(tmp_path / "grid.vnl"), APRILGRID)
    assert [name for name, _ in back] == [name for name, _ in views[:3]]
    for (_, read), (_, given) in zip(back, views[:3]):
        assert np.array_equal(read, given, equal_nan=True)


def test_targets_and_chessboards_say_what_they_need() -> None:
    views = aprilgrid_views(lens(), 30, 5)
    for board, spacing, message in (
        (APRILGRID, 0.1, "spacing: a target's sizes are in its text"),
        (BOARD, None, r"spacing: a chessboard \(W, H\) needs its spacing"),
        ("aprilgrid:6x5:0.1", None, "aprilgrid"),
        ("checkerboard:9x6", None, "expected charuco:COLSxROWS"),
    ):
        with pytest.raises(fishcam.Error, match=message):
            fishcam.calibrate(views, board, spacing, (640, 483), "kannala-brandt")
    with pytest.raises(fishcam.Error, match="expected charuco:COLSxROWS"):
        fishcam.read_corners("none.vnl", "grid")
