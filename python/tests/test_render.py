"""fishcam.render: the bundled and seeded streets as numpy arrays, checked against the
geometry (a rotation-only change moves points exactly) and against bad input."""

import os

import numpy as np
import pytest

import fishcam

DATA = os.environ.get("FISHCAM_DATA_DIR", os.path.join(os.path.dirname(__file__), "..", "..", "data"))


@pytest.fixture(scope="module")
def camera() -> fishcam.Camera:
    front = fishcam.Camera.read(os.path.join(DATA, "woodscape_front.json"))
    return front.resized(320, 242)


def test_arrays_and_determinism(camera):
    a = fishcam.render(camera, scene_seed=4)
    b = fishcam.render(camera, scene_seed=4)
    assert set(a) == {"image", "mask", "depth"}
    assert a["image"].shape == (242, 320, 3) and a["image"].dtype == np.uint8
    assert a["mask"].shape == (242, 320) and a["mask"].dtype == np.uint8
    assert a["depth"].shape == (242, 320) and a["depth"].dtype == np.float32
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    other = fishcam.render(camera, scene_seed=5)
    assert (other["mask"] != a["mask"]).mean() > 0.05
    assert a["mask"].max() < 10
    # The sky is at infinity, the ground and objects at finite ranges.
    sky = np.isinf(a["depth"])
    assert sky.any() and (a["mask"][sky] == 0).all()
    assert np.isfinite(a["depth"][a["mask"] == 1]).all()


def test_a_rotation_moves_the_scene_point_of_a_pixel_exactly(camera):
    """The pixel a scene point lands on after a rotation-only change has that point's
    range and label (away from label boundaries)."""
    change = fishcam.ViewpointChange(rotation_deg=(4.0, -9.0, 6.0))
    before = fishcam.render(camera, scene_seed=8, supersampling=1)
    after = fishcam.render(camera, scene_seed=8, change=change, supersampling=1)
    v, u = np.mgrid[20:222:7, 20:300:7]
    pixels = np.stack([u.ravel(), v.ravel()], axis=1).astype(np.float64)
    rays, ok = camera.unproject(pixels)
    moved = rays @ change.rotation.T
    target, seen = camera.project(moved)
    keep = ok & seen
    t = np.round(target[keep]).astype(int)
    inside = (t[:, 0] >= 2) & (t[:, 0] < 318) & (t[:, 1] >= 2) & (t[:, 1] < 240)
    src = pixels[keep][inside].astype(int)
    t = t[inside]
    labels_before = before["mask"][src[:, 1], src[:, 0]]
    # Pixels whose 5x5 neighbourhood after the change has one label only.
    window = np.stack([after["mask"][t[:, 1] + dy, t[:, 0] + dx] for dy in range(-2, 3) for dx in range(-2, 3)])
    uniform = (window == window[0]).all(axis=0)
    assert uniform.sum() > 500
    assert (labels_before[uniform] == after["mask"][t[uniform, 1], t[uniform, 0]]).mean() > 0.995


def test_bad_input(camera):
    with pytest.raises(fishcam.Error, match="supersampling"):
        fishcam.render(camera, supersampling=0)
    unmounted = fishcam.Camera.read(os.path.join(DATA, "equidistant.json"))
    with pytest.raises(fishcam.Error, match="no pose"):
        fishcam.render(unmounted, scene_seed=1)
