"""fishcam.albumentations inside albumentations pipelines: Compose with boxes,
keypoints and additional targets under one change, the numpy transform's result for
the same seed, Compose(seed=) reproducibility, ReplayCompose replay."""

import json
import os

import fishcam
import numpy as np
import pytest

if os.environ.get("FISHCAM_REQUIRE_PEERS") != "1":
    pytest.importorskip("albumentations")
import albumentations as A  # noqa: E402
import fishcam.albumentations as fa  # noqa: E402
from conftest import DATA


@pytest.fixture(scope="module")
def cam():
    return fishcam.Camera.read(os.path.join(DATA, "woodscape_front.json")).resized(320, 242)


@pytest.fixture(scope="module")
def data(cam):
    rng = np.random.default_rng(0)
    h, w = cam.height, cam.width
    return dict(
        image=rng.integers(0, 256, (h, w, 3), dtype=np.uint8),
        image2=rng.integers(0, 256, (h, w), dtype=np.uint8),
        mask=rng.integers(0, 10, (h, w)).astype(np.int64),
        instances=rng.integers(0, 3, (h, w)).astype(np.int32),
        bboxes=np.array([[100.0, 90.0, 160.0, 140.0], [2.0, 2.0, 12.0, 12.0]]),
        labels=[4, 7],
        keypoints=np.array([[160.0, 121.0], [60.0, 50.0], [1.0, 1.0]]),
        depth=np.full((h, w), 5.0, np.float32),
        polygons=[np.array([[100.0, 90], [160, 90], [160, 140]])],
    )


def compose(cam, seed, min_visibility=0.0):
    return A.Compose(
        [fa.RandomViewpoint(cam, preset="large")],
        bbox_params=A.BboxParams(format="pascal_voc", label_fields=["labels"], min_visibility=min_visibility),
        keypoint_params=A.KeypointParams(format="xy", remove_invisible=False),
        additional_targets={"image2": "image", "instances": "mask"},
        seed=seed,
    )


def test_every_target_under_the_numpy_transforms_change(cam, data):
    pipeline = compose(cam, seed=5)
    out = pipeline(**data, camera=cam)
    seed = pipeline.transforms[0].params["seed"]
    expected = fishcam.transforms.RandomViewpoint(cam, preset="large")(
        image=data["image"],
        mask=data["mask"],
        depth_map=data["depth"],
        keypoints=data["keypoints"],
        boxes=data["bboxes"],
        polygons=data["polygons"],
        camera=cam,
        seed=seed,
    )
    np.testing.assert_array_equal(out["image"], expected["image"])
    np.testing.assert_array_equal(
        out["image2"], fishcam.transforms.RandomViewpoint(cam, preset="large")(image=data["image2"], seed=seed)["image"]
    )
    assert out["mask"].dtype == np.int64 and np.array_equal(out["mask"], expected["mask"])
    assert out["instances"].dtype == np.int32
    np.testing.assert_array_equal(out["depth"], expected["depth_map"])
    np.testing.assert_allclose(out["polygons"][0], expected["polygons"][0])
    assert out["camera"] == expected["camera"]
    # Keypoints: exact (albumentations keeps them in float32); hidden ones NaN.
    kp = np.array(out["keypoints"], dtype=np.float64)
    seen = expected["keypoints_visible"]
    np.testing.assert_allclose(kp[seen], expected["keypoints"][seen], atol=1e-3)
    # Boxes: the tight box of the outline, then albumentations' own clipping.
    boxes = np.array(out["bboxes"])
    kept = np.array(out["labels"]) == 4
    np.testing.assert_allclose(boxes[kept][0], np.clip(expected["boxes"][0], 0, (320, 242, 320, 242)), atol=1e-3)


def test_seeds_reproduce_and_replay(cam, data):
    a = compose(cam, seed=1)(**data)
    b = compose(cam, seed=1)(**data)
    c = compose(cam, seed=2)(**data)
    assert np.array_equal(a["image"], b["image"]) and not np.array_equal(a["image"], c["image"])
    replay = A.ReplayCompose([fa.RandomViewpoint(cam, preset="medium"), A.HorizontalFlip(p=0.5)])
    first = replay(image=data["image"], mask=data["mask"])
    again = A.ReplayCompose.replay(first["replay"], image=data["image"], mask=data["mask"])
    assert np.array_equal(first["image"], again["image"]) and np.array_equal(first["mask"], again["mask"])


def test_to_dict_round_trips_a_constructor_camera(cam, data):
    """A.to_dict writes the constructor's camera as its fishcam JSON object (JSON all
    through) and A.from_dict rebuilds the same pipeline: the same camera, the same
    image for the same seed."""
    pipeline = A.Compose([fa.RandomViewpoint(cam, preset="medium", fill_mask=255), A.HorizontalFlip(p=0.5)], seed=4)
    described = json.loads(json.dumps(A.to_dict(pipeline)))
    assert described["transform"]["transforms"][0]["camera"]["fishcam_camera"] == 1
    again = A.from_dict(described)
    assert again.transforms[0].camera == cam
    again.set_random_seed(4)
    pipeline.set_random_seed(4)
    assert np.array_equal(pipeline(image=data["image"])["image"], again(image=data["image"])["image"])
    with pytest.raises(fishcam.Error, match="camera: expected a fishcam.Camera or its fishcam JSON object"):
        fa.RandomViewpoint("front.json")
    with pytest.raises(fishcam.Error):
        fa.RandomViewpoint({"fishcam_camera": 1, "model": "nonsense"})


def test_min_visibility_drops_boxes_that_leave(cam, data):
    """albumentations' min_visibility, on the boxes fishcam returns unclipped: a box
    survives exactly when at least that much of its transformed box is in view."""
    dropped = 0
    for seed in range(12):
        pipeline = compose(cam, seed=seed, min_visibility=0.9)
        out = pipeline(**data)
        _, visibility = (
            fishcam.transforms.RandomViewpoint(cam, preset="large")
            .draw(seed=pipeline.transforms[0].params["seed"])
            .boxes(data["bboxes"])
        )
        assert (7 in out["labels"]) == (visibility[1] >= 0.9), seed
        dropped += 7 not in out["labels"]
    assert dropped >= 3, "too few seeds moved the corner box out of view to test anything"


def test_affine_and_errors(cam, data):
    out = A.Compose([fa.RandomAffine(preset="small")], seed=0)(
        image=data["image"], mask=data["mask"], depth=data["depth"]
    )
    assert out["image"].shape == data["image"].shape and out["depth"].dtype == np.float32
    assert set(np.unique(out["depth"][np.isfinite(out["depth"])])) <= {5.0}
    with pytest.raises(fishcam.Error, match="camera: none given"):
        A.Compose([fa.RandomViewpoint()])(image=data["image"])
    with pytest.raises(fishcam.Error, match="is 10x10 but the camera is 320x242"):
        A.Compose([fa.RandomViewpoint(cam)])(image=np.zeros((10, 10), np.uint8))
    assert "preset='large'" in repr(fa.RandomViewpoint(cam, preset="large"))


def test_one_draw_per_call_and_the_image_and_mask_in_one_pass(cam, data, monkeypatch):
    """albumentations applies a transform target by target: the change is drawn once
    for all of them, and the image and the mask are warped together (the maps computed
    once), with the same outputs as the numpy transform's."""
    draws, passes = [], []
    draw, warp = fishcam.transforms.RandomViewpoint.draw, fishcam.ViewpointWarp.warp

    def counted_draw(self, *args, **kwargs):
        draws.append(1)
        return draw(self, *args, **kwargs)

    def counted_warp(self, *args, **kwargs):
        passes.append((kwargs.get("image") is not None, kwargs.get("labels") is not None))
        return warp(self, *args, **kwargs)

    monkeypatch.setattr(fishcam.transforms.RandomViewpoint, "draw", counted_draw)
    monkeypatch.setattr(fishcam.ViewpointWarp, "warp", counted_warp)
    pipeline = compose(cam, seed=3)
    out = pipeline(
        image=data["image"],
        mask=data["mask"],
        bboxes=data["bboxes"],
        labels=data["labels"],
        keypoints=data["keypoints"],
        depth=data["depth"],
        camera=cam,
    )
    assert len(draws) == 1
    assert passes == [(True, True)]  # image and mask together, nothing else rasterised
    seed = pipeline.transforms[0].params["seed"]
    expected = fishcam.transforms.RandomViewpoint(cam, preset="large")(
        image=data["image"], mask=data["mask"], seed=seed
    )
    np.testing.assert_array_equal(out["image"], expected["image"])
    np.testing.assert_array_equal(out["mask"], expected["mask"])
    # A replay (its params are copies) draws again, to the same outputs.
    replay = A.ReplayCompose([fa.RandomViewpoint(cam, preset="medium")])
    first = replay(image=data["image"], mask=data["mask"])
    again = A.ReplayCompose.replay(first["replay"], image=data["image"], mask=data["mask"])
    assert np.array_equal(first["image"], again["image"]) and np.array_equal(first["mask"], again["mask"])


def coordinates(cam):
    """An HxWx2 float32 image whose pixels hold their own (row + 1, column + 1): 0 is padding."""
    rows, cols = np.mgrid[1 : cam.height + 1, 1 : cam.width + 1].astype(np.float32)
    return np.stack([rows, cols], axis=-1)


@pytest.mark.parametrize(
    "transform",
    [
        fa.HorizontalFlip(p=1),
        fa.VerticalFlip(p=1),
        fa.Resize(121, 160, interpolation=0),
        fa.RandomCrop(100, 150),
        fa.RandomCrop(300, 400, pad_if_needed=True, pad_position="random"),
        fa.CenterCrop(101, 151),
        fa.CenterCrop(300, 401, pad_if_needed=True),
        fa.Crop(10, 20, 110, 220),
    ],
    ids=["hflip", "vflip", "resize", "crop", "crop-padded", "center", "center-padded", "crop-window"],
)
def test_geometric_transforms_keep_the_camera_true(cam, transform):
    """Every output pixel that shows a source pixel: the returned camera sees there the ray
    the input camera saw at that source pixel (to 1e-9 px; nearest resizing: the source
    pixel is the one sampled)."""
    for seed in range(3):
        out = A.Compose([transform], seed=seed)(image=coordinates(cam), camera=cam)
        image, after = out["image"], out["camera"]
        assert (after.width, after.height) == (image.shape[1], image.shape[0])
        ys, xs = np.nonzero(image[..., 0] > 0)
        assert len(xs) > 100
        source = np.stack([image[ys, xs, 1] - 1, image[ys, xs, 0] - 1], axis=1).astype(np.float64)
        rays, ok = cam.unproject(source)
        pixels, seen = after.project(rays[ok])
        assert seen.all()
        expected = np.stack([xs, ys], axis=1)[ok].astype(np.float64)
        if isinstance(transform, fa.Resize):  # nearest: the output pixel's centre lies within its source pixel
            assert (np.abs(pixels - expected) <= np.array([160 / 320, 121 / 242]) / 2 + 1e-9).all()
        else:
            np.testing.assert_allclose(pixels, expected, atol=1e-9)


def test_a_geometric_transform_refuses_a_stale_camera(cam):
    with pytest.raises(fishcam.Error, match="camera: 320x242 but the images are 160x121"):
        A.Compose([A.Resize(121, 160), fa.HorizontalFlip(p=1)])(image=coordinates(cam), camera=cam)
