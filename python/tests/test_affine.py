"""The affine baseline (paper §V.C.2) in Python: the CLI's bytes, identity, labels, torch."""

import json
import os
import subprocess

import cv2
import fishcam
import fishcam.torch
import numpy as np
import pytest
import torch
from conftest import BINARY, DATA
from fishcam.transforms import RandomAffine

CAMERA = os.path.join(DATA, "woodscape_front.json")


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, size=(966, 1280, 3), dtype=np.uint8)
    labels = ((np.arange(1280)[None, :] // 37 + np.arange(966)[:, None] // 23) % 10).astype(np.uint8)
    return image, labels


def test_seeded_run_equals_fishcam_augment(scene, tmp_path):
    if not BINARY:
        pytest.skip("FISHCAM_BINARY not set (run through CTest)")
    image, labels = scene
    cv2.imwrite(str(tmp_path / "i.png"), image)
    cv2.imwrite(str(tmp_path / "l.png"), labels)
    t = RandomAffine(preset="train", fill_mask=255)
    for seed in (3, 2**64 - 1):
        result = subprocess.run(
            [
                BINARY,
                "augment",
                CAMERA,
                "--image",
                tmp_path / "i.png",
                "--label",
                tmp_path / "l.png",
                "--out-image",
                tmp_path / "a.png",
                "--out-label",
                tmp_path / "al.png",
                "--force",
                "--method",
                "affine",
                "--preset",
                "train",
                "--seed",
                str(seed),
                "--label-fill",
                "255",
                "--json",
            ],
            capture_output=True,
            text=True,
        )
        assert result.returncode == 0, result.stderr
        cli = json.loads(result.stdout)
        out = t(image=image, mask=labels, seed=seed)
        np.testing.assert_array_equal(out["image"], cv2.imread(str(tmp_path / "a.png"), cv2.IMREAD_UNCHANGED))
        np.testing.assert_array_equal(out["mask"], cv2.imread(str(tmp_path / "al.png"), cv2.IMREAD_UNCHANGED))
        for key in ("method", "rotation_deg", "translation", "scale", "seed"):
            assert out["change"][key] == cli[key], key


def test_identity_is_an_exact_copy_and_labels_keep_their_values(scene):
    image, labels = scene
    out = fishcam._fishcam.affine_warp(image=image, labels=labels, change=fishcam._fishcam.AffineChange())
    np.testing.assert_array_equal(out["image"], image)
    np.testing.assert_array_equal(out["labels"], labels)
    t = RandomAffine(preset="train", fill_mask=200)
    for seed in range(5):
        mask = t(mask=labels, seed=seed)["mask"]
        assert set(np.unique(mask)) <= set(range(10)) | {200}
    # p = 0: the identity, still reported
    skipped = RandomAffine(p=0)(image=image, seed=1)
    np.testing.assert_array_equal(skipped["image"], image)
    assert skipped["change"]["scale"] == 1.0


def test_custom_ranges_and_bad_arguments():
    t = RandomAffine(max_rotation_deg=5, max_translation=0.01, scale_range=(0.9, 1.1))
    for seed in range(50):
        c = t.change_for(seed)
        assert abs(c.rotation_deg) <= 5 and max(abs(c.translation)) <= 0.01 and 0.9 <= c.scale <= 1.1
    with pytest.raises(fishcam.Error):
        RandomAffine(preset="huge")
    with pytest.raises(fishcam.Error):
        RandomAffine(max_rotation_deg=5, max_translation=0.1)
    with pytest.raises(fishcam.Error):
        RandomAffine(max_rotation_deg=5, max_translation=0.1, scale_range=(1.5, 0.5))
    with pytest.raises(fishcam.Error):
        fishcam._fishcam.AffineChange(scale=0)
    with pytest.raises(fishcam.Error):
        RandomAffine()(seed=1)


def test_torch_adapter_keeps_tensors_and_matches_numpy(scene):
    from torchvision import tv_tensors

    image, labels = scene
    module = fishcam.torch.RandomAffine(preset="medium")
    tensor = tv_tensors.Image(torch.from_numpy(image).permute(2, 0, 1))
    with fishcam.torch.sample_seed(11) as records:
        out_image, out_mask = module((tensor, tv_tensors.Mask(torch.from_numpy(labels))))
    assert out_image.shape == tensor.shape and out_mask.shape == labels.shape
    expected = RandomAffine(preset="medium")(image=image, mask=labels, seed=11)
    np.testing.assert_array_equal(out_image.permute(1, 2, 0).numpy(), expected["image"])
    np.testing.assert_array_equal(out_mask.numpy(), expected["mask"])
    assert records == [expected["change"]] and records[0]["method"] == "affine"
