"""Fill per target type (issue 37, item 1): where the moved camera has no source,
images get the image fill, semantic masks the ignore label (fill_mask), and
instance masks 0 / False whatever fill_mask says, so the boxes taken from them
stay tight. Checked against the warp's own validity (ViewpointWarp.warp's
``valid``), not against the transforms' output."""

import os

import fishcam
import fishcam.torch as ft
import numpy as np
import pytest
import torch
from conftest import DATA
from torchvision import tv_tensors
from torchvision.ops import masks_to_boxes
from torchvision.transforms import v2

H, W = 121, 160
# Seeds whose "large" change leaves >= 1300 no-source pixels and moves the corner
# instance wholly out of view (checked in the test, not assumed).
SEEDS = [0, 2, 6]
FILLS = [dict(fill_mask=255), dict(fill={tv_tensors.Image: 0, tv_tensors.Mask: 255})]


@pytest.fixture(scope="module")
def cam():
    return fishcam.Camera.read(os.path.join(DATA, "woodscape_front.json")).resized(W, H)


def instances(dtype=torch.uint8):
    """Three instances: two large ones the change pushes partly out of view, one in
    the corner (outside the image circle) that leaves it altogether."""
    masks = torch.zeros((3, H, W), dtype=dtype)
    masks[0, 10:110, 5:75] = 1
    masks[1, 20:100, 85:155] = 1
    masks[2, 0:4, 0:4] = 1
    return masks


def reference(cam, seed, masks):
    """The validity of the change of ``seed`` ("large") and the instances warped by the
    library itself, restricted to the pixels with a source: (valid, planes bool)."""
    change = fishcam.transforms.RandomViewpoint(cam, preset="large").change_for(seed)
    warp = fishcam.ViewpointWarp(cam)
    valid = warp.warp(labels=np.ones((H, W), np.uint8), change=change, return_valid=True)["valid"]
    planes = np.stack(
        [warp.warp(labels=m.numpy().astype(np.uint8), change=change, label_fill=255)["labels"] != 0 for m in masks]
    )
    return valid, planes & valid


def tight_box(plane):
    """x_min, y_min, x_max, y_max in pixel edges (fishcam's boxes); zeros when empty."""
    ys, xs = np.nonzero(plane)
    return [xs.min(), ys.min(), xs.max() + 1, ys.max() + 1] if len(xs) else [0, 0, 0, 0]


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("fill", FILLS, ids=["fill_mask", "fill_dict"])
def test_instance_masks_never_take_no_source_pixels(cam, seed, fill):
    """A detection sample (image, {"boxes", "labels", "masks"}) beside an NxHxW
    instance Mask and a semantic HxW Mask: no instance holds a no-source pixel, the
    boxes (fishcam's and masks_to_boxes') are those of the valid pixels, and the
    semantic mask still gets 255 exactly where there is no source."""
    masks = instances()
    valid, expected = reference(cam, seed, masks)
    assert (~valid).sum() >= 1300, "too small a no-source region to test anything"
    assert expected[0].sum() > 2000 and expected[1].sum() > 2000 and expected[2].sum() == 0
    boxes = tv_tensors.BoundingBoxes([tight_box(m.numpy()) for m in masks], format="XYXY", canvas_size=(H, W))
    sample = (
        tv_tensors.Image(torch.full((3, H, W), 9, dtype=torch.uint8)),
        {"boxes": boxes, "labels": torch.tensor([1, 2, 3]), "masks": tv_tensors.Mask(masks)},
        tv_tensors.Mask(instances()),
        tv_tensors.Mask(torch.ones((H, W), dtype=torch.int64)),
    )
    with ft.sample_seed(seed):
        image, target, loose, semantic = ft.RandomViewpoint(cam, preset="large", boxes="from_masks", **fill)(sample)

    # The semantic mask: 255 exactly where the warp has no source; the image: 0 there.
    assert semantic.dtype == torch.int64
    assert torch.equal(semantic == 255, torch.from_numpy(~valid))
    assert set(semantic[torch.from_numpy(valid)].unique().tolist()) == {1}
    assert (image[:, torch.from_numpy(~valid)] == 0).all() and (image[:, torch.from_numpy(valid)] == 9).all()
    for out in (target["masks"], loose):  # under "masks" in a dict, and N >= 2 on its own
        assert out.dtype == torch.uint8 and set(out.unique().tolist()) <= {0, 1}
        assert not out[:, torch.from_numpy(~valid)].any()
        assert torch.equal(out.bool(), torch.from_numpy(expected))
        # masks_to_boxes on the output: within 1 px of the boxes of the valid pixels alone.
        got = masks_to_boxes(out).numpy()
        for i in range(2):
            want = masks_to_boxes(torch.from_numpy(expected[i : i + 1])).numpy()[0]
            np.testing.assert_allclose(got[i], want, atol=1)
        assert got[2].tolist() == [0, 0, 0, 0]
    # fishcam's boxes: the tight boxes of the transformed instances (none for the one that left).
    want_boxes = [tight_box(plane) for plane in expected]
    np.testing.assert_allclose(target["boxes"].numpy(), want_boxes, atol=1)
    areas = [(b[2] - b[0]) * (b[3] - b[1]) for b in target["boxes"].tolist()]
    assert max(areas) < 0.9 * H * W and areas[2] == 0

    # SanitizeBoundingBoxes drops the instance that left the view, with its label and mask.
    with ft.sample_seed(seed):
        image, target = v2.Compose(
            [ft.RandomViewpoint(cam, preset="large", boxes="from_masks", **fill), v2.SanitizeBoundingBoxes()]
        )(sample[:2])
    assert target["labels"].tolist() == [1, 2] and len(target["masks"]) == 2 and len(target["boxes"]) == 2


def test_how_masks_are_classified(cam):
    """bool masks and NxHxW masks (N >= 2) are instances; HxW and 1xHxW masks of an
    integer dtype are semantic; any mask under the key "masks" is an instance."""
    seed = 2
    valid, _ = reference(cam, seed, instances())
    no_source = torch.from_numpy(~valid)
    ones = torch.ones((H, W), dtype=torch.uint8)
    sample = {
        "image": tv_tensors.Image(torch.zeros((3, H, W), dtype=torch.uint8)),
        "hw": tv_tensors.Mask(ones),
        "one_hw": tv_tensors.Mask(ones[None]),
        "bool_hw": tv_tensors.Mask(ones.bool()),
        "bool_one_hw": tv_tensors.Mask(ones[None].bool()),
        "two_hw": tv_tensors.Mask(torch.stack([ones, ones])),
        "masks": tv_tensors.Mask(ones[None]),  # one instance: under "masks", still an instance
        "target": {"masks": [tv_tensors.Mask(ones)]},
    }
    with ft.sample_seed(seed):
        out = ft.RandomViewpoint(cam, preset="large", fill_mask=255)(sample)
    for key in ["hw", "one_hw"]:
        assert (out[key][..., no_source] == 255).all() and (out[key][..., ~no_source] == 1).all(), key
    for key in ["bool_hw", "bool_one_hw"]:
        assert out[key].dtype == torch.bool and torch.equal(out[key].reshape(H, W), ~no_source), key
    for got in [out["two_hw"][0], out["two_hw"][1], out["masks"][0], out["target"]["masks"][0]]:
        assert torch.equal(got, (~no_source).to(torch.uint8))
    assert ft.is_instance_mask(torch.zeros((2, 4, 4), dtype=torch.uint8))
    assert ft.is_instance_mask(torch.zeros((4, 4), dtype=torch.bool))
    assert ft.is_instance_mask(torch.zeros((1, 4, 4), dtype=torch.uint8), under_masks_key=True)
    assert not ft.is_instance_mask(torch.zeros((1, 4, 4), dtype=torch.uint8))
    assert not ft.is_instance_mask(torch.zeros((4, 4), dtype=torch.int64))


def test_the_dict_fill_and_the_old_fill_mask_agree(cam):
    """fill={Image: v, Mask: m} is fill=v, fill_mask=m (same bytes, same repr), the
    numpy transforms' {"image", "mask"} too; fill_mask alone keeps its old result."""
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (3, H, W), dtype=np.uint8)
    labels = rng.integers(0, 10, (H, W)).astype(np.int64)

    def run(**kwargs):
        with ft.sample_seed(6):
            return ft.RandomViewpoint(cam, preset="large", **kwargs)(
                (tv_tensors.Image(torch.from_numpy(image)), tv_tensors.Mask(torch.from_numpy(labels)))
            )

    old_image, old_mask = run(fill=7, fill_mask=255)
    numpy_side = fishcam.transforms.RandomViewpoint(cam, preset="large", fill=7, fill_mask=255)(
        image=np.ascontiguousarray(np.moveaxis(image, 0, -1)), mask=labels, seed=6
    )
    assert np.array_equal(old_image.permute(1, 2, 0).numpy(), numpy_side["image"])
    assert np.array_equal(old_mask.numpy(), numpy_side["mask"])
    valid, _ = reference(cam, 6, instances())
    assert (old_mask.numpy()[~valid] == 255).all() and (old_image.numpy()[:, ~valid] == 7).all()
    assert (old_mask.numpy()[valid] < 10).all()
    for kwargs in [
        dict(fill={tv_tensors.Image: 7, tv_tensors.Mask: 255}),
        dict(fill={tv_tensors.Image: 7, tv_tensors.Mask: 255}, fill_mask=255),  # agreeing: fine
        dict(fill={tv_tensors.Image: 7}, fill_mask=255),
    ]:
        new_image, new_mask = run(**kwargs)
        assert torch.equal(new_image, old_image) and torch.equal(new_mask, old_mask), kwargs
    assert "fill=7, fill_mask=255" in repr(ft.RandomViewpoint(cam, fill={tv_tensors.Image: 7, tv_tensors.Mask: 255}))
    only_mask = ft.RandomViewpoint(cam, fill={tv_tensors.Mask: 200})
    assert "fill=0, fill_mask=200" in repr(only_mask)
    # The numpy transforms: the same dict with string keys.
    keyed = fishcam.transforms.RandomViewpoint(cam, preset="large", fill={"image": 7, "mask": 255})(
        image=np.ascontiguousarray(np.moveaxis(image, 0, -1)), mask=labels, seed=6
    )
    assert np.array_equal(keyed["image"], numpy_side["image"]) and np.array_equal(keyed["mask"], numpy_side["mask"])
    # SampleChange: instance=True (or a bool mask) gives 0 / False where there is no source.
    change = fishcam.transforms.RandomViewpoint(cam, preset="large", fill_mask=255).draw(seed=6)
    ones = np.ones((H, W), np.uint16)
    assert np.array_equal(change.mask(ones), np.where(valid, 1, 255))
    assert np.array_equal(change.mask(ones, instance=True), valid.astype(np.uint16))
    assert np.array_equal(change.mask(ones.astype(bool)), valid)
    out = fishcam.transforms.RandomViewpoint(cam, preset="large", fill_mask=255)(mask=ones.astype(bool), seed=6)
    assert np.array_equal(out["mask"], valid)


def test_affine_instance_masks_too(cam):
    """RandomAffine (torch): the same rule; validity from the library's affine warp."""
    masks = instances()
    seed = 3
    change = fishcam.transforms.RandomAffine(preset="train").change_for(seed)
    valid = fishcam._fishcam.affine_warp(labels=np.ones((H, W), np.uint8), change=change, return_valid=True)["valid"]
    assert (~valid).sum() > 1000
    with ft.sample_seed(seed):
        image, target, semantic = ft.RandomAffine(preset="train", fill={tv_tensors.Image: 0, tv_tensors.Mask: 255})(
            (
                tv_tensors.Image(torch.zeros((3, H, W), dtype=torch.uint8)),
                {"masks": tv_tensors.Mask(masks)},
                tv_tensors.Mask(torch.ones((H, W), dtype=torch.uint8)),
            )
        )
    assert not target["masks"][:, torch.from_numpy(~valid)].any() and target["masks"].sum() > 1000
    assert torch.equal(semantic == 255, torch.from_numpy(~valid))


def test_bad_fills_are_refused_in_one_line(cam):
    cases = [
        (lambda: ft.RandomViewpoint(cam, fill={tv_tensors.BoundingBoxes: 0}), "unknown key tv_tensors.BoundingBoxes"),
        (lambda: ft.RandomViewpoint(cam, fill={"others": 0}), "unknown key 'others'"),
        (lambda: ft.RandomViewpoint(cam, fill={torch.Tensor: 0}), "unknown key Tensor"),
        (lambda: ft.RandomViewpoint(cam, fill={"image": 0}), "expected tv_tensors.Image and/or tv_tensors.Mask"),
        (lambda: ft.RandomAffine(fill={tv_tensors.Video: 0}), "unknown key tv_tensors.Video"),
        (lambda: ft.RandomViewpoint(cam, fill={tv_tensors.Mask: 255}, fill_mask=254), "disagree"),
        (
            lambda: ft.RandomViewpoint(cam, fill={tv_tensors.Mask: 70000}),
            r"fill\[tv_tensors.Mask\]: 70000 outside 0..65535",
        ),
        (lambda: ft.RandomViewpoint(cam, fill={tv_tensors.Mask: -1}), r"fill\[tv_tensors.Mask\]: -1 outside"),
        (lambda: ft.RandomViewpoint(cam, fill={tv_tensors.Mask: 1.5}), "expected an integer"),
        (lambda: ft.RandomViewpoint(cam, fill={tv_tensors.Mask: True}), "expected an integer"),
        (lambda: ft.RandomViewpoint(cam, fill={tv_tensors.Image: (1, 2, 3)}), "expected a number, got tuple"),
        (lambda: ft.RandomViewpoint(cam, fill={tv_tensors.Image: float("nan")}), "must be finite"),
        (lambda: ft.RandomViewpoint(cam, fill_mask=-1), "fill_mask: -1 outside 0..65535"),
        (lambda: ft.RandomAffine(fill_mask=65536), "fill_mask: 65536 outside 0..65535"),
        (lambda: fishcam.transforms.RandomViewpoint(cam, fill={tv_tensors.Image: 0}), "unknown key tv_tensors.Image"),
        (lambda: fishcam.transforms.RandomAffine(fill={"image": 0, "masks": 0}), "unknown key 'masks'"),
        (lambda: fishcam.transforms.RandomViewpoint(cam, fill={"mask": 3}, fill_mask=4), "disagree"),
        (
            lambda: ft.warp_batch(torch.zeros((1, 3, H, W)), cam, [fishcam.ViewpointChange()], fill={"x": 1}),
            "unknown key 'x'",
        ),
    ]
    for call, message in cases:
        with pytest.raises(fishcam.Error, match=message) as error:
            call()
        assert "\n" not in str(error.value), str(error.value)
    # A fill the mask's dtype cannot hold: refused at the call (it would wrap or fail in the warp).
    t = fishcam.transforms.RandomViewpoint(cam, preset="large", fill_mask=300)
    with pytest.raises(fishcam.Error, match=r"fill 300 does not fit dtype uint8 \(0..255\)"):
        t(mask=np.ones((H, W), np.uint8), seed=1)
    with pytest.raises(fishcam.Error, match=r"fill 200 does not fit dtype int8 \(0..127\)"):
        fishcam.transforms.RandomViewpoint(cam, fill_mask=200)(mask=np.ones((H, W), np.int8), seed=1)
    assert t(mask=np.ones((H, W), np.uint16), seed=1)["mask"].max() == 300  # uint16 holds it
    with ft.sample_seed(1), pytest.raises(fishcam.Error, match="does not fit dtype uint8"):
        ft.RandomViewpoint(cam, fill_mask=300)(tv_tensors.Mask(torch.ones((H, W), dtype=torch.uint8)))
    # An instance mask never uses the semantic fill, so it cannot fail on it.
    with ft.sample_seed(1):
        out = ft.RandomViewpoint(cam, preset="large", fill_mask=300)(tv_tensors.Mask(instances()))
    assert set(out.unique().tolist()) == {0, 1}


def test_warp_batch_takes_the_fill_by_type(cam):
    changes = [fishcam.random_change("large", 2), fishcam.random_change("large", 6)]
    warp = fishcam.ViewpointWarp(cam)
    valid = np.stack(
        [warp.warp(labels=np.ones((H, W), np.uint8), change=c, return_valid=True)["valid"] for c in changes]
    )
    images = torch.full((2, 3, H, W), 9, dtype=torch.uint8)
    labels = torch.ones((2, H, W), dtype=torch.int64)
    out = ft.warp_batch(images, cam, changes, masks=labels, fill={tv_tensors.Image: 5, tv_tensors.Mask: 255})
    same = ft.warp_batch(images, cam, changes, masks=labels, fill=5, fill_mask=255)
    assert torch.equal(out.images, same.images) and torch.equal(out.masks, same.masks)
    assert (out.masks[~out.valid] == 255).all() and (out.images[:, 0][~out.valid] == 5).all()
    # The batched path's validity is the grid's: within a pixel of the border of the warp's.
    assert (out.valid.numpy() != valid).sum() < 0.02 * valid.size and (~valid).sum() > 2000
    flags = ft.warp_batch(images, cam, changes, masks=labels.bool(), fill_mask=255).masks
    assert flags.dtype == torch.bool and torch.equal(flags, out.valid)
    with pytest.raises(fishcam.Error, match=r"fill_mask: 255 does not fit the masks' dtype torch.int8 \(-128..127\)"):
        ft.warp_batch(images, cam, changes, masks=labels.to(torch.int8), fill_mask=255)
    # torch's own ignore_index (-100) still works for int64 masks.
    assert (ft.warp_batch(images, cam, changes, masks=labels, fill_mask=-100).masks[~out.valid] == -100).all()


def test_albumentations_masks_are_instances(cam):
    """albumentations' ``masks`` (instance masks) get 0 where there is no source; ``mask`` gets the label."""
    pytest.importorskip("albumentations")
    import albumentations as A
    import fishcam.albumentations as fa

    pipeline = A.Compose([fa.RandomViewpoint(cam, preset="large", fill={"image": 0, "mask": 255})], seed=0)
    out = pipeline(image=np.zeros((H, W, 3), np.uint8), mask=np.ones((H, W), np.uint8), masks=instances().numpy())
    seed = pipeline.transforms[0].params["seed"]
    change = fishcam.transforms.RandomViewpoint(cam, preset="large").change_for(seed)
    valid = fishcam.ViewpointWarp(cam).warp(labels=np.ones((H, W), np.uint8), change=change, return_valid=True)["valid"]
    assert (~valid).sum() > 300
    assert np.array_equal(out["mask"] == 255, ~valid)
    masks = np.asarray(out["masks"])
    assert masks.shape == (3, H, W) and not masks[:, ~valid].any() and masks.sum() > 1000


@pytest.mark.parametrize("fill", [300, -1, 2**31, 2**32 + 7, 2**64, 1.5, 1e20])
def test_image_fills_an_integer_image_cannot_hold_are_refused(cam, fill):
    """An integer image's fill must be a value of its dtype: OpenCV would saturate
    300 to 255, round 1.5 and wrap 2^31 to 0; fishcam refuses them, in one line, in
    every adapter (a float32 image takes any of them but 1e39)."""
    pytest.importorskip("albumentations")
    import albumentations as A
    import fishcam.albumentations as fa

    image = np.full((H, W, 3), 9, np.uint8)
    calls = [
        lambda: fishcam.transforms.RandomViewpoint(cam, preset="large", fill=fill)(image=image, seed=0),
        lambda: fishcam.transforms.RandomAffine(fill=fill)(image=image, seed=0),
        lambda: fishcam.transforms.RandomViewpoint(cam, fill={"image": fill})(image=image, mask=image[..., 0], seed=0),
        lambda: ft.RandomViewpoint(cam, fill=fill)(tv_tensors.Image(torch.from_numpy(image).permute(2, 0, 1))),
        lambda: ft.RandomAffine(fill={tv_tensors.Image: fill})(torch.from_numpy(image).permute(2, 0, 1)),
        lambda: A.Compose([fa.RandomViewpoint(cam, fill=fill)], seed=0)(image=image),
        lambda: ft.warp_batch(
            torch.from_numpy(image).permute(2, 0, 1)[None], cam, [fishcam.random_change("large", 0)], fill=fill
        ),
    ]
    for call in calls:
        with pytest.raises(fishcam.Error, match="no-source fill .* dtype (torch.)?uint8") as error:
            call()
        assert "\n" not in str(error.value)
    if fill != 1e20:
        out = fishcam.transforms.RandomViewpoint(cam, preset="large", fill=fill)(image=image.astype(np.float32), seed=0)
        assert (out["image"] == np.float32(fill)).any()
    with pytest.raises(fishcam.Error, match="past the range of dtype float32"):
        fishcam.transforms.RandomViewpoint(cam, fill=1e39)(image=image.astype(np.float32), seed=0)


@pytest.mark.parametrize("dtype, fill", [(np.uint8, 255), (np.uint8, 0), (np.uint16, 65535), (np.float32, -1.0)])
def test_image_fills_the_dtype_holds_are_exact(cam, dtype, fill):
    image = np.full((H, W, 3), 9, dtype)
    out = fishcam.transforms.RandomViewpoint(cam, preset="large", fill=fill)(image=image, seed=SEEDS[0])["image"]
    valid = fishcam.ViewpointWarp(cam).warp(
        image=image, change=fishcam.random_change("large", SEEDS[0]), return_valid=True
    )["valid"]
    assert (~valid).sum() > 1000 and (out[~valid] == np.array(fill, dtype)).all() and (out[valid] != fill).any()


@pytest.mark.parametrize("dtype", [np.bool_, np.uint8, np.int64])
def test_instance_masks_travel_sixteen_to_a_pass(cam, dtype):
    """SampleChange.instance_masks packs two-valued masks 16 to a uint16 pass and gives
    each back as mask(..., instance=True) gives it alone; a mask of more values (ids)
    still goes alone. Counted: 20 two-valued masks and one of ids take 3 passes."""
    rng = np.random.default_rng(5)
    top = {np.bool_: True, np.uint8: 255, np.int64: 7}[dtype]
    masks = np.zeros((21, H, W), dtype)
    for i in range(20):
        y, x = rng.integers(0, H - 30), rng.integers(0, W - 30)
        masks[i, y : y + rng.integers(5, 30), x : x + rng.integers(5, 30)] = top
    masks[5] = 0  # an instance with no pixels
    if dtype != np.bool_:
        masks[20] = rng.integers(0, 4, (H, W)).astype(dtype)  # ids: alone
    change = fishcam.transforms.RandomViewpoint(cam, preset="large").draw(cam, seed=3)
    alone = np.stack([change.mask(m, instance=True) for m in masks])
    passes = []
    resample = change._resample
    change._resample = lambda **kw: passes.append(1) or resample(**kw)
    together = change.instance_masks(masks)
    assert together.dtype == masks.dtype and together.shape == alone.shape
    assert np.array_equal(together, alone)
    assert len(passes) == (2 if dtype == np.bool_ else 3)
    assert together[:20].sum() > 0 and not together[5].any()
