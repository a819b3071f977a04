"""fishcam.metrics and ``fishcam evaluate`` against an independent numpy implementation."""

import json
import os
import subprocess

import cv2
import fishcam
import numpy as np
import pytest
import torch
from conftest import BINARY


def reference_iou(preds, gts, num_classes, ignore=None):
    """Eq. 11 per class from np.bincount over every pixel; NaN where TP + FP + FN = 0."""
    pred = np.concatenate([p.ravel() for p in preds]).astype(np.int64)
    gt = np.concatenate([g.ravel() for g in gts]).astype(np.int64)
    keep = gt != ignore if ignore is not None else np.ones_like(gt, bool)
    matrix = np.bincount(gt[keep] * num_classes + pred[keep], minlength=num_classes**2)
    matrix = matrix.reshape(num_classes, num_classes)
    tp = np.diag(matrix).astype(float)
    union = matrix.sum(0) + matrix.sum(1) - tp
    with np.errstate(invalid="ignore", divide="ignore"):
        iou = np.where(union > 0, tp / np.maximum(union, 1), np.nan)
    return matrix, iou


def random_labels(rng, shape, num_classes, ignore=None, missing=()):
    labels = rng.integers(0, num_classes, shape).astype(np.uint8)
    for c in missing:  # classes left out on purpose
        labels[labels == c] = 0
    if ignore is not None:
        labels[rng.random(shape) < 0.1] = ignore
    return labels


def test_confusion_matrix_equals_bincount_with_ignore():
    rng = np.random.default_rng(7)
    gts = [random_labels(rng, (31, 47), 10, ignore=255, missing=(4,)) for _ in range(5)]
    preds = [random_labels(rng, (31, 47), 10, missing=(4,)) for _ in range(5)]
    matrix = fishcam.metrics.ConfusionMatrix(10, ignore=255)
    for p, g in zip(preds, gts):
        matrix.update(p.astype(np.int64), g)  # argmax-style int64 predictions
    expected_counts, expected_iou = reference_iou(preds, gts, 10, ignore=255)
    np.testing.assert_array_equal(matrix.counts, expected_counts)
    np.testing.assert_allclose(matrix.iou(), expected_iou, rtol=1e-15, equal_nan=True)
    assert np.isnan(matrix.iou()[4])
    assert matrix.miou() == pytest.approx(np.nanmean(expected_iou), rel=1e-15)


def test_torch_batches_and_validity_masks():
    rng = np.random.default_rng(3)
    gt = torch.from_numpy(rng.integers(0, 5, (4, 16, 16)))
    pred = torch.from_numpy(rng.integers(0, 5, (4, 16, 16)))
    valid = rng.random((4, 16, 16)) < 0.5
    matrix = fishcam.metrics.ConfusionMatrix(5)
    matrix.update(pred, gt, valid=torch.from_numpy(valid))
    _, expected = reference_iou([pred.numpy()[valid]], [gt.numpy()[valid]], 5)
    np.testing.assert_allclose(matrix.iou(), expected, rtol=1e-15)
    assert matrix.scored_pixels == valid.sum()


def test_validity_masks_are_bool_or_zero_one_integers():
    """256 and 0.5 once cast to 0 and silently left pixels unscored."""
    gt = np.array([[0, 1, 2, 1]], np.uint8)
    for mask in [
        np.array([[True, True, False, True]]),
        np.array([[1, 1, 0, 1]], np.int64),
        np.array([[1, 1, 0, 1]], np.uint16),
    ]:
        matrix = fishcam.metrics.ConfusionMatrix(3)
        matrix.update(gt, gt, valid=mask)
        assert matrix.scored_pixels == 3, mask.dtype
    matrix = fishcam.metrics.ConfusionMatrix(3)
    for mask, message in [
        (np.array([[256, 256, 1, 1]]), "only 0 and 1"),
        (np.array([[-1, 1, 1, 1]], np.int8), "only 0 and 1"),
        (np.array([[0.5, 1, 1, 1]]), "got dtype float64"),
        (np.array([["a", "b", "c", "d"]]), "got dtype"),
    ]:
        with pytest.raises(fishcam.Error, match=message):
            matrix.update(gt, gt, valid=mask)
    assert matrix.scored_pixels == 0


def test_bad_input_raises_and_leaves_the_matrix_unchanged():
    matrix = fishcam.metrics.ConfusionMatrix(3, ignore=255)
    matrix.update(np.zeros((2, 2), np.uint8), np.zeros((2, 2), np.uint8))
    before = matrix.counts.copy()
    cases = [
        (np.array([[0, 3]], np.uint8), np.array([[0, 0]], np.uint8), "prediction value 3 at pixel (1, 0)"),
        (np.array([[0, 0]], np.uint8), np.array([[9, 0]], np.uint8), "ground truth value 9 at pixel (0, 0)"),
        (np.zeros((2, 3), np.uint8), np.zeros((3, 2), np.uint8), "shape (2, 3) differs"),
        (np.zeros((2, 2), np.float32), np.zeros((2, 2), np.uint8), "dtype"),
    ]
    for pred, gt, message in cases:
        with pytest.raises(fishcam.Error, match=message.replace("(", r"\(").replace(")", r"\)")):
            matrix.update(pred, gt)
    np.testing.assert_array_equal(matrix.counts, before)
    with pytest.raises(fishcam.Error):
        fishcam.metrics.ConfusionMatrix(0)
    assert np.isnan(fishcam.metrics.ConfusionMatrix(2).miou())


def cli(*args, ok=True):
    if not BINARY:
        pytest.skip("FISHCAM_BINARY not set (run through CTest)")
    result = subprocess.run([BINARY, *map(str, args)], capture_output=True, text=True)
    if ok:
        assert result.returncode == 0, result.stderr
    else:
        assert result.returncode != 0
        assert result.stderr.count("\n") == 1, result.stderr
    return result


def write_set(folder, labels):
    folder.mkdir(parents=True, exist_ok=True)
    for i, image in enumerate(labels):
        assert cv2.imwrite(str(folder / f"img{i:02d}.png"), image)


def test_evaluate_equals_the_reference_and_prints_table_2(tmp_path):
    rng = np.random.default_rng(11)
    sets = {}
    for name, noise in (("original", 0.1), ("small", 0.3), ("large", 0.6)):
        gts = [random_labels(rng, (24, 40), 10, ignore=255, missing=(7,)) for _ in range(3)]
        preds = []
        for g in gts:
            p = np.where(rng.random(g.shape) < noise, rng.integers(0, 10, g.shape), g).astype(np.uint8)
            p[p == 255] = 0
            p[p == 7] = 0
            preds.append(p)
        write_set(tmp_path / name / "gt", gts)
        write_set(tmp_path / name / "pred", preds)
        sets[name] = reference_iou(preds, gts, 10, ignore=255)[1]
    args = []
    for name in sets:
        args += ["--set", f"{name}={tmp_path / name / 'pred'}:{tmp_path / name / 'gt'}"]
    result = json.loads(cli("evaluate", *args, "--ignore", 255, "--json").stdout)
    first = np.nanmean(sets["original"])
    for row, (name, iou) in zip(result["sets"], sets.items()):
        assert row["name"] == name and row["images"] == 3
        got = np.array([np.nan if v is None else v for v in row["iou"].values()])
        np.testing.assert_allclose(got, 100 * iou, rtol=1e-12, equal_nan=True)
        assert row["miou"] == pytest.approx(100 * np.nanmean(iou), rel=1e-12)
        assert row["absent"] == ["bicycle"]
        if name != "original":
            assert row["degradation_pct"] == pytest.approx(100 * (np.nanmean(iou) - first) / first, rel=1e-12)
    text = cli("evaluate", *args, "--ignore", 255).stdout
    assert "mIoU (%)" in text and "degrades (%)" in text and "left out of its mIoU: bicycle" in text
    single = json.loads(
        cli(
            "evaluate",
            "--pred",
            tmp_path / "small" / "pred",
            "--gt",
            tmp_path / "small" / "gt",
            "--ignore",
            255,
            "--json",
        ).stdout
    )
    assert single["miou"] == pytest.approx(100 * np.nanmean(sets["small"]), rel=1e-12)


def test_evaluate_reads_the_layout_augment_dataset_writes(tmp_path):
    rng = np.random.default_rng(5)
    for preset in ("small", "large"):
        labels = [random_labels(rng, (8, 8), 3) for _ in range(2)]
        write_set(tmp_path / "gt" / preset / "semantic_annotations" / "gtLabels", labels)
        write_set(tmp_path / "pred" / preset, labels)
    result = json.loads(
        cli("evaluate", "--pred", tmp_path / "pred", "--gt", tmp_path / "gt", "--classes", 3, "--json").stdout
    )
    assert [s["name"] for s in result["sets"]] == ["small", "large"]
    assert all(s["miou"] == 100 for s in result["sets"])


def test_evaluate_bad_inputs_name_the_file(tmp_path):
    gt, pred = tmp_path / "gt", tmp_path / "pred"
    write_set(gt, [np.zeros((4, 4), np.uint8), np.ones((4, 4), np.uint8)])
    write_set(pred, [np.zeros((4, 4), np.uint8)])
    assert "img01.png: no prediction named img01" in cli("evaluate", "--pred", pred, "--gt", gt, ok=False).stderr
    write_set(pred, [np.zeros((4, 4), np.uint8), np.zeros((4, 5), np.uint8)])
    assert "img01.png: is 5x4 but its ground truth" in cli("evaluate", "--pred", pred, "--gt", gt, ok=False).stderr
    write_set(pred, [np.zeros((4, 4), np.uint8), np.full((4, 4), 12, np.uint8)])
    err = cli("evaluate", "--pred", pred, "--gt", gt, ok=False).stderr
    assert str(pred / "img01.png") + ": prediction value 12 at pixel (0, 0) is not a class (0 to 9)" in err
    write_set(gt, [np.zeros((4, 4), np.uint8), np.full((4, 4), 255, np.uint8)])
    write_set(pred, [np.zeros((4, 4), np.uint8), np.zeros((4, 4), np.uint8)])
    err = cli("evaluate", "--pred", pred, "--gt", gt, ok=False).stderr
    assert str(gt / "img01.png") + ": ground truth value 255" in err
    cli("evaluate", "--pred", pred, "--gt", gt, "--ignore", 255)  # ignored before the range check
    assert cv2.imwrite(str(pred / "extra.png"), np.zeros((4, 4), np.uint8))
    assert (
        "extra.png: no ground truth named extra"
        in cli("evaluate", "--pred", pred, "--gt", gt, "--ignore", 255, ok=False).stderr
    )
    os.remove(pred / "extra.png")
    assert "--classes" in cli("evaluate", "--pred", pred, "--gt", gt, "--classes", "x", ok=False).stderr
    assert "--set" in cli("evaluate", "--set", "nope", ok=False).stderr
    assert "no such folder" in cli("evaluate", "--pred", tmp_path / "none", "--gt", gt, ok=False).stderr
