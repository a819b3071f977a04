"""A camera that stays true (issue 37, item 3, in part): fishcam.torch.Resize resizes a
sample's camera with its images, so the camera projects scene points onto the resized
image exactly as torchvision maps pixel centres; after RandomViewpoint the chain's
camera is the final image's."""

import os

import fishcam
import fishcam.torch as ft
import numpy as np
import pytest
import torch
from conftest import DATA
from torchvision import tv_tensors
from torchvision.transforms import v2


@pytest.fixture(scope="module")
def cam():
    return fishcam.Camera.read(os.path.join(DATA, "woodscape_front.json")).resized(320, 242)


def test_resize_keeps_the_camera_true(cam):
    points = np.array([[0.3, -0.2, 1.0], [-0.8, 0.1, 0.6], [0.05, 0.4, 2.0]])
    before, seen = cam.project(points)
    assert seen.all()
    image = tv_tensors.Image(torch.zeros((3, cam.height, cam.width), dtype=torch.uint8))
    out_image, out_camera = ft.Resize((121, 160))(image, cam)
    assert out_image.shape == (3, 121, 160) and (out_camera.width, out_camera.height) == (160, 121)
    after, _ = out_camera.project(points)
    # torchvision maps a pixel centre x to (x + 0.5) * s - 0.5: the camera does the same.
    np.testing.assert_allclose(after, (before + 0.5) * np.array([160 / 320, 121 / 242]) - 0.5, atol=1e-9)
    # An int size (the shorter side), as v2.Resize takes it.
    _, shorter = ft.Resize(121)(image, cam)
    assert (shorter.width, shorter.height) == (160, 121)


def test_a_chain_ends_with_the_final_images_camera(cam):
    t = v2.Compose([ft.RandomViewpoint(preset="small"), ft.Resize((121, 160))])
    image = tv_tensors.Image(torch.zeros((3, cam.height, cam.width), dtype=torch.uint8))
    with ft.sample_seed(3):
        out = t({"image": image, "camera": cam})
    change = ft.RandomViewpoint(preset="small").numpy_transform.change_for(3)
    assert out["camera"] == cam.augmented(change).resized(160, 121)
    assert out["image"].shape[-2:] == (121, 160)


def test_a_camera_that_no_longer_matches_is_refused(cam):
    image = tv_tensors.Image(torch.zeros((3, 100, 100), dtype=torch.uint8))
    with pytest.raises(fishcam.Error, match="camera: 320x242 but the images are 100x100"):
        ft.Resize((50, 50))(image, cam)


def coordinates_image(cam):
    """A 2xHxW float image whose pixels hold their own (row + 1, column + 1): 0 is padding."""
    rows = torch.arange(1, cam.height + 1, dtype=torch.float32).view(cam.height, 1).expand(cam.height, cam.width)
    cols = torch.arange(1, cam.width + 1, dtype=torch.float32).view(1, cam.width).expand(cam.height, cam.width)
    return tv_tensors.Image(torch.stack([rows, cols]))


def assert_camera_describes(before, after, image):
    """Every output pixel that shows a source pixel: the new camera sees there the ray the
    old camera saw at that source pixel (to 1e-9 px)."""
    ys, xs = torch.nonzero(image[0] > 0, as_tuple=True)
    assert len(xs) > 100
    source = np.stack([image[1, ys, xs].numpy() - 1, image[0, ys, xs].numpy() - 1], axis=1).astype(np.float64)
    rays, ok = before.unproject(source)
    pixels, seen = after.project(rays[ok])
    assert seen.all()
    np.testing.assert_allclose(pixels, np.stack([xs.numpy(), ys.numpy()], axis=1)[ok].astype(np.float64), atol=1e-9)


@pytest.mark.parametrize(
    "transform",
    [
        ft.RandomCrop((100, 150)),
        ft.RandomCrop((100, 150), padding=(7, 3, 5, 11)),
        ft.RandomCrop((300, 400), pad_if_needed=True),
        ft.CenterCrop((101, 151)),
        ft.CenterCrop((300, 401)),
        ft.CenterCrop(120),
    ],
    ids=["crop", "crop-padded", "crop-pad-if-needed", "center", "center-padded", "center-square"],
)
def test_crops_keep_the_camera_true(cam, transform):
    torch.manual_seed(2)
    for _ in range(3):
        image, out_camera = transform(coordinates_image(cam), cam)
        assert (out_camera.width, out_camera.height) == (image.shape[-1], image.shape[-2])
        assert_camera_describes(cam, out_camera, image)
    # After a viewpoint change too: the chain's camera is the final image's.
    chain = v2.Compose([ft.RandomViewpoint(preset="small", sampling="exact"), transform])
    _, chained = chain(coordinates_image(cam), cam)
    assert (chained.width, chained.height) == (image.shape[-1], image.shape[-2])


def test_a_crop_refuses_a_stale_camera(cam):
    image = tv_tensors.Image(torch.zeros((3, cam.height, cam.width), dtype=torch.uint8))
    with pytest.raises(fishcam.Error, match="camera: 320x242 but the images are 160x121"):
        v2.Compose([v2.Resize((121, 160)), ft.CenterCrop(100)])(image, cam)
    with pytest.raises(fishcam.Error, match="cropped: width and height must be >= 1"):
        cam.cropped(0, 0, 0, 10)


@pytest.mark.parametrize(
    "transform, horizontal, vertical",
    [(ft.RandomHorizontalFlip(p=1), True, False), (ft.RandomVerticalFlip(p=1), False, True)],
    ids=["horizontal", "vertical"],
)
def test_flips_keep_the_camera_true(cam, transform, horizontal, vertical):
    image, flipped = transform(coordinates_image(cam), cam)
    assert flipped == cam.mirrored(horizontal=horizontal, vertical=vertical)
    assert_camera_describes(cam, flipped, image)
    # Not drawn (p = 0): the sample, camera included, passes unchanged.
    _, same = type(transform)(p=0)(coordinates_image(cam), cam)
    assert same == cam
    with pytest.raises(fishcam.Error, match="camera: 320x242 but the images are 160x121"):
        transform(tv_tensors.Image(torch.zeros((3, 121, 160))), cam)


@pytest.mark.parametrize("flip", [ft.RandomHorizontalFlip(p=1), ft.RandomVerticalFlip(p=1)], ids=["h", "v"])
def test_a_flip_and_a_viewpoint_change_commute(cam, flip):
    """Flipped first, the viewpoint change warps with the mirrored camera: the same image
    and camera as the change followed by the flip (a flip before an ordinary
    v2.RandomHorizontalFlip would warp with unmirrored intrinsics)."""
    viewpoint = ft.RandomViewpoint(preset="medium", sampling="exact")
    outputs = []
    for chain in (v2.Compose([flip, viewpoint]), v2.Compose([viewpoint, flip])):
        with ft.sample_seed(11):
            outputs.append(chain(coordinates_image(cam), cam))
    (first, first_camera), (second, second_camera) = outputs
    # The same camera; its pose to the last bits (a quaternion normalised once more or less).
    for a, b in zip(first_camera.pose, second_camera.pose):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)
    assert first_camera.parameters_key(with_pose=False) == second_camera.parameters_key(with_pose=False)
    both = (first[0] > 0) & (second[0] > 0)
    assert both.sum() > 0.5 * cam.width * cam.height
    assert (both == (first[0] > 0)).float().mean() > 0.99
    # cv2.remap places bilinear samples on a 1/32 px grid: a mirrored position may round
    # to the neighbouring step (the coordinates image has slope 1 per pixel).
    torch.testing.assert_close(first[:, both], second[:, both], atol=1 / 32 + 1e-3, rtol=0)


def test_a_mirrored_camera_lives_in_fishcam_json_only(cam, tmp_path):
    mirrored = cam.mirrored()
    assert list(mirrored.pixel_scale) == [-cam.pixel_scale[0], cam.pixel_scale[1]]
    assert mirrored.mirrored() == cam
    mirrored.write(str(tmp_path / "mirrored.json"))
    assert fishcam.Camera.read(str(tmp_path / "mirrored.json")) == mirrored
    with pytest.raises(fishcam.Error, match="cannot hold a mirrored pixel grid"):
        mirrored.write(str(tmp_path / "mirrored.txt"), format="woodscape")
