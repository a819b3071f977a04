"""fishcam.render: the bundled and seeded streets as numpy arrays, checked against the
geometry (a rotation-only change moves points exactly) and against bad input."""

import os

import fishcam
import fishcam.transforms
import numpy as np
import pytest
from conftest import DATA


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


# --- depth="map": the sample's own depth map places the scene points ---


def _away_from_boundaries(labels, valid):
    """Pixels whose 5x5 neighbourhood holds one label and has a source all around."""
    windows = np.lib.stride_tricks.sliding_window_view(np.pad(labels, 2, mode="edge"), (5, 5))
    uniform = (windows == labels[..., None, None]).all(axis=(-1, -2))
    valid_windows = np.lib.stride_tricks.sliding_window_view(np.pad(valid, 2, constant_values=False), (5, 5))
    return uniform & valid_windows.all(axis=(-1, -2))


def _translated_change():
    return fishcam.ViewpointChange(rotation_deg=(3.0, -6.0, 4.0), translation=(0.15, -0.1, 0.25))  # metres


def test_depth_map_augmentation_matches_the_moved_camera_render(camera):
    source = fishcam.render(camera, scene_seed=13, supersampling=1)
    change = _translated_change()
    truth = fishcam.render(camera, scene_seed=13, change=change, supersampling=1)
    warp = fishcam.ViewpointWarp(camera)
    result = warp.warp(
        image=source["image"],
        labels=source["mask"],
        change=change,
        depth="map",
        depth_map=source["depth"],
        label_fill=255,
        return_valid=True,
    )
    where = _away_from_boundaries(truth["mask"], result["valid"])
    assert where.sum() > 20000
    assert (result["labels"][where] == truth["mask"][where]).mean() > 0.98
    # The depth map itself, re-expressed in the moved camera: the truth's range.
    depth = warp.warp_depth(source["depth"], change, depth="map")
    finite = where & np.isfinite(truth["depth"]) & np.isfinite(depth)
    relative = np.abs(depth[finite] - truth["depth"][finite]) / truth["depth"][finite]
    # Nearest-neighbour values along the exact ray of the sampled position: within half
    # a pixel's change of range along the surface.
    assert finite.sum() > 10000 and np.median(relative) < 5e-3 and np.percentile(relative, 95) < 0.03, (
        np.median(relative),
        np.percentile(relative, 95),
    )
    # Keypoints: each pixel's scene point moved and projected (independently, here).
    v, u = np.mgrid[30:210:9, 30:290:9]
    points = np.stack([u.ravel(), v.ravel()], axis=1).astype(np.float64)
    mapped, visible = warp.forward(points, change, depth="map", depth_map=source["depth"])
    rays, ok = camera.unproject(points)
    ranges = source["depth"][v.ravel(), u.ravel()].astype(np.float64)
    finite_points = ok & np.isfinite(ranges)
    moved = (rays[finite_points] * ranges[finite_points, None]) @ change.rotation.T + change.translation
    expected, seen = camera.project(moved)
    np.testing.assert_allclose(mapped[finite_points][seen], expected[seen], atol=1e-6)
    assert visible.sum() > 300


def test_depth_map_transform_and_errors(camera):
    source = fishcam.render(camera, scene_seed=13, supersampling=1)
    t = fishcam.transforms.RandomViewpoint(camera, depth="map", preset="medium", fill_mask=255)
    out = t(image=source["image"], mask=source["mask"], depth_map=source["depth"], seed=5)
    change = fishcam.ViewpointChange(out["change"]["rotation_deg"], out["change"]["translation"])
    truth = fishcam.render(camera, scene_seed=13, change=change, supersampling=1)
    where = _away_from_boundaries(truth["mask"], out["mask"] != 255)
    assert where.sum() > 10000
    assert (out["mask"][where] == truth["mask"][where]).mean() > 0.98
    with pytest.raises(fishcam.Error, match="depth map"):
        t(image=source["image"], seed=5)
    with pytest.raises(fishcam.Error, match="float32"):
        t(image=source["image"], depth_map=source["depth"].astype(np.float64), seed=5)
    with pytest.raises(fishcam.Error, match="depth"):
        fishcam.transforms.RandomViewpoint(camera, depth="nearest")
    warp = fishcam.ViewpointWarp(camera)
    with pytest.raises(fishcam.Error, match="depth_map"):
        warp.warp(image=source["image"], change=change, depth="map")
    with pytest.raises(fishcam.Error, match="depth_map"):
        warp.warp(image=source["image"], change=change, depth="infinity", depth_map=source["depth"])


def test_depth_map_in_a_torchvision_pipeline(camera):
    torch = pytest.importorskip("torch")
    fishcam_torch = pytest.importorskip("fishcam.torch")
    from torchvision import tv_tensors

    source = fishcam.render(camera, scene_seed=13, supersampling=1)
    sample = {
        "image": tv_tensors.Image(torch.from_numpy(source["image"]).permute(2, 0, 1)),
        "mask": tv_tensors.Mask(torch.from_numpy(source["mask"])),
        "depth": fishcam_torch.DepthMap(torch.from_numpy(source["depth"])),
        "camera": camera,
    }
    t = fishcam_torch.RandomViewpoint(depth="map", preset="small", fill_mask=255)
    with fishcam_torch.sample_seed(11) as records:
        out = t(sample)
    change = fishcam.ViewpointChange(records[0]["rotation_deg"], records[0]["translation"])
    truth = fishcam.render(camera, scene_seed=13, change=change, supersampling=1)
    mask = out["mask"].numpy()
    where = _away_from_boundaries(truth["mask"], mask != 255)
    assert where.sum() > 10000
    assert (mask[where] == truth["mask"][where]).mean() > 0.98
    del sample["depth"]
    with pytest.raises(fishcam.Error, match="DepthMap"):
        t(sample)
