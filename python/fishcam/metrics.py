"""Segmentation metrics the paper's way (eqs. 11-12), as ``fishcam evaluate`` computes them.

    matrix = fishcam.metrics.ConfusionMatrix(10, ignore=255)
    for images, masks in loader:
        matrix.update(model(images).argmax(1), masks)   # torch tensors or numpy arrays
    print(matrix.miou(), matrix.iou())

One confusion matrix over every scored pixel of the test set (not a mean of
per-image scores). IoU and mIoU are fractions in [0, 1] (the CLI prints %); a class
absent from both prediction and ground truth has IoU NaN and is left out of the
mean.
"""

import typing

import numpy as np
import numpy.typing as npt

from . import Error, _fishcam

__all__ = ["ConfusionMatrix"]


def _as_numpy(x: typing.Any, what: str) -> npt.NDArray[typing.Any]:
    if isinstance(x, np.ndarray):
        return x
    if type(x).__module__.startswith("torch"):
        # GPU outputs are copied to the host: the counting runs in C++ on the CPU.
        array: npt.NDArray[typing.Any] = x.detach().cpu().numpy()
        return array
    if x is None:
        raise Error(f"{what}: expected an array, got None")
    return np.asarray(x)


class ConfusionMatrix(_fishcam.ConfusionMatrix):
    """``ConfusionMatrix(num_classes, ignore=None)``: rows ground truth, columns prediction.

    update(prediction, ground_truth, valid=None): integer arrays (uint8, uint16, int32
        or int64; numpy or torch, any equal shape: one image or a batch); ground-truth
        pixels equal to ``ignore`` and pixels where ``valid`` is 0 are not scored. A
        value that is not a class raises fishcam.Error and leaves the matrix unchanged.
    iou(): per class, NaN where the class is absent from both. miou(): their mean
        over the present classes (NaN before any pixel was scored).
    counts: the matrix as an int64 (num_classes, num_classes) array.
    """

    def update(self, prediction: typing.Any, ground_truth: typing.Any, valid: typing.Any = None) -> None:
        """Counts the pixels of one batch: prediction and ground_truth integer arrays
        (numpy or torch, CUDA tensors copied to the host) of one shape, valid an
        optional bool mask of that shape. A value that is not a class (nor the
        ignored label) raises fishcam.Error and leaves the matrix unchanged."""
        prediction = _as_numpy(prediction, "prediction")
        ground_truth = _as_numpy(ground_truth, "ground_truth")
        if valid is not None:
            valid = _as_numpy(valid, "valid")
        super().update(prediction, ground_truth, valid)

    def iou(self) -> npt.NDArray[np.float64]:
        """Per-class intersection over union, (num_classes,) float64 fractions; NaN for
        classes absent from both prediction and ground truth."""
        return np.array([np.nan if v is None else v for v in self._iou()], dtype=np.float64)

    def miou(self) -> float:
        """The mean of iou() over the classes present (a float fraction; NaN if none)."""
        value = self._miou()
        return float("nan") if value is None else value

    def __repr__(self) -> str:
        return (
            f"ConfusionMatrix(num_classes={self.num_classes}, ignore={self.ignore}, scored_pixels={self.scored_pixels})"
        )
