"""fishcam.torch.warp_batch: batched tensors sampled by grid_sample against the
per-sample path (CPU tensors here; the code path is the device's)."""

import os

import cv2
import fishcam
import fishcam.torch as ft
import numpy as np
import pytest
import torch
from conftest import DATA


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """A rendered street scene (real edges and labels) and its camera at 320x242."""
    import subprocess

    binary = os.environ.get(
        "FISHCAM_BINARY", os.path.join(os.path.dirname(__file__), "..", "..", "build", "tools", "fishcam")
    )
    out = tmp_path_factory.mktemp("batch")
    camera = fishcam.Camera.read(os.path.join(DATA, "woodscape_front.json")).resized(320, 242)
    camera.write(str(out / "cam.json"))
    subprocess.run(
        [binary, "render", str(out / "cam.json"), "--out-image", str(out / "i.png"), "--out-label", str(out / "l.png")],
        check=True,
        capture_output=True,
    )
    image = cv2.imread(str(out / "i.png"), cv2.IMREAD_UNCHANGED)
    labels = cv2.imread(str(out / "l.png"), cv2.IMREAD_UNCHANGED)
    return camera, image, labels


def test_the_batched_path_agrees_with_the_per_sample_path(scene):
    camera, image, labels = scene
    seeds = [3, 14, 15, 92]
    changes = [fishcam.random_change("medium", s) for s in seeds]
    images = torch.from_numpy(np.stack([image] * len(seeds))).permute(0, 3, 1, 2)
    masks = torch.from_numpy(np.stack([labels] * len(seeds)).astype(np.int64))
    out = ft.warp_batch(images, camera, changes, masks=masks, fill=0, fill_mask=255)
    assert out.images.dtype == torch.uint8 and out.images.shape == images.shape
    assert out.masks.dtype == torch.int64 and out.valid.dtype == torch.bool
    warp = fishcam.ViewpointWarp(camera)
    for i, change in enumerate(changes):
        expected = warp.warp(image=image, labels=labels, change=change, label_fill=255, return_valid=True)
        valid = expected["valid"]
        # Validity: the same decision but within a pixel of its border.
        disagree = valid != out.valid[i].numpy()
        border = valid ^ np.roll(valid, 1, 0) | valid ^ np.roll(valid, 1, 1)
        assert (disagree & ~border).sum() <= 4
        # Images: one grey level away from edges: where the source varies by at most 16
        # grey levels around the sampled point (a 1/32 px map difference is then worth
        # at most half a grey level before rounding).
        got = out.images[i].permute(1, 2, 0).numpy().astype(int)
        want = expected["image"].astype(int)
        kernel = np.ones((3, 3), np.uint8)
        variation = (cv2.dilate(image, kernel) - cv2.erode(image, kernel)).max(-1)
        map_x, map_y, map_valid = warp.maps(change, grid=True)
        both = valid & out.valid[i].numpy() & map_valid
        u = np.clip(np.rint(np.nan_to_num(map_x)), 0, camera.width - 1).astype(int)
        v = np.clip(np.rint(np.nan_to_num(map_y)), 0, camera.height - 1).astype(int)
        smooth = both & (variation[v, u] <= 16)
        assert smooth.sum() > 0.3 * smooth.size
        assert np.abs(got - want)[smooth].max() <= 1
        # Masks: nearest, so equal but where the map's 1/32 px differences change the nearest pixel.
        both = valid & out.valid[i].numpy()
        assert (out.masks[i].numpy()[both] != expected["labels"][both]).mean() < 0.01
        assert set(np.unique(out.masks[i].numpy()[~out.valid[i].numpy()])) <= {255}
    # The maps are the grid path's: within 1/16 px of the per-pixel map.
    gx, gy, gv = warp.maps(changes[0], grid=True)
    ex, ey, ev = warp.maps(changes[0], exact=True)
    both = gv & ev
    assert np.max(np.hypot(gx - ex, gy - ey)[both]) <= 1 / 16


def test_float_images_per_sample_cameras_and_errors(scene):
    camera, image, labels = scene
    images = torch.from_numpy(np.stack([image, image])).permute(0, 3, 1, 2).float() / 255
    changes = [fishcam.random_change("small", 1), fishcam.ViewpointChange()]
    out = ft.warp_batch(images, [camera, camera], changes)
    assert out.images.dtype == torch.float32 and out.masks is None
    # The identity leaves every valid pixel as it was.
    same = out.valid[1]
    assert torch.allclose(out.images[1][:, same], images[1][:, same], atol=2e-3)  # the float kernel's 1e-3 px
    with pytest.raises(fishcam.Error, match="one per image"):
        ft.warp_batch(images, camera, changes[:1])
    with pytest.raises(fishcam.Error, match=r"\(B, C, H, W\)"):
        ft.warp_batch(images[0], camera, changes)
    with pytest.raises(fishcam.Error, match="are 320x242 but cameras"):
        ft.warp_batch(images, camera.resized(160, 121), changes)
    with pytest.raises(fishcam.Error, match="integer or bool"):
        ft.warp_batch(images, camera, changes, masks=torch.zeros(2, 242, 320))
    with pytest.raises(fishcam.Error, match="ViewpointChange"):
        ft.warp_batch(images, camera, [None, None])
