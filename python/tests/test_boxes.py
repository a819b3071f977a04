"""Boxes keep their meaning (issue 37, item 2): by default each box follows its own
outline (amodal and loose boxes stay what they are, whatever masks lie beside them);
boxes="from_masks" makes box i the tight box of instance mask i, paired by index as
torchvision's detection targets are, counts checked; min_visibility means the same
in both modes. The reference is the numpy SampleChange of the same draw."""

import os

import fishcam
import fishcam.torch as ft
import numpy as np
import pytest
import torch
from conftest import DATA
from torchvision import tv_tensors
from torchvision.transforms import v2

H, W = 121, 160
SEED = 4


@pytest.fixture(scope="module")
def cam():
    return fishcam.Camera.read(os.path.join(DATA, "woodscape_front.json")).resized(W, H)


def instances():
    masks = torch.zeros((3, H, W), dtype=torch.uint8)
    masks[0, 50:70, 60:80] = 1
    masks[1, 30:45, 90:120] = 1
    masks[2, 80:100, 30:50] = 1
    return masks


def tight(plane):
    ys, xs = torch.nonzero(plane, as_tuple=True)
    return [xs.min().item(), ys.min().item(), xs.max().item() + 1, ys.max().item() + 1] if len(xs) else [0, 0, 0, 0]


# Amodal boxes: each wider than its instance's visible pixels, the last reaching past
# the image's edge.
AMODAL = [[50.0, 40.0, 90.0, 80.0], [85.0, 25.0, 125.0, 50.0], [20.0, 75.0, 60.0, 130.0]]


def sample(boxes):
    return {
        "image": tv_tensors.Image(torch.zeros((3, H, W), dtype=torch.uint8)),
        "boxes": tv_tensors.BoundingBoxes(boxes, format="XYXY", canvas_size=(H, W)),
        "masks": tv_tensors.Mask(instances()),
        "labels": torch.tensor([1, 2, 3]),
    }


def reference(cam, t, boxes):
    """The numpy SampleChange the torch transform draws for SEED, and its boxes."""
    change = t.numpy_transform.draw(cam, SEED)
    return change.boxes(np.asarray(boxes, np.float64))


def test_boxes_follow_their_own_outline_by_default(cam):
    t = ft.RandomViewpoint(cam, preset="small")
    with ft.sample_seed(SEED):
        out = t(sample(AMODAL))
    mapped, _ = reference(cam, t, AMODAL)
    np.testing.assert_allclose(out["boxes"].numpy(), mapped, atol=1e-4)
    # Not the masks' tight boxes: an amodal box stays amodal.
    tight_boxes = np.array([tight(m) for m in out["masks"]], np.float64)
    assert np.abs(out["boxes"].numpy() - tight_boxes).max() > 5


def test_from_masks_pairs_by_index_and_counts_must_match(cam):
    reordered = [AMODAL[2], AMODAL[0], AMODAL[1]]  # box i is given for another instance
    t = ft.RandomViewpoint(cam, preset="small", boxes="from_masks")
    with ft.sample_seed(SEED):
        out = t(sample(reordered))
    # Box i is mask i's tight box whatever box i said: pairing by index, as torchvision's.
    assert out["boxes"].tolist() == [tight(m) for m in out["masks"]]
    with pytest.raises(fishcam.Error, match="2 boxes but 3 instance masks"):
        t({**sample(AMODAL[:2]), "labels": torch.tensor([1, 2])})
    loose = {**sample(AMODAL), "others": tv_tensors.Mask(instances())}
    del loose["masks"]  # two sets of instance masks, neither under "masks": which one is a guess
    loose["more"] = tv_tensors.Mask(instances())
    with pytest.raises(fishcam.Error, match='the instance masks under "masks" or one NxHxW'):
        t(loose)
    with pytest.raises(fishcam.Error, match="boxes: expected outline or from_masks"):
        ft.RandomViewpoint(cam, boxes="tight")
    # A sample without boxes (an unlabelled image in the same pipeline) has nothing to pair.
    with ft.sample_seed(SEED):
        alone = t({"image": tv_tensors.Image(torch.zeros((3, H, W), dtype=torch.uint8))})
    assert alone["image"].shape == (3, H, W)


def test_min_visibility_means_the_same_in_both_modes(cam):
    boxes = AMODAL
    _, seen = reference(cam, ft.RandomViewpoint(cam, preset="small"), boxes)
    threshold = float(np.median(seen))  # some boxes below it, some at or above
    expected = [bool(s >= threshold) for s in seen]
    assert any(expected) and not all(expected), seen
    for mode in ("outline", "from_masks"):
        t = v2.Compose(
            [
                ft.RandomViewpoint(cam, preset="small", min_visibility=threshold, boxes=mode),
                v2.SanitizeBoundingBoxes(labels_getter=lambda s: s["labels"]),
            ]
        )
        with ft.sample_seed(SEED):
            out = t(sample(boxes))
        kept = [label in out["labels"].tolist() for label in (1, 2, 3)]
        assert kept == expected, mode
