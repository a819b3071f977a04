"""fishcam for PyTorch: the viewpoint transform (and the affine baseline) as nn.Modules, a WoodScape dataset,
an epoch-carrying sampler, and the DataLoader worker set-up.

    dataset = fishcam.torch.WoodScapeDataset(root, transform=fishcam.torch.RandomViewpoint(preset="train"), seed=5)
    loader = torch.utils.data.DataLoader(dataset, batch_size=8, num_workers=2,
                                         sampler=fishcam.torch.EpochSampler(torch.utils.data.RandomSampler(dataset)),
                                         worker_init_fn=fishcam.torch.worker_init_fn,
                                         persistent_workers=True,  # workers keep their warps
                                         generator=torch.Generator().manual_seed(0))

Seeding: without a dataset seed, each sample's change comes from torch's generator
(two 32-bit draws, since torch.randint cannot draw 64 bits), which the DataLoader
seeds per worker from its own generator: workers differ, and the same generator
seed reproduces a run. With ``WoodScapeDataset(seed=S)``, sample ``i`` of epoch
``e`` gets ``derive_seed(S, f"epoch{e}", i)`` whatever the workers and processes:
the epoch travels with the index from ``EpochSampler``, which runs in the main
process and counts the epochs itself. A seeded dataset indexed by a bare index
inside a DataLoader worker raises instead of repeating one epoch's changes (a
worker's copy of the dataset never sees ``set_epoch`` from the main process).
"""

import json
import os

import numpy as np
import torch

from . import Camera, Error, derive_seed, set_num_threads
from . import transforms as _transforms


def _cv2():
    import cv2  # python3-opencv: only the dataset needs it

    return cv2


def torch_seed():
    """One 64-bit seed from torch's (per-worker) generator."""
    hi, lo = torch.randint(0, 2**32, (2,), dtype=torch.int64).tolist()
    return (hi << 32) | lo


def worker_init_fn(worker_id):
    """For DataLoader workers: one fishcam thread each (the workers are the parallelism)."""
    del worker_id
    set_num_threads(1)


def _to_numpy(x, what):
    """HWC numpy from a numpy array or a CHW / HW tensor; returns (array, was_tensor)."""
    if isinstance(x, torch.Tensor):
        if x.device.type != "cpu":
            raise Error(f"{what}: fishcam runs on the CPU; got a tensor on {x.device} (move it with .cpu())")
        array = x.detach().numpy()
        if array.ndim == 3:
            array = np.moveaxis(array, 0, -1)  # CHW -> HWC (a view; copied to contiguous in C++)
        return array, True
    if isinstance(x, np.ndarray):
        return x, False
    raise Error(f"{what}: expected a numpy array or a torch tensor, got {type(x).__name__}")


def _from_numpy(array, as_tensor):
    if not as_tensor:
        return array
    tensor = torch.from_numpy(array)
    return tensor.permute(2, 0, 1) if tensor.ndim == 3 else tensor


class _Transform(torch.nn.Module):
    """A numpy transform of fishcam.transforms as a module: ``forward(image, mask=None,
    camera=None, seed=None)`` -> ``(image, mask, change)``. Images HWC numpy or CHW
    tensors (returned the same way), masks HW; the change is the manifest dict.
    Without ``seed``, one is drawn from torch's (per-worker) generator."""

    def __init__(self, transform):
        super().__init__()
        self.transform = transform

    def forward(self, image, mask=None, camera=None, seed=None):
        image_np, image_tensor = _to_numpy(image, "image")
        mask_np, mask_tensor = (None, False) if mask is None else _to_numpy(mask, "mask")
        if seed is None:
            seed = torch_seed()
        out = self.transform(image=image_np, mask=mask_np, camera=camera, seed=seed)
        new_mask = _from_numpy(out["mask"], mask_tensor) if mask is not None else None
        return _from_numpy(out["image"], image_tensor), new_mask, out["change"]


class RandomViewpoint(_Transform):
    """fishcam.transforms.RandomViewpoint as a module (see _Transform)."""

    def __init__(self, camera=None, preset="train", max_rotation_deg=None, max_translation=None,
                 depth="source-sphere", p=1.0, fill=0, fill_mask=0, sampling="grid"):
        super().__init__(_transforms.RandomViewpoint(camera, preset=preset, max_rotation_deg=max_rotation_deg,
                                                     max_translation=max_translation, depth=depth, p=p, fill=fill,
                                                     fill_mask=fill_mask, sampling=sampling))


class RandomAffine(_Transform):
    """fishcam.transforms.RandomAffine (the paper's affine baseline) as a module (see _Transform)."""

    def __init__(self, preset="train", max_rotation_deg=None, max_translation=None, scale_range=None, p=1.0,
                 fill=0, fill_mask=0):
        super().__init__(_transforms.RandomAffine(preset=preset, max_rotation_deg=max_rotation_deg,
                                                  max_translation=max_translation, scale_range=scale_range, p=p,
                                                  fill=fill, fill_mask=fill_mask))


class EpochSampler(torch.utils.data.Sampler):
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

    def __init__(self, sampler, start_epoch=0):
        if isinstance(start_epoch, bool) or not isinstance(start_epoch, int) or start_epoch < 0:
            raise Error(f"EpochSampler: start_epoch must be a non-negative integer, got {start_epoch!r}")
        self.sampler = sampler
        self.next_epoch = start_epoch

    def set_epoch(self, epoch):
        """Makes the next pass epoch ``epoch``."""
        if isinstance(epoch, bool) or not isinstance(epoch, int) or epoch < 0:
            raise Error(f"EpochSampler.set_epoch: expected a non-negative integer, got {epoch!r}")
        self.next_epoch = epoch

    def __len__(self):
        return len(self.sampler)

    def __iter__(self):
        epoch = self.next_epoch
        self.next_epoch = epoch + 1
        if hasattr(self.sampler, "set_epoch"):
            self.sampler.set_epoch(epoch)
        for index in self.sampler:
            yield (epoch, int(index))


class WoodScapeDataset(torch.utils.data.Dataset):
    """Samples of a WoodScape-layout folder: ``rgb_images/NAME.png``,
    ``semantic_annotations/gtLabels/NAME.png`` and ``calibration/NAME.json`` (one
    calibration per image, as WoodScape has).

    Each item is a dict: ``image`` (CHW uint8 tensor), ``mask`` (HW int64 tensor),
    ``name``, and ``change`` when a transform is set: the manifest's fields as a
    JSON string (seeds are 64-bit, past torch's int64, so the default collate
    could not batch them as numbers; ``json.loads`` gives the dict back). Cameras are read once per
    distinct calibration file content; the transform keeps one warp per calibration.
    With ``seed``, sample ``index`` in epoch ``e`` gets the seed
    ``derive_seed(seed, f"epoch{e}", index)``: the same whatever the workers. The
    epoch comes with the key: ``dataset[(e, index)]``, as ``EpochSampler`` yields
    them; a bare ``dataset[index]`` uses ``set_epoch``'s epoch, in the main process
    only (raises in a DataLoader worker, whose copy never sees ``set_epoch``).
    """

    def __init__(self, root, transform=None, seed=None):
        self.root = os.fspath(root)
        self.transform = transform
        self.seed = None if seed is None else int(seed)
        self.epoch = 0
        images = os.path.join(self.root, "rgb_images")
        if not os.path.isdir(images):
            raise Error(f"{images}: missing (expected the WoodScape layout)")
        self.names = sorted(os.path.splitext(f)[0] for f in os.listdir(images)
                            if f.lower().endswith((".png", ".jpg", ".jpeg")))
        if not self.names:
            raise Error(f"{images}: no images")
        self._files = {os.path.splitext(f)[0]: f for f in os.listdir(images)}
        self._cameras = {}

    def set_epoch(self, epoch):
        """The epoch of bare-index items in this process (DataLoader workers: use EpochSampler)."""
        self.epoch = int(epoch)

    def _epoch_and_index(self, key):
        if isinstance(key, tuple):
            if len(key) != 2:
                raise Error(f"WoodScapeDataset: expected an index or (epoch, index), got {key!r}")
            epoch, index = (int(k) for k in key)
        else:
            epoch, index = None, int(key)
            if self.seed is not None and self.transform is not None:
                if torch.utils.data.get_worker_info() is not None:
                    raise Error("WoodScapeDataset(seed=...) in a DataLoader worker needs the epoch with each index "
                                "(the worker's copy never sees set_epoch): pass "
                                "sampler=fishcam.torch.EpochSampler(...) to the DataLoader")
                epoch = self.epoch
        if not -len(self.names) <= index < len(self.names):
            raise IndexError(f"WoodScapeDataset: index {index} out of range for {len(self.names)} samples")
        return epoch, index % len(self.names)

    def __len__(self):
        return len(self.names)

    def camera(self, name):
        path = os.path.join(self.root, "calibration", name + ".json")
        with open(path, "rb") as f:
            key = f.read()
        camera = self._cameras.get(key)
        if camera is None:
            camera = Camera.read(path)
            self._cameras[key] = camera
        return camera

    @staticmethod
    def _read(path, flags):
        image = _cv2().imread(path, flags)
        if image is None:
            raise Error(f"{path}: cannot read image")
        return image

    def __getitem__(self, key):
        epoch, index = self._epoch_and_index(key)
        name = self.names[index]
        image = self._read(os.path.join(self.root, "rgb_images", self._files[name]), _cv2().IMREAD_COLOR)
        image = _cv2().cvtColor(image, _cv2().COLOR_BGR2RGB)
        mask = self._read(os.path.join(self.root, "semantic_annotations", "gtLabels", name + ".png"),
                          _cv2().IMREAD_UNCHANGED)
        if mask.ndim != 2:
            raise Error(f"{name}: expected a single-channel label image")
        item = {"name": name}
        if self.transform is not None:
            seed = None if self.seed is None else derive_seed(self.seed, f"epoch{epoch}", index)
            camera = self.camera(name)
            if isinstance(self.transform, _Transform):
                image, mask, item["change"] = self.transform(image, mask, camera=camera, seed=seed)
            else:
                out = self.transform(image=image, mask=mask, camera=camera, seed=seed)
                image, mask, item["change"] = out["image"], out["mask"], out["change"]
        if "change" in item:
            item["change"] = json.dumps(item["change"])
        item["image"] = torch.from_numpy(np.ascontiguousarray(image)).permute(2, 0, 1)
        item["mask"] = torch.from_numpy(mask.astype(np.int64))
        return item
