"""WoodScapeDataset and EpochSampler: whole samples for the transform, a seed per
sample and epoch."""

import json
import operator
import os
import typing

import numpy as np
import torch
from torchvision import tv_tensors

from .. import (
    _MAX_CAMERA_FILE_BYTES,
    Camera,
    Error,
    _check_regular_file,
    _check_seed,
    _read_regular_file,
    _shown,
    derive_seed,
)
from .. import transforms as _transforms
from .seeding import record_changes, sample_seed
from .targets import Sample


def _cv2() -> typing.Any:
    import cv2  # python3-opencv: only the dataset needs it

    return cv2


class EpochSampler(torch.utils.data.Sampler[tuple[int, int]]):
    """Yields ``(epoch, index)`` for every index of ``sampler``, one epoch per pass.

    The DataLoader iterates its sampler in the main process, so the epoch reaches
    ``WoodScapeDataset(seed=...)`` in every worker, persistent or not. Each
    ``iter()`` starts the next epoch (0, 1, 2, ... from ``start_epoch``);
    ``set_epoch(e)`` makes the next pass epoch ``e`` (resuming a training run).
    A sampler with ``set_epoch`` (``DistributedSampler``) is told each epoch too,
    so its shuffle changes with it.

    Args:
        sampler: any sampler or iterable of dataset indices with ``len()``
            (``SequentialSampler``, ``RandomSampler``, ``DistributedSampler``, a list).
        start_epoch: the first pass's epoch.
    """

    def __init__(self, sampler: typing.Iterable[int], start_epoch: int = 0) -> None:
        if isinstance(start_epoch, bool) or not isinstance(start_epoch, int) or start_epoch < 0:
            raise Error(f"EpochSampler: start_epoch must be a non-negative integer, got {_shown(start_epoch)}")
        self.sampler = sampler
        self.next_epoch = start_epoch

    def set_epoch(self, epoch: int) -> None:
        """Makes the next pass epoch ``epoch``."""
        if isinstance(epoch, bool) or not isinstance(epoch, int) or epoch < 0:
            raise Error(f"EpochSampler.set_epoch: expected a non-negative integer, got {_shown(epoch)}")
        self.next_epoch = epoch

    def __len__(self) -> int:
        return len(typing.cast(typing.Sized, self.sampler))

    def __iter__(self) -> typing.Iterator[tuple[int, int]]:
        epoch = self.next_epoch
        self.next_epoch = epoch + 1
        if hasattr(self.sampler, "set_epoch"):
            self.sampler.set_epoch(epoch)
        for index in self.sampler:
            yield (epoch, int(index))


def _index(value: object, what: str) -> int:
    """An integer index (int, numpy or 0-dimensional torch integer), or fishcam.Error."""
    if isinstance(value, (bool, np.bool_)):
        raise Error(f"{what}: expected an integer, got {type(value).__name__}")
    try:
        return operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise Error(f"{what}: expected an integer, got {type(value).__name__}") from None


class WoodScapeDataset(torch.utils.data.Dataset[Sample]):
    """Samples of a WoodScape-layout folder: ``rgb_images/NAME.png``,
    ``semantic_annotations/gtLabels/NAME.png`` and ``calibration/NAME.json`` (one
    calibration per image, as WoodScape has). One image a name: ``NAME.png`` beside
    ``NAME.jpg`` is refused (fishcam.Error naming both).

    Each item is a dict: ``image`` (``tv_tensors.Image``, 3xHxW uint8), ``mask``
    (``tv_tensors.Mask``, HxW ``mask_dtype``, int64 by default: what cross-entropy
    takes; None keeps the PNG's uint8/uint16), ``camera`` (the fishcam.Camera of the
    image), ``name``; the whole dict goes through ``transform`` (the mask still as
    decoded, which is cheaper to resample; a v2 transform or
    ``v2.Compose``; fishcam's transforms take the camera from it and put the
    augmented camera back), and ``changes`` is added: the records of the changes
    fishcam's transforms made, as a JSON list (seeds are 64-bit, past torch's int64;
    ``json.loads`` gives the dicts back). Batch with ``collate_fn=fishcam.torch.collate``
    (cameras are gathered into lists). Cameras are read once per distinct calibration
    file content; the transforms keep one warp per calibration.

    With ``seed``, sample ``index`` in epoch ``e`` is transformed under
    ``sample_seed(derive_seed(seed, f"epoch{e}", index))``: the same change whatever
    the workers. The epoch comes with the key: ``dataset[(e, index)]``, as
    ``EpochSampler`` yields them; a bare ``dataset[index]`` uses ``set_epoch``'s
    epoch, in the main process only, and only once ``set_epoch`` has been called
    (raises otherwise: every epoch would repeat epoch 0's changes; and in a
    DataLoader worker, whose copy never sees ``set_epoch``).
    """

    def __init__(
        self,
        root: typing.Union[str, "os.PathLike[str]"],
        transform: typing.Optional[typing.Callable[[Sample], Sample]] = None,
        seed: typing.Optional[int] = None,
        mask_dtype: typing.Optional[torch.dtype] = torch.int64,
    ) -> None:
        self.root = os.fspath(root)
        self.transform = transform
        self.mask_dtype = mask_dtype
        self.seed = None if seed is None else _check_seed(seed)
        self.epoch: typing.Optional[int] = None  # set_epoch's; None: bare indices of a seeded dataset refused
        images = os.path.join(self.root, "rgb_images")
        if not os.path.isdir(images):
            raise Error(f"{images}: missing (expected the WoodScape layout)")
        # One image a name: NAME.png beside NAME.jpg would be one sample twice (or two
        # images under one calibration and label image).
        self._files: dict[str, str] = {}
        for f in sorted(os.listdir(images)):
            name, extension = os.path.splitext(f)
            if extension.lower() not in (".png", ".jpg", ".jpeg"):
                continue
            if name in self._files:
                raise Error(f"{images}: two images of sample {name!r}, {self._files[name]!r} and {f!r}: keep one")
            self._files[name] = f
        self.names = sorted(self._files)
        if not self.names:
            raise Error(f"{images}: no images")
        self._cameras: dict[bytes, Camera] = {}

    def set_epoch(self, epoch: int) -> None:
        """The epoch of bare-index items in this process (DataLoader workers: use EpochSampler)."""
        self.epoch = _index(epoch, "WoodScapeDataset.set_epoch")

    def _epoch_and_index(self, key: typing.Union[int, tuple[int, int]]) -> tuple[typing.Optional[int], int]:
        if isinstance(key, tuple):
            if len(key) != 2:
                raise Error(f"WoodScapeDataset: expected an index or (epoch, index), got {_shown(key)}")
            epoch, index = (_index(k, "WoodScapeDataset: (epoch, index)") for k in key)
        else:
            epoch, index = None, _index(key, "WoodScapeDataset: index")
            if self.seed is not None and self.transform is not None:
                if torch.utils.data.get_worker_info() is not None:
                    raise Error(
                        "WoodScapeDataset(seed=...) in a DataLoader worker needs the epoch with each index "
                        "(the worker's copy never sees set_epoch): pass "
                        "sampler=fishcam.torch.EpochSampler(...) to the DataLoader"
                    )
                if self.epoch is None:
                    raise Error(
                        "WoodScapeDataset(seed=...): a bare index has no epoch (every epoch would repeat "
                        "epoch 0's changes): pass sampler=fishcam.torch.EpochSampler(...) to the DataLoader, "
                        "index with (epoch, index), or call set_epoch(e) before each epoch"
                    )
                epoch = self.epoch
        if not -len(self.names) <= index < len(self.names):
            raise IndexError(f"WoodScapeDataset: index {index} out of range for {len(self.names)} samples")
        return epoch, index % len(self.names)

    def __len__(self) -> int:
        return len(self.names)

    def camera(self, name: str) -> Camera:
        """The fishcam.Camera of sample ``name`` (read once per distinct file content)."""
        path = os.path.join(self.root, "calibration", name + ".json")
        key = _read_regular_file(path, _MAX_CAMERA_FILE_BYTES, "a camera file")
        camera = self._cameras.get(key)
        if camera is None:
            camera = Camera.read(path)
            self._cameras[key] = camera
        return camera

    @staticmethod
    def _read(path: str, flags: int) -> _transforms.Array:
        _check_regular_file(path, "an image")  # a FIFO would block imread
        image: typing.Optional[_transforms.Array] = _cv2().imread(path, flags)
        if image is None:
            raise Error(f"{path}: cannot read image")
        return image

    def __getitem__(self, key: typing.Union[int, tuple[int, int]]) -> Sample:
        epoch, index = self._epoch_and_index(key)
        name = self.names[index]
        image = self._read(os.path.join(self.root, "rgb_images", self._files[name]), _cv2().IMREAD_COLOR)
        image = _cv2().cvtColor(image, _cv2().COLOR_BGR2RGB)
        mask = self._read(
            os.path.join(self.root, "semantic_annotations", "gtLabels", name + ".png"), _cv2().IMREAD_UNCHANGED
        )
        if mask.ndim != 2:
            raise Error(f"{name}: expected a single-channel label image")
        # The transform gets the mask as decoded (uint8 or uint16: cheaper to resample);
        # the item has it in mask_dtype.
        item = {
            "image": tv_tensors.Image(torch.from_numpy(image).permute(2, 0, 1)),
            "mask": tv_tensors.Mask(torch.from_numpy(mask)),
            "camera": self.camera(name),
            "name": name,
        }
        if self.transform is None:
            return self._with_mask_dtype(item)
        if self.seed is None:
            with record_changes() as records:
                item = self.transform(item)
        else:
            with sample_seed(derive_seed(self.seed, f"epoch{epoch}", index)) as records:
                item = self.transform(item)
        item = self._with_mask_dtype(item)
        item["changes"] = json.dumps(records)
        return item

    def _with_mask_dtype(self, item: Sample) -> Sample:
        mask = item.get("mask") if isinstance(item, dict) else None
        if self.mask_dtype is not None and isinstance(mask, torch.Tensor) and mask.dtype != self.mask_dtype:
            item["mask"] = (
                tv_tensors.wrap(mask.to(self.mask_dtype), like=mask)
                if isinstance(mask, tv_tensors.TVTensor)
                else mask.to(self.mask_dtype)
            )
        return item
