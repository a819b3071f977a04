"""The paper's experiment on fishcam's synthetic surround-view streets (docs/experiment.md).

Trains a small segmentation network (a compact U-Net in plain PyTorch, no downloaded
weights) on the train split of a ``fishcam sample-dataset --scenes N`` dataset under
each augmentation configuration, for several training seeds, and evaluates every
run on the original test split and on the true viewpoint test sets (the test scenes
re-rendered from moved cameras). Writes ``runs/CONFIG-seedS.json`` and the trained
weights ``runs/CONFIG-seedS.pt`` per run (a run already there is not repeated: the
experiment resumes; each run records its settings and the dataset's identity, and a
stored run that differs is refused, or recomputed with ``--rerun``), ``results.json``,
``tables.md`` (the paper's Tables 2-5 as mean ± std over the seeds, and the
augmentation's fidelity against the re-renders) and ``figures/`` (mIoU against change
size; example predictions; needs matplotlib).

    build/tools/fishcam sample-dataset sv --scenes 48 --size 192x145 --seed 1 --depth
    python -m fishcam.experiment sv results/ [--seeds 3] [--epochs 12] [--quick]
    python -m fishcam.experiment sv results/ --budget 60   # --scale, --train-images, --width, --epochs chosen

Under ``torchrun --nproc_per_node=N`` each process trains on its share of every
batch (``DistributedSampler`` inside ``fishcam.torch.EpochSampler``, gloo on the CPU,
NCCL with ``--device cuda``); rank 0 evaluates and writes.
"""

import argparse
import hashlib
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import time
import typing

import numpy as np
import numpy.typing as npt
import torch
import torch.distributed as dist
from torchvision import tv_tensors
from torchvision.transforms import v2

import fishcam
import fishcam.metrics
import fishcam.torch as ft

from . import Error, experiment_budget

CLASSES = 10
NO_SOURCE = 255
TEST_SETS = ("small", "medium", "large")
# A split file's size at most (WoodScape's lists of ~10k names are ~150 KB).
MAX_SPLIT_FILE_BYTES = 16 << 20
# The image files a dataset's rgb_images/ holds (other files there are ignored).
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg")
# --width's bound: 16 times the harness's default (the network's parameters grow as
# 454 width^2: 30 M at 256, 0.5 GB with AdamW's state; its activations as 40 width
# floats per pixel and image, checked against the memory available by
# training_memory); far past what this CPU experiment can train in its budget.
MAX_WIDTH = 256
# What a run's result depends on besides its configuration and seed, in the order a
# difference is reported (the dataset's identity is compared first); the option that
# sets each.
SETTINGS = (
    ("scale", "--scale"),
    ("train_images", "--train-images"),
    ("epochs", "--epochs"),
    ("batch_size", "--batch-size"),
    ("width", "--width"),
    ("class_weights", "--class-weights"),
    ("device", "--device"),
    ("amp", "--amp"),
    ("channels_last", "--channels-last"),
    ("processes", "--nproc_per_node (torchrun's processes)"),
)
# The value a setting had before the harness recorded it (runs stored by then; they
# trained on every image of train/, which stored_run is told).
SETTING_DEFAULTS: dict[str, typing.Any] = {"amp": False, "channels_last": False, "scale": 1.0}

# Augmentation configurations: Table 3 (none, base, viewpoint, base + viewpoint),
# Table 4 (affine vs viewpoint), Table 5 (viewpoint computed with a model fitted to
# the camera instead of its own: equidistant, stereographic, Kannala-Brandt; the
# paper's fit, which defines the first two only, and least squares).
CONFIGS = (
    "none",
    "base",
    "viewpoint",
    "base+viewpoint",
    "affine",
    "viewpoint:equidistant:paper",
    "viewpoint:equidistant:lsq",
    "viewpoint:stereographic:paper",
    "viewpoint:stereographic:lsq",
    "viewpoint:kannala-brandt:lsq",
)
# --quick's settings, and the defaults without it (an option given explicitly wins;
# with either, --scale 1 and --train-images all of train/ unless --budget chooses them).
QUICK: dict[str, typing.Any] = {"configs": "none,viewpoint", "seeds": 2, "epochs": 1, "width": 4}
DEFAULTS: dict[str, typing.Any] = {"configs": ",".join(CONFIGS), "seeds": 3, "epochs": 10, "width": 16}
# What --budget chooses when not given (fishcam.experiment_budget).
BUDGET_CHOOSES = ("scale", "train_images", "width", "epochs")


class UNet(torch.nn.Module):
    """A compact U-Net: three levels, ``width`` channels at the top, doubled per level."""

    def __init__(self, width: int = 16, classes: int = CLASSES) -> None:
        super().__init__()

        def block(a: int, b: int) -> torch.nn.Sequential:
            return torch.nn.Sequential(
                torch.nn.Conv2d(a, b, 3, padding=1),
                torch.nn.BatchNorm2d(b),
                torch.nn.ReLU(),
                torch.nn.Conv2d(b, b, 3, padding=1),
                torch.nn.BatchNorm2d(b),
                torch.nn.ReLU(),
            )

        w = width
        self.down1, self.down2, self.down3 = block(3, w), block(w, 2 * w), block(2 * w, 4 * w)
        self.up2, self.up1 = torch.nn.ConvTranspose2d(4 * w, 2 * w, 2, 2), torch.nn.ConvTranspose2d(2 * w, w, 2, 2)
        self.fuse2, self.fuse1 = block(4 * w, 2 * w), block(2 * w, w)
        self.head = torch.nn.Conv2d(w, classes, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h, w = x.shape[-2:]
        pad_h, pad_w = (-h) % 4, (-w) % 4  # two halvings
        x = torch.nn.functional.pad(x, (0, pad_w, 0, pad_h))
        a = self.down1(x)
        b = self.down2(torch.nn.functional.max_pool2d(a, 2))
        c = self.down3(torch.nn.functional.max_pool2d(b, 2))
        b = self.fuse2(torch.cat([self.up2(c), b], 1))
        a = self.fuse1(torch.cat([self.up1(b), a], 1))
        return typing.cast(torch.Tensor, self.head(a)[..., :h, :w])


class ReplaceCamera:
    """Puts a fitted model of the sample's camera in its place (Table 5), for the
    viewpoint transform that follows."""

    def __init__(self, model: str, method: str) -> None:
        self.model, self.method = model, method
        self._fits: dict[fishcam.Camera, fishcam.Camera] = {}

    def __call__(self, sample: dict[str, typing.Any]) -> dict[str, typing.Any]:
        camera = sample["camera"]
        if camera not in self._fits:
            self._fits[camera] = fishcam.convert(camera, self.model, self.method).camera
        return {**sample, "camera": self._fits[camera]}


def scaled_size(image_size: tuple[int, int], scale: float) -> tuple[int, int]:
    """(height, width) of an image of ``image_size`` downscaled by ``scale`` (halves
    rounded up, at least one pixel)."""
    height, width = image_size
    return max(1, math.floor(height * scale + 0.5)), max(1, math.floor(width * scale + 0.5))


class Downscale:
    """Resizes a sample by ``scale`` (--scale) through ``fishcam.torch.Resize``: the
    image with antialiasing, the labels nearest-neighbour (torchvision resizes masks
    so), and the camera resized with them (``Camera.resized``), so that the viewpoint
    augmentation after it stays exact at the new resolution."""

    def __init__(self, scale: float) -> None:
        self.scale = scale
        self._resizes: dict[tuple[int, int], typing.Any] = {}

    def __call__(self, sample: dict[str, typing.Any]) -> dict[str, typing.Any]:
        height, width = sample["image"].shape[-2:]
        size = scaled_size((int(height), int(width)), self.scale)
        if size not in self._resizes:
            self._resizes[size] = ft.Resize(size)
        resized: dict[str, typing.Any] = self._resizes[size](sample)
        return resized


def transform_for(config: str, scale: float = 1.0) -> typing.Optional[typing.Callable[[typing.Any], typing.Any]]:
    """The training transform of a configuration at ``scale`` (None: no augmentation):
    the downscaling first, so the augmentations see the training resolution's camera."""
    if config not in CONFIGS:
        raise Error(f"config: expected one of {', '.join(CONFIGS)}, got {config!r}")
    to_float = v2.ToDtype({tv_tensors.Image: torch.float32, "others": None}, scale=True)
    base = [
        v2.ColorJitter(brightness=0.3, contrast=0.3, saturation=0.3),
        v2.GaussianBlur(5, sigma=(0.1, 1.5)),
        v2.RandomHorizontalFlip(),
    ]
    steps: list[typing.Any] = [] if scale == 1 else [Downscale(scale)]
    if config.startswith("viewpoint:"):
        _, model, method = config.split(":")
        steps += [ReplaceCamera(model, method), ft.RandomViewpoint(preset="train", fill_mask=NO_SOURCE)]
    elif config in ("viewpoint", "base+viewpoint"):
        steps.append(ft.RandomViewpoint(preset="train", fill_mask=NO_SOURCE))
    elif config == "affine":
        steps.append(ft.RandomAffine(preset="train", fill_mask=NO_SOURCE))
    if config in ("base", "base+viewpoint"):
        steps += base
    compose: typing.Callable[[typing.Any], typing.Any] = v2.Compose(steps + [to_float])
    return compose


def evaluation_transform(scale: float = 1.0) -> typing.Callable[[typing.Any], typing.Any]:
    """What the test images go through: downscaled as the training images (``scale``),
    labels nearest-neighbour, so a run is scored at the resolution it trained at."""
    to_float = v2.ToDtype({tv_tensors.Image: torch.float32, "others": None}, scale=True)
    transform: typing.Callable[[typing.Any], typing.Any] = (
        to_float if scale == 1 else v2.Compose([Downscale(scale), to_float])
    )
    return transform


def distributed() -> tuple[int, int]:
    """(rank, world size); initialises the process group under torchrun."""
    if "WORLD_SIZE" not in os.environ or int(os.environ["WORLD_SIZE"]) < 2:
        return 0, 1
    if not dist.is_initialized():
        dist.init_process_group(
            "nccl" if torch.cuda.is_available() and os.environ.get("FISHCAM_DEVICE") == "cuda" else "gloo"
        )
    return dist.get_rank(), dist.get_world_size()


def class_weights(counts: npt.NDArray[np.int64]) -> torch.Tensor:
    """ENet's class weights 1 / ln(1.02 + p) from the label shares p of a split (the
    un-augmented masks' pixel counts per class, ``DatasetInfo.train_counts``), so that
    the small classes (persons, riders, signs) are learnt beside road and background;
    absent classes weigh 0."""
    share = counts / max(int(counts.sum()), 1)
    weights = np.where(counts > 0, 1.0 / np.log(1.02 + share), 0.0)
    return torch.tensor(weights, dtype=torch.float32)


def evaluation_folders(dataset_root: str) -> list[tuple[str, str]]:
    """(test set, folder) of every split a run is scored on: ``original`` (test/), then
    each true viewpoint test set present (test-PRESET/, test-PRESET-rotation/) and the
    paper's protocol (test-PRESET-paper/: the original test images augmented)."""
    folders = [("original", os.path.join(dataset_root, "test"))]
    for name in TEST_SETS:
        for variant in (f"test-{name}", f"test-{name}-rotation", f"test-{name}-paper"):
            folder = os.path.join(dataset_root, variant)
            if os.path.isdir(folder):
                folders.append((variant[len("test-") :], folder))
    return folders


class DatasetInfo(typing.NamedTuple):
    """What scan_dataset found: the identity of the files the runs read, the training
    images' size and count, and the training labels' pixel count per class, per
    training image in the sorted order of their names (the order --train-images takes
    the first of)."""

    sha256: str
    files: int
    image_size: tuple[int, int]  # (height, width)
    train_images: int
    train_image_counts: npt.NDArray[np.int64]  # train_images x CLASSES

    def train_counts(self, images: int) -> npt.NDArray[np.int64]:
        """The pixel count per class of the first ``images`` training images."""
        counts: npt.NDArray[np.int64] = self.train_image_counts[:images].sum(axis=0)
        return counts

    def record(self, root: str) -> dict[str, typing.Any]:
        """As stored with each run (the path only informs: a moved dataset is the same)."""
        return {"sha256": self.sha256, "files": self.files, "path": os.path.abspath(root)}


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _decode(data: bytes, path: str) -> npt.NDArray[typing.Any]:
    image: typing.Optional[npt.NDArray[typing.Any]] = ft.data._cv2().imdecode(
        np.frombuffer(data, np.uint8), ft.data._cv2().IMREAD_UNCHANGED
    )
    if image is None:
        raise Error(f"{path}: cannot read image")
    return image


def _image_size(data: bytes, path: str) -> tuple[int, int]:
    """(height, width) of an image file's bytes: a PNG's header, else decoded."""
    if data[:8] == PNG_SIGNATURE and data[12:16] == b"IHDR":
        width, height = struct.unpack(">II", data[16:24])
        return int(height), int(width)
    shape = _decode(data, path).shape
    return int(shape[0]), int(shape[1])


def scan_dataset(root: str) -> DatasetInfo:
    """Checks every file a run reads — each sample's RGB image, label image and
    calibration in train/, test/ and the true viewpoint test sets — before anything
    runs: present, readable, labels single-channel, of their image's size and in
    0..CLASSES-1 or NO_SOURCE, a folder's images of one size (they are batched), the
    calibration read by fishcam.Camera.read. Names the file at fault (fishcam.Error).

    The dataset's identity: SHA-256 over ``relative path NUL size NUL SHA-256 of the
    contents`` of each of those files, in order (splits, then sample names sorted):
    contents, not times, so a copied or moved dataset is the same one and a
    regenerated or edited one is not; val/, depth/ and the other files, which no run
    reads, are left out."""
    digest = hashlib.sha256()
    files = 0
    cameras: set[bytes] = set()
    train_size, train_images = (0, 0), 0
    train_counts: list[npt.NDArray[np.int64]] = []
    for split, folder in [("train", os.path.join(root, "train"))] + evaluation_folders(root):
        images = os.path.join(folder, "rgb_images")
        if not os.path.isdir(images):
            raise Error(f"{images}: missing (expected the WoodScape layout)")
        found = {os.path.splitext(f)[0]: f for f in os.listdir(images) if f.lower().endswith((".png", ".jpg", ".jpeg"))}
        if not found:
            raise Error(f"{images}: no images")
        size: typing.Optional[tuple[int, int]] = None
        first = ""
        for name in sorted(found):
            rgb = os.path.join(images, found[name])
            label = os.path.join(folder, "semantic_annotations", "gtLabels", name + ".png")
            calibration = os.path.join(folder, "calibration", name + ".json")
            contents = {}
            for path, what in ((rgb, "image"), (label, "label image"), (calibration, "calibration")):
                if not os.path.isfile(path):
                    raise Error(f"{path}: missing (the {what} of {found[name]})")
                with open(path, "rb") as f:
                    contents[path] = f.read()
                data = contents[path]
                digest.update(f"{os.path.relpath(path, root)}\0{len(data)}\0".encode())
                digest.update(hashlib.sha256(data).hexdigest().encode() + b"\n")
                files += 1
            image_size = _image_size(contents[rgb], rgb)
            if size is None:
                size, first = image_size, rgb
            elif image_size != size:
                raise Error(
                    f"{rgb}: {image_size[1]}x{image_size[0]}, but {first} is {size[1]}x{size[0]} (a folder's "
                    "images are batched: one size)"
                )
            mask = _decode(contents[label], label)
            if mask.ndim != 2:
                raise Error(f"{label}: expected a single-channel label image")
            if mask.shape != image_size:
                raise Error(
                    f"{label}: {mask.shape[1]}x{mask.shape[0]}, but its image is {image_size[1]}x{image_size[0]}"
                )
            bad = np.unique(mask[(mask >= CLASSES) & (mask != NO_SOURCE)])
            if bad.size:
                raise Error(
                    f"{label}: label {int(bad[0])} is outside the {CLASSES} classes (0-{CLASSES - 1}; "
                    f"{NO_SOURCE} marks no label)"
                )
            if split == "train":
                train_counts.append(np.bincount(mask[mask < CLASSES].ravel(), minlength=CLASSES)[:CLASSES])
            if contents[calibration] not in cameras:
                try:
                    fishcam.Camera.read(calibration)
                except Error as e:
                    raise Error(str(e) if calibration in str(e) else f"{calibration}: {e}") from None
                cameras.add(contents[calibration])
        if split == "train":
            assert size is not None
            train_size, train_images = size, len(found)
    return DatasetInfo(
        digest.hexdigest(), files, train_size, train_images, np.array(train_counts, np.int64).reshape(-1, CLASSES)
    )


def available_memory(device: torch.device) -> typing.Optional[int]:
    """Bytes free for the training: the GPU's free memory (cuda); MemAvailable, and
    the room left under a cgroup v2 limit (cpu). None when unknown."""
    if device.type == "cuda":
        return int(torch.cuda.mem_get_info(device)[0])
    free: list[int] = []
    try:
        with open("/proc/meminfo") as f:
            free += [int(line.split()[1]) * 1024 for line in f if line.startswith("MemAvailable:")]
    except (OSError, ValueError, IndexError):
        pass
    try:
        with open("/sys/fs/cgroup/memory.max") as f:
            limit = f.read().strip()
        with open("/sys/fs/cgroup/memory.current") as f:
            current = int(f.read())
        if limit != "max":
            free.append(max(int(limit) - current, 0))
    except (OSError, ValueError):
        pass
    return min(free) if free else None


def training_memory(width: int, batch_size: int, image_size: tuple[int, int]) -> int:
    """Bytes one training process needs, about: the parameters with their gradients and
    AdamW's two moments (16 bytes each; counted on the meta device, nothing
    allocated), and the activations autograd keeps, ~40 floats per pixel and channel
    of ``width`` (measured: 27-41 for widths 8-64 at 192x145 and 640x483)."""
    with torch.device("meta"):
        parameters = sum(p.numel() for p in UNet(width).parameters())
    height, image_width = image_size
    pixels = (height + (-height) % 4) * (image_width + (-image_width) % 4)
    return 16 * parameters + 4 * batch_size * pixels * (40 * width + 16)


def parse_device(text: str) -> torch.device:
    """--device: cpu, or cuda (cuda:N) when torch has that CUDA device."""
    try:
        device = torch.device(text)
    except (RuntimeError, ValueError):
        device = None
    if device is None or device.type not in ("cpu", "cuda") or (device.type == "cpu" and device.index not in (None, 0)):
        raise Error(f"--device {text!r}: expected cpu or cuda (cuda:N)")
    if device.type == "cuda":
        if not torch.cuda.is_available():
            raise Error(f"--device {text}: no CUDA device (this torch {torch.__version__} sees none)")
        if device.index is not None and device.index >= torch.cuda.device_count():
            raise Error(f"--device {text}: there are {torch.cuda.device_count()} CUDA devices")
    return device


def parse_list(option: str, text: str, choices: typing.Sequence[str]) -> list[str]:
    """A comma-separated option: at least one name, none empty, none twice, each one of
    ``choices``."""
    names = text.split(",")
    if not text.strip():
        raise Error(f"{option}: empty (expected one or more of {', '.join(choices)}, comma-separated)")
    for k, name in enumerate(names):
        if not name:
            raise Error(f"{option} {text!r}: an empty name (expected names separated by single commas)")
        if name not in choices:
            raise Error(f"{option}: expected one of {', '.join(choices)}, got {name!r}")
        if name in names[:k]:
            raise Error(f"{option} {text!r}: {name} is given twice")
    return names


def check_out(out: str, dataset: str) -> None:
    """OUT: a folder (or none yet), and neither the dataset nor inside it (symlinks
    resolved), where the runs would be written into the data they are scored on."""
    if os.path.lexists(out) and not os.path.isdir(out):
        raise Error(f"{out}: exists and is not a folder (OUT is the output folder)")
    real_out, real_dataset = os.path.realpath(out), os.path.realpath(dataset)
    if os.path.commonpath([real_out, real_dataset]) == real_dataset:
        where = "is the dataset" if real_out == real_dataset else f"is inside the dataset {real_dataset}"
        raise Error(f"{out}: OUT {where}; give an output folder outside it")


def is_flat_layout(root: str) -> bool:
    """A WoodScape-layout folder without splits (rgb_images/ at its top), as the real
    dataset comes."""
    return os.path.isdir(os.path.join(root, "rgb_images")) and not os.path.isdir(os.path.join(root, "train"))


def split_names(root: str, split: typing.Optional[str], seed: typing.Optional[int], test_share: float) -> list[str]:
    """The test images of a flat dataset, by name (no extension): those a split file
    lists (one image per line, as WoodScape's own lists: NAME.png or NAME; blank lines
    and # comments ignored), or a seeded share of the images."""
    images = os.path.join(root, "rgb_images")
    names = sorted(os.path.splitext(f)[0] for f in os.listdir(images) if f.lower().endswith(IMAGE_EXTENSIONS))
    if not names:
        raise Error(f"{images}: no images")
    if split is not None:
        # A regular file of a bounded size: a FIFO or /dev/zero is refused, not read.
        if not os.path.isfile(split):
            raise Error(f"{split}: not a regular file (expected a split file, one test image per line)")
        if os.path.getsize(split) > MAX_SPLIT_FILE_BYTES:
            raise Error(f"{split}: larger than {MAX_SPLIT_FILE_BYTES >> 20} MiB: not a split file")
        try:
            with open(split, encoding="utf-8") as f:
                listed = [line.split("#")[0].strip() for line in f]
        except (OSError, UnicodeDecodeError) as e:
            raise Error(f"{split}: cannot be read as a split file ({type(e).__name__})") from None
        test = [os.path.splitext(os.path.basename(n))[0] for n in listed if n]
        if not test:
            raise Error(f"{split}: names no image (expected one test image per line, e.g. 00001_FV.png)")
        missing = sorted(set(test) - set(names))
        if missing:
            raise Error(f"{split}: names {len(missing)} image(s) not in {images}, e.g. {missing[0]}")
        if len(set(test)) == len(names):
            raise Error(f"{split}: lists every image as a test image; nothing would be left to train on")
        return sorted(set(test))
    if seed is None:
        raise Error(f"{root}: a folder without splits needs --split FILE or --split-seed S")
    if not 0 < test_share < 1:
        raise Error(f"--test-share {test_share}: must be in (0, 1)")
    count = max(1, min(len(names) - 1, round(test_share * len(names))))
    if len(names) < 2:
        raise Error(f"{images}: one image cannot be split into training and test images")
    order = np.random.default_rng(fishcam.derive_seed(seed, "split", 0)).permutation(len(names))
    return sorted(names[i] for i in order[:count])


def prepare_flat_dataset(args: argparse.Namespace) -> str:
    """A flat (real) dataset made into the harness's layout under OUT/dataset: train/
    and test/ of links to the images, labels and calibrations (by the split), and the
    paper's protocol test sets test-PRESET-paper/ made by `fishcam augment-dataset`
    itself (--seed, --label-fill 0: the paper's empty value). Real data has no
    re-rendered truth: no true viewpoint test sets and no fidelity tables. Returns the
    folder."""
    root = os.path.abspath(args.dataset)
    test = set(split_names(root, args.split, args.split_seed, args.test_share))
    binary = args.fishcam or os.environ.get("FISHCAM_BINARY") or shutil.which("fishcam")
    if not binary or not os.access(binary, os.X_OK):
        raise Error("the paper-protocol test sets are made by the fishcam program: give --fishcam PATH")
    out = os.path.join(args.out, "dataset")
    done = os.path.join(out, "prepared")
    # Under torchrun the first process prepares; the others wait for its marker.
    if int(os.environ.get("RANK", "0")) != 0:
        return _wait_for_preparation(out, done)
    _record_split(out, root, test)
    _link_split(root, out, test)
    _make_paper_test_sets(binary, out, args.split_seed or 0)
    with open(done, "w") as f:
        f.write("prepared\n")
    print(
        f"{args.dataset}: {len(test)} test and the other images train; real data has no re-rendered truth, so the "
        "test sets are the paper's protocol only (test-PRESET-paper/, fishcam augment-dataset) and there are no "
        "fidelity tables",
        flush=True,
    )
    return out


def _wait_for_preparation(out: str, done: str) -> str:
    """``out`` once the first process has written its marker ``done``; fishcam.Error
    after an hour without it."""
    for _ in range(3600):
        if os.path.exists(done):
            return out
        time.sleep(1)
    raise Error(f"{done}: the first process did not prepare the dataset within an hour")


def _record_split(out: str, root: str, test: set[str]) -> None:
    """Writes OUT/dataset/split.json (the dataset and its test images), or checks that
    the one there records the same split."""
    # One split per OUT: links of another split would leave images in both halves.
    record = os.path.join(out, "split.json")
    split_record = {"dataset": root, "test": sorted(test)}
    if os.path.exists(record):
        try:
            with open(record, encoding="utf-8") as f:
                stored = json.load(f)
        except (OSError, ValueError):
            raise Error(f"{record}: unreadable (not this harness's split record); use another OUT") from None
        if stored != split_record:
            raise Error(f"{record}: OUT holds another split of another dataset; use another OUT")
    else:
        os.makedirs(out, exist_ok=True)
        with open(record + ".tmp", "w", encoding="utf-8") as f:
            json.dump(split_record, f, indent=1)
        os.replace(record + ".tmp", record)


def _link_split(root: str, out: str, test: set[str]) -> None:
    """Links each image of ``root``, its labels and its calibration into out/test/ or
    out/train/ (``test``: the test images' names); fishcam.Error for a missing file or
    a link to another file already there."""
    files = {
        part: {os.path.splitext(f)[0]: f for f in os.listdir(os.path.join(root, part))}
        for part in ("rgb_images", "semantic_annotations/gtLabels", "calibration")
        if os.path.isdir(os.path.join(root, part))
    }
    for name in sorted(n for n, f in files["rgb_images"].items() if f.lower().endswith(IMAGE_EXTENSIONS)):
        split = "test" if name in test else "train"
        for part, extension in (
            ("rgb_images", None),
            ("semantic_annotations/gtLabels", ".png"),
            ("calibration", ".json"),
        ):
            file = files.get(part, {}).get(name)
            if file is None or (extension is not None and file != name + extension):
                expected = os.path.join(root, part, name + (extension or ".png"))
                raise Error(f"{expected}: missing (the {part} of {name})")
            target = os.path.join(root, part, file)
            link = os.path.join(out, split, part, file)
            os.makedirs(os.path.dirname(link), exist_ok=True)
            try:
                os.symlink(target, link)
            except FileExistsError:  # an earlier run's: the same split only
                if os.path.realpath(link) != os.path.realpath(target):
                    raise Error(
                        f"{link}: exists and is not a link to {target} (another split? use another OUT)"
                    ) from None


def _make_paper_test_sets(binary: str, out: str, seed: int) -> None:
    """out/test-PRESET-paper/ per preset: out/test/ augmented by `fishcam
    augment-dataset` with the paper's settings; fishcam.Error with the program's last
    line when it fails."""
    for preset in TEST_SETS:
        made = subprocess.run(
            [
                binary,
                "augment-dataset",
                os.path.join(out, "test"),
                "--preset",
                preset,
                "--seed",
                str(seed),
                "--label-fill",
                "0",
                "--depth",
                "source-sphere",
                "--out",
                os.path.join(out, f"test-{preset}-paper"),
            ],
            capture_output=True,
            text=True,
        )
        if made.returncode != 0:
            last = made.stderr.strip().splitlines()[-1] if made.stderr.strip() else "failed"
            raise Error(f"fishcam augment-dataset ({preset}): {last}")


def run_settings(args: argparse.Namespace, device: torch.device, processes: int) -> dict[str, typing.Any]:
    """The settings a run's result depends on (SETTINGS), as stored with it."""
    return {
        "scale": args.scale,
        "train_images": args.train_images,
        "epochs": args.epochs,
        "batch_size": args.batch_size,
        "width": args.width,
        "class_weights": args.class_weights,
        "device": device.type,
        "amp": args.amp,
        "channels_last": args.channels_last,
        "processes": processes,
    }


def stored_run(
    path: str,
    settings: dict[str, typing.Any],
    dataset: dict[str, typing.Any],
    rerun: bool,
    defaults: typing.Mapping[str, typing.Any] = SETTING_DEFAULTS,
) -> typing.Optional[dict[str, typing.Any]]:
    """The result stored at ``path`` when it was made from this dataset with these
    settings; None when there is none, or when it differs and ``rerun`` (it is
    recomputed). Refuses one that differs otherwise, naming the dataset or the first
    setting that differs (``defaults``: the value of a setting a run stored before the
    harness recorded it had)."""
    if not os.path.exists(path):
        return None
    hint = "give --rerun to recompute such runs, or another OUT"
    try:
        with open(path) as f:
            result = json.load(f)
        stored_settings, stored_dataset = result.get("settings"), result.get("dataset")
    except (OSError, ValueError, AttributeError) as e:
        if rerun:
            return None
        raise Error(f"{path}: cannot read the stored run ({e}); {hint}") from None
    if not isinstance(stored_settings, dict) or not isinstance(stored_dataset, dict):
        if rerun:
            return None
        raise Error(f"{path}: stored without its settings and dataset (an older harness); {hint}")
    if stored_dataset.get("sha256") != dataset["sha256"]:
        if rerun:
            return None
        raise Error(
            f"{path}: made from another dataset ({stored_dataset.get('path')}: {stored_dataset.get('files')} "
            f"files, sha256 {str(stored_dataset.get('sha256'))[:12]}; now {dataset['path']}: "
            f"{dataset['files']} files, sha256 {dataset['sha256'][:12]}); {hint}"
        )
    for key, option in SETTINGS:
        # Settings added since a run was stored had their default then.
        stored_value = stored_settings.get(key, defaults.get(key))
        if stored_value != settings[key]:
            if rerun:
                return None
            raise Error(f"{path}: made with {option} {stored_value}, now {settings[key]}; {hint}")
    return typing.cast(dict[str, typing.Any], result)


def finite_or_none(value: typing.Any) -> typing.Any:
    """value with every non-finite float (an angle band without pixels, a set without
    compared pixels) as None, through dicts and lists."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite_or_none(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_or_none(v) for v in value]
    return value


def autocast(device: torch.device, amp: bool) -> typing.Any:
    """Mixed precision (--amp): bfloat16 on the CPU, float16 on a GPU; off: a no-op."""
    return torch.autocast(device.type, dtype=torch.bfloat16 if device.type == "cpu" else torch.float16, enabled=amp)


class FirstImages(torch.utils.data.Dataset[typing.Any]):
    """The first ``count`` samples of a WoodScapeDataset (its names sorted: for
    ``sample-dataset`` output, scene by scene), indexed as it is (``(epoch, index)``
    keys pass through, so each sample's seeded change is the one it has in the whole
    dataset)."""

    def __init__(self, dataset: ft.WoodScapeDataset, count: int) -> None:
        self.dataset, self.count = dataset, count

    def __len__(self) -> int:
        return self.count

    def __getitem__(self, key: typing.Union[int, tuple[int, int]]) -> typing.Any:
        index = key[1] if isinstance(key, tuple) else key
        if not 0 <= index < self.count:
            raise IndexError(f"FirstImages: index {index} out of range for {self.count} samples")
        return self.dataset[key]


def training_loader(
    dataset_root: str,
    config: str,
    seed: int,
    batch_size: int,
    workers: int,
    scale: float = 1.0,
    images: typing.Optional[int] = None,
) -> "torch.utils.data.DataLoader[typing.Any]":
    """The DataLoader a run of ``config`` trains from: the first ``images`` of train/
    (None: all) downscaled by ``scale``, under the configuration's transform, seeded
    per sample and epoch, shuffled by ``seed`` (shared among the processes under
    torchrun)."""
    rank, world = distributed()
    whole = ft.WoodScapeDataset(os.path.join(dataset_root, "train"), transform=transform_for(config, scale), seed=seed)
    dataset: typing.Union[ft.WoodScapeDataset, FirstImages] = (
        whole if images is None or images >= len(whole) else FirstImages(whole, images)
    )
    if world > 1:
        inner: typing.Any = torch.utils.data.DistributedSampler(dataset, num_replicas=world, rank=rank, seed=seed)
    else:
        inner = torch.utils.data.RandomSampler(dataset, generator=torch.Generator().manual_seed(seed))
    return torch.utils.data.DataLoader(
        dataset,
        batch_size=batch_size,
        sampler=ft.EpochSampler(inner),
        num_workers=workers,
        persistent_workers=workers > 0,
        worker_init_fn=ft.worker_init_fn,
        collate_fn=ft.collate,
    )


class Training:
    """One run's network, optimiser, loss scaling and schedule; ``step`` trains on one
    batch (what ``train`` repeats, and ``--budget`` times)."""

    def __init__(
        self,
        width: int,
        device: torch.device,
        weights: typing.Optional[torch.Tensor],
        steps: int,
        amp: bool = False,
        channels_last: bool = False,
        name: str = "",
    ) -> None:
        _, world = distributed()
        self.layout = torch.channels_last if channels_last else torch.contiguous_format
        net: torch.nn.Module = UNet(width).to(device).to(memory_format=self.layout)
        # float16 gradients underflow without loss scaling; bfloat16 has float32's range.
        self.scaler = torch.amp.GradScaler(device.type, enabled=amp and device.type == "cuda")
        if world > 1:
            net = torch.nn.parallel.DistributedDataParallel(net)
        self.net = net
        self.optimiser = torch.optim.AdamW(net.parameters(), lr=2e-3, weight_decay=1e-4)
        self.schedule = torch.optim.lr_scheduler.OneCycleLR(self.optimiser, max_lr=2e-3, total_steps=max(steps, 1))
        self.device, self.amp, self.name = device, amp, name
        self.weights = None if weights is None else weights.to(device)
        net.train()

    def step(self, batch: dict[str, typing.Any]) -> None:
        image, mask = batch["image"].to(self.device, memory_format=self.layout), batch["mask"].to(self.device)
        with autocast(self.device, self.amp):
            loss = torch.nn.functional.cross_entropy(self.net(image), mask, weight=self.weights, ignore_index=NO_SOURCE)
        if not torch.isfinite(loss):
            raise Error(f"{self.name}: the loss is not finite")
        self.optimiser.zero_grad()
        self.scaler.scale(loss).backward()  # type: ignore[no-untyped-call]
        self.scaler.step(self.optimiser)
        self.scaler.update()
        self.schedule.step()

    def trained(self) -> torch.nn.Module:
        """The network (without DistributedDataParallel's wrapper)."""
        net = self.net
        return net.module if isinstance(net, torch.nn.parallel.DistributedDataParallel) else net


def train(
    dataset_root: str,
    config: str,
    seed: int,
    epochs: int,
    batch_size: int,
    width: int,
    workers: int,
    device: torch.device,
    weights: typing.Optional[torch.Tensor],
    amp: bool = False,
    channels_last: bool = False,
    scale: float = 1.0,
    images: typing.Optional[int] = None,
) -> torch.nn.Module:
    loader = training_loader(dataset_root, config, seed, batch_size, workers, scale, images)
    torch.manual_seed(seed)
    training = Training(width, device, weights, epochs * len(loader), amp, channels_last, f"{config}, seed {seed}")
    for _ in range(epochs):
        for batch in loader:
            training.step(batch)
    return training.trained()


@torch.no_grad()
def evaluate(
    net: torch.nn.Module, root: str, device: torch.device, batch_size: int, amp: bool = False, scale: float = 1.0
) -> dict[str, typing.Any]:
    """mIoU and per-class IoU over a WoodScape-layout folder (under --amp's precision),
    its images and labels downscaled by ``scale``."""
    dataset = ft.WoodScapeDataset(root, transform=evaluation_transform(scale))
    loader = torch.utils.data.DataLoader(dataset, batch_size=batch_size, collate_fn=ft.collate)
    confusion = fishcam.metrics.ConfusionMatrix(CLASSES, NO_SOURCE)
    net.eval()
    for batch in loader:
        with autocast(device, amp):
            scores = net(batch["image"].to(device))
        prediction = scores.argmax(1).cpu().numpy().astype(np.uint8)
        for p, t in zip(prediction, batch["mask"].numpy()):
            confusion.update(p, t)
    iou = confusion.iou()
    return {"miou": float(confusion.miou()), "iou": [None if math.isnan(x) else float(x) for x in iou]}


def run_path(out: str, config: str, seed: int) -> str:
    """runs/CONFIG-seedS (without extension: .json the result, .pt the weights)."""
    return os.path.join(out, "runs", f"{config.replace(':', '_')}-seed{seed}")


def run_one(
    args: argparse.Namespace,
    config: str,
    seed: int,
    device: torch.device,
    weights: typing.Optional[torch.Tensor],
    record: dict[str, typing.Any],
    stored: typing.Optional[dict[str, typing.Any]],
) -> typing.Optional[dict[str, typing.Any]]:
    """One training run and its evaluation (stored with ``record``: the settings and the
    dataset's identity), or ``stored``, the result of an earlier run that matches."""
    if stored is not None:
        return stored
    rank, _ = distributed()
    path = run_path(args.out, config, seed) + ".json"
    if rank == 0 and os.path.exists(path):  # --rerun: not complete until the new run is written
        os.remove(path)
    start = time.perf_counter()
    net = train(
        args.dataset,
        config,
        seed,
        args.epochs,
        args.batch_size,
        args.width,
        args.workers,
        device,
        weights,
        args.amp,
        args.channels_last,
        args.scale,
        args.train_images,
    )
    if rank != 0:
        return None
    result: dict[str, typing.Any] = {
        "config": config,
        "seed": seed,
        **record,
        "train_seconds": time.perf_counter() - start,
        "test": {},
    }
    for test_set, folder in evaluation_folders(args.dataset):
        result["test"][test_set] = evaluate(net, folder, device, args.batch_size, args.amp, args.scale)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    weights_path = run_path(args.out, config, seed) + ".pt"
    torch.save(net.state_dict(), weights_path + ".tmp")
    os.replace(weights_path + ".tmp", weights_path)
    with open(path + ".tmp", "w") as f:  # last: the run's marker of completion
        json.dump(result, f, indent=1)
    os.replace(path + ".tmp", path)
    return result


def mean_std(values: typing.Sequence[float]) -> str:
    if not values:
        return "–"
    mean = float(np.mean(values)) * 100
    std = float(np.std(values, ddof=1)) * 100 if len(values) > 1 else 0.0
    return f"{mean:.1f} ± {std:.1f}"


# Student's t, the 0.975 quantile by degrees of freedom (1..30; beyond, the normal's).
_T975 = (
    12.706,
    4.303,
    3.182,
    2.776,
    2.571,
    2.447,
    2.365,
    2.306,
    2.262,
    2.228,
    2.201,
    2.179,
    2.160,
    2.145,
    2.131,
    2.120,
    2.110,
    2.101,
    2.093,
    2.086,
    2.080,
    2.074,
    2.069,
    2.064,
    2.060,
    2.056,
    2.052,
    2.048,
    2.045,
    2.042,
)


def paired_difference(
    config: typing.Sequence[float], baseline: typing.Sequence[float]
) -> typing.Optional[tuple[float, float, float]]:
    """The mean of config - baseline over pairs (the same training seed, scored on the
    same test images) and its 95 % interval (Student's t over the pairs); None with
    fewer than 2 pairs."""
    differences = [a - b for a, b in zip(config, baseline)]
    n = len(differences)
    if n < 2:
        return None
    mean = float(np.mean(differences))
    half = (_T975[n - 2] if n - 1 <= len(_T975) else 1.96) * float(np.std(differences, ddof=1)) / math.sqrt(n)
    return mean, mean - half, mean + half


def class_names() -> list[str]:
    return [name for name, _ in fishcam.woodscape_classes()][:CLASSES]


def fidelity_table(rows: typing.Sequence[dict[str, typing.Any]]) -> list[str]:
    """fishcam.dataset_fidelity's rows as markdown."""
    lines = [
        "### Fidelity - the augmentation against the re-rendered truth",
        "",
        "Each test sample augmented by its test set's change under each depth prior (`map`: the sample's own "
        "depth map) against the re-render from the moved camera; labels compared away from class boundaries; "
        "means over the samples.",
        "",
        "| test set | prior | samples | with a source (%) | labels agree (%) | PSNR (dB) |",
        "|---|---|---:|---:|---:|---:|",
    ]
    lines += [
        f"| {r['test_set'][len('test-') :]} | {r['prior']} | {r['samples']} | {100 * r['valid_share']:.1f} | "
        f"{100 * r['label_agreement']:.2f} | {r['psnr_db']:.1f} |"
        for r in rows
    ]
    return lines + [""]


# The models of Table 5 by geometry (fishcam.dataset_model_fidelity): the camera's
# own, then the fitted models the Table 5 configurations train with.
FIDELITY_MODELS = ("own",) + tuple(c[len("viewpoint:") :] for c in CONFIGS if c.startswith("viewpoint:"))


def model_fidelity_table(rows: typing.Sequence[dict[str, typing.Any]]) -> list[str]:
    """fishcam.dataset_model_fidelity's rows as markdown: Table 5 answered by geometry."""

    def px(value: typing.Optional[float]) -> str:
        return "–" if value is None or not math.isfinite(value) else f"{value:.2f}"

    lines = [
        "### Table 5 by geometry - the model used for augmenting, against the re-rendered truth",
        "",
        "Each test sample augmented by its test set's change computed through the model (source-sphere prior) "
        "against the re-render from the truly moved camera; endpoint: the distance (px) of the model's map from "
        "the camera's own, by the output pixel's angle of incidence. No training involved.",
        "",
        "| test set | model | with a source (%) | labels agree (%) | PSNR (dB) | endpoint (px) | 0-30° | 30-60° "
        "| 60-90° | 90°+ |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    lines += [
        f"| {r['test_set'][len('test-') :]} | {r['model']} | {100 * r['valid_share']:.1f} | "
        f"{100 * r['label_agreement']:.2f} | {r['psnr_db']:.1f} | {px(r['endpoint_px'])} | "
        + " | ".join(px(b) for b in r["endpoint_by_angle_px"])
        + " |"
        for r in rows
    ]
    return lines + [""]


def difference_table(
    results: list[dict[str, typing.Any]], configs: typing.Sequence[str], present: typing.Sequence[str]
) -> list[str]:
    """Each configuration's mIoU minus none's, paired by training seed (both scored on
    the same test images), with its 95 % interval; * where the interval excludes 0."""

    def by_seed(config: str, test_set: str) -> dict[int, float]:
        return {
            r["seed"]: r["test"][test_set]["miou"] for r in results if r["config"] == config and test_set in r["test"]
        }

    lines = [
        "### Differences from none (mIoU points, paired by seed; 95 % interval; * excludes 0)",
        "",
        "| configuration | " + " | ".join(present) + " |",
        "|---|" + "---:|" * len(present),
    ]
    for config in configs:
        if config == "none":
            continue
        cells = []
        for test_set in present:
            mine, base = by_seed(config, test_set), by_seed("none", test_set)
            seeds = sorted(set(mine) & set(base))
            d = paired_difference([mine[s] for s in seeds], [base[s] for s in seeds])
            if d is None:
                cells.append("–")
                continue
            mean, low, high = (100 * v for v in d)
            mark = "*" if low > 0 or high < 0 else ""
            cells.append(f"{mean:+.1f} [{low:+.1f}, {high:+.1f}]{mark}")
        lines.append(f"| {config} | " + " | ".join(cells) + " |")
    return lines + [""]


def setup(args: argparse.Namespace) -> str:
    """What the runs trained on and were scored at, as tables.md says it."""
    height, width = scaled_size(args.image_size, args.scale)
    return (
        f"Trained and scored at {width} × {height} (--scale {args.scale:g} of the dataset's {args.image_size[1]} × "
        f"{args.image_size[0]}) on the first {args.train_images} training images; width {args.width}, "
        f"{args.epochs} epochs."
    )


def tables(
    results: list[dict[str, typing.Any]],
    configs: typing.Sequence[str],
    fidelity: typing.Sequence[dict[str, typing.Any]] = (),
    model_fidelity: typing.Sequence[dict[str, typing.Any]] = (),
    setup: str = "",
) -> str:
    """The paper's tables as markdown: ``setup`` (what the runs trained on), mIoU (%)
    per test set, mean ± std over seeds; Table 5 by geometry beside Table 5; then the
    fidelity rows."""
    sets = ["original"] + [s for name in TEST_SETS for s in (name, f"{name}-rotation", f"{name}-paper")]
    present = [s for s in sets if any(s in r["test"] for r in results)]

    def miou(config: str, test_set: str) -> list[float]:
        return [r["test"][test_set]["miou"] for r in results if r["config"] == config and test_set in r["test"]]

    lines = [setup, ""] if setup else []
    lines += [
        "mIoU (%) on the original test split and the true viewpoint test sets (`small` = the re-rendered "
        "test scenes from cameras moved by the preset's changes; `-rotation`: the same changes without "
        "translation; `-paper`: the paper's protocol, the original test images augmented by the same changes "
        "with the unit-sphere prior); mean ± std over training seeds.",
        "",
    ]
    for title, chosen in (
        ("Table 3 - augmentation", ("none", "base", "viewpoint", "base+viewpoint")),
        ("Table 4 - affine baseline vs viewpoint", ("affine", "viewpoint")),
        (
            "Table 5 - the model used for augmenting",
            ("viewpoint",) + tuple(c for c in CONFIGS if c.startswith("viewpoint:")),
        ),
    ):
        rows = [c for c in chosen if c in configs]
        if not rows:
            continue
        lines += [
            f"### {title}",
            "",
            "| configuration | " + " | ".join(present) + " |",
            "|---|" + "---:|" * len(present),
        ]
        lines += [f"| {c} | " + " | ".join(mean_std(miou(c, s)) for s in present) + " |" for c in rows]
        lines.append("")
    if "none" in configs:
        lines += difference_table(results, configs, present)
    if model_fidelity:
        lines += model_fidelity_table(model_fidelity)
    if "none" in configs:
        lines += [
            "### Table 2 - no augmentation: per-class IoU (%) and degradation",
            "",
            "| test set | mIoU | degrades (%) | " + " | ".join(class_names()) + " |",
            "|---|---:|---:|" + "---:|" * CLASSES,
        ]
        base = [r for r in results if r["config"] == "none"]
        original = np.mean([r["test"]["original"]["miou"] for r in base])
        for s in present:
            runs = [r["test"][s] for r in base if s in r["test"]]
            m = float(np.mean([x["miou"] for x in runs]))
            per_class = []
            for k in range(CLASSES):
                values = [x["iou"][k] for x in runs if x["iou"][k] is not None]
                per_class.append(f"{100 * np.mean(values):.1f}" if values else "–")
            degrades = f"{100 * (original - m) / original:.1f}" if original > 0 else "–"  # 0 mIoU: no ratio
            lines.append(f"| {s} | {100 * m:.1f} | {degrades} | " + " | ".join(per_class) + " |")
        lines.append("")
    if fidelity:
        lines += fidelity_table(fidelity)
    return "\n".join(lines)


def colourise(labels: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """Class ids as the WoodScape display colours (no source: black)."""
    palette = np.zeros((256, 3), np.uint8)
    palette[:CLASSES] = [colour for _, colour in fishcam.woodscape_classes()][:CLASSES]
    coloured: npt.NDArray[np.uint8] = palette[labels]
    return coloured


def figures(
    args: argparse.Namespace,
    results: list[dict[str, typing.Any]],
    configs: typing.Sequence[str],
    device: torch.device,
    model_fidelity: typing.Sequence[dict[str, typing.Any]] = (),
) -> list[str]:
    """figures/miou_vs_change.png (mean ± std over seeds against the change size),
    figures/predictions.png (seed 0 of each configuration on test-large samples) and,
    given Table 5 by geometry's rows, figures/model_fidelity.png; returns the files
    written."""
    import matplotlib  # type: ignore[import-untyped]

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # type: ignore[import-untyped]

    folder = os.path.join(args.out, "figures")
    os.makedirs(folder, exist_ok=True)
    written = [
        _miou_vs_change_figure(plt, results, configs, os.path.join(folder, "miou_vs_change.png")),
        _predictions_figure(plt, args, configs, device, os.path.join(folder, "predictions.png")),
    ]
    if model_fidelity:
        written.append(model_fidelity_figure(plt, model_fidelity, os.path.join(folder, "model_fidelity.png")))
    return written


def _miou_vs_change_figure(
    plt: typing.Any, results: list[dict[str, typing.Any]], configs: typing.Sequence[str], path: str
) -> str:
    """mIoU (mean ± std over seeds) against the test set's change size, one line per
    configuration, beside each other: the true test sets, their rotation-only twins
    and the paper's protocol."""
    sizes = ["original"] + list(TEST_SETS)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2), sharey=True)
    for ax, suffix, title in (
        (axes[0], "", "true: rotation + translation"),
        (axes[1], "-rotation", "true: rotation only"),
        (axes[2], "-paper", "the paper's protocol (augmented)"),
    ):
        for config in configs:
            xs: list[int] = []
            means: list[float] = []
            stds: list[float] = []
            for k, size in enumerate(sizes):
                key = size if size == "original" else size + suffix
                values = [r["test"][key]["miou"] * 100 for r in results if r["config"] == config and key in r["test"]]
                if values:
                    xs.append(k)
                    means.append(float(np.mean(values)))
                    stds.append(float(np.std(values, ddof=1)) if len(values) > 1 else 0.0)
            if xs:
                ax.errorbar(xs, means, yerr=stds, marker="o", capsize=3, label=config)
        ax.set_xticks(range(len(sizes)), sizes)
        ax.set_title(f"test sets, {title}")
        ax.set_xlabel("test set (change size)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("mIoU (%), mean ± std over seeds")
    axes[2].legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _predictions_figure(
    plt: typing.Any, args: argparse.Namespace, configs: typing.Sequence[str], device: torch.device, path: str
) -> str:
    """Up to three samples of the test set of the largest changes there is (the
    original test split without one): image, truth and each configuration's
    prediction by its seed-0 network."""
    test_set = next(
        (f"test-{name}" for name in reversed(TEST_SETS) if os.path.isdir(os.path.join(args.dataset, f"test-{name}"))),
        "test",
    )
    dataset = ft.WoodScapeDataset(os.path.join(args.dataset, test_set), transform=evaluation_transform(args.scale))
    picks = sorted({0, len(dataset) // 3, 2 * len(dataset) // 3})
    shown = [c for c in configs if os.path.exists(run_path(args.out, c, 0) + ".pt")]
    fig, axes = plt.subplots(
        len(picks), 2 + len(shown), figsize=(2.2 * (2 + len(shown)), 1.9 * len(picks)), squeeze=False
    )
    nets = {}
    for config in shown:
        net = UNet(args.width)
        net.load_state_dict(torch.load(run_path(args.out, config, 0) + ".pt", map_location="cpu"))
        nets[config] = net.to(device).eval()
    with torch.no_grad():
        for row, index in enumerate(picks):
            sample = dataset[index]
            image = sample["image"]
            panels = [
                ("image", (image.permute(1, 2, 0).numpy() * 255).astype(np.uint8)),
                ("truth", colourise(sample["mask"].numpy().astype(np.uint8))),
            ]
            for config, net in nets.items():
                prediction = net(image[None].to(device)).argmax(1)[0].cpu().numpy().astype(np.uint8)
                panels.append((config, colourise(prediction)))
            for col, (title, picture) in enumerate(panels):
                ax = axes[row][col]
                ax.imshow(picture)
                ax.set_axis_off()
                if row == 0:
                    ax.set_title(title, fontsize=7)
    fig.suptitle(f"{test_set}: predictions of each configuration (training seed 0)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def model_fidelity_figure(plt: typing.Any, rows: typing.Sequence[dict[str, typing.Any]], path: str) -> str:
    """Table 5 by geometry as bars: per test set, each model's endpoint distance from
    the camera's own map (px) and its label agreement with the re-rendered truth."""
    sets = list(dict.fromkeys(r["test_set"] for r in rows))
    models = list(dict.fromkeys(r["model"] for r in rows))
    by = {(r["test_set"], r["model"]): r for r in rows}
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    width = 0.8 / len(models)
    for ax, key, scale, label in (
        (axes[0], "endpoint_px", 1.0, "endpoint vs the camera's own map (px)"),
        (axes[1], "label_agreement", 100.0, "labels agree with the truth (%)"),
    ):
        for m, model in enumerate(models):
            values = [scale * by[s, model][key] if (s, model) in by else float("nan") for s in sets]
            ax.bar([k + (m - (len(models) - 1) / 2) * width for k in range(len(sets))], values, width, label=model)
        ax.set_xticks(range(len(sets)), [s[len("test-") :] for s in sets], rotation=20, fontsize=8)
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    agreements = [r["label_agreement"] for r in rows if math.isfinite(r["label_agreement"])]
    if agreements:
        axes[1].set_ylim(max(0.0, 100 * min(agreements) - 2), 100.5)
    axes[0].legend(fontsize=7)
    fig.suptitle("Table 5 by geometry: the augmentation computed through each model (source-sphere prior)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: typing.Optional[typing.Sequence[str]] = None) -> int:
    """The command line (``python -m fishcam.experiment``, ``fishcam-experiment``): one
    line on stderr and exit status 2 for bad input; 1 for a failing file system or
    too little memory."""
    try:
        # The process's imports count against --budget.
        return run(argv, experiment_budget.seconds_since_process_start())
    except Error as e:
        print(f"fishcam-experiment: error: {e}", file=sys.stderr)
        return 2
    except (OSError, MemoryError, torch.OutOfMemoryError) as e:
        print(f"fishcam-experiment: error: {type(e).__name__}: {e}".splitlines()[0], file=sys.stderr)
        return 1


def run(argv: typing.Optional[typing.Sequence[str]] = None, spent_before: float = 0.0) -> int:
    """The experiment (main's, without its error handling); ``spent_before``: seconds
    the caller spent before it, which count against --budget."""
    started = time.perf_counter() - spent_before
    args = _parser().parse_args(argv)
    configs, device = _checked_options(args)
    args.dataset = _split_dataset(args)
    check_out(args.out, args.dataset)
    if not args.no_figures:
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            raise Error("the figures need matplotlib (pip install matplotlib), or give --no-figures") from None
    info = scan_dataset(args.dataset)
    if args.train_images is not None and args.train_images > info.train_images:
        raise Error(f"--train-images {args.train_images}: {args.dataset}/train has {info.train_images} images")
    if args.train_images is None and args.budget is None:
        args.train_images = info.train_images
    args.image_size = info.image_size
    processes = int(os.environ.get("WORLD_SIZE", "1"))
    args.budget_plan = None if args.budget is None else _budget_plan(args, configs, device, info, started)
    _check_memory(args, info, device, processes)
    settings, dataset_record = run_settings(args, device, processes), info.record(args.dataset)
    record = {"settings": settings, "dataset": dataset_record}
    # Runs stored before the harness recorded --train-images trained on all of train/.
    defaults = {**SETTING_DEFAULTS, "train_images": info.train_images}
    # Every stored run is checked before the first one trains.
    stored = {
        (config, seed): stored_run(
            run_path(args.out, config, seed) + ".json", settings, dataset_record, args.rerun, defaults
        )
        for config in configs
        for seed in range(args.seeds)
    }
    os.environ["FISHCAM_DEVICE"] = device.type
    rank, _ = distributed()
    start = time.perf_counter()
    # The class weights of the images trained on.
    counts = info.train_counts(args.train_images)
    weights = class_weights(counts) if args.class_weights == "balanced" else None
    results = _run_all(args, configs, device, weights, record, stored, rank)
    if rank == 0:
        _write_results(args, configs, device, results, record, weights, start)
    if dist.is_initialized():
        dist.destroy_process_group()
    return 0


def _parser() -> argparse.ArgumentParser:
    """The command line's options (those left None take --quick's or the default
    settings: _checked_options)."""
    parser = argparse.ArgumentParser(prog="fishcam-experiment", description=__doc__.split("\n")[0])
    parser.add_argument(
        "dataset",
        help="a dataset of `fishcam sample-dataset --scenes N` (train/, test/, test-PRESET/), or a WoodScape-layout "
        "folder without splits (rgb_images/, semantic_annotations/gtLabels/, calibration/; with --split or --split-seed)",
    )
    parser.add_argument(
        "out", help="output folder (runs/, results.json, tables.md), outside the dataset; existing runs are kept"
    )
    parser.add_argument(
        "--configs", help=f"comma-separated configurations, each once (default: all of {', '.join(CONFIGS)})"
    )
    parser.add_argument("--seeds", type=int, help="training seeds per configuration (default: 3)")
    parser.add_argument(
        "--train-images",
        type=int,
        metavar="N",
        help="train on the first N images of train/ in the order of their names (sample-dataset's: scene by "
        "scene; default: all)",
    )
    parser.add_argument(
        "--scale",
        help="train and score at the dataset's resolution times this, one of "
        f"{', '.join(f'{s:g}' for s in experiment_budget.SCALES)} (images antialiased, labels nearest-neighbour, "
        "the cameras resized with them; default: 1)",
    )
    parser.add_argument("--epochs", type=int, help="training epochs per run (default: 10)")
    parser.add_argument("--batch-size", type=int, default=8)
    parser.add_argument(
        "--width", type=int, help=f"the U-Net's channels at full resolution, 1-{MAX_WIDTH} (default: 16)"
    )
    parser.add_argument("--workers", type=int, default=0, help="DataLoader workers")
    parser.add_argument("--device", default="cpu", help="cpu or cuda (cuda:N)")
    parser.add_argument(
        "--amp",
        action="store_true",
        help="mixed precision: float16 with loss scaling on a GPU, bfloat16 on the CPU (the GPU recipe, tested there)",
    )
    parser.add_argument("--channels-last", action="store_true", help="the network and its inputs in NHWC memory layout")
    parser.add_argument(
        "--class-weights",
        choices=("balanced", "none"),
        default="balanced",
        help="cross-entropy class weights: balanced (ENet's 1/ln(1.02 + share) from train/) or none",
    )
    parser.add_argument("--no-figures", action="store_true", help="skip figures/ (they need matplotlib)")
    parser.add_argument(
        "--no-fidelity", action="store_true", help="skip the fidelity tables (per depth prior, and Table 5 by geometry)"
    )
    parser.add_argument(
        "--budget",
        type=float,
        metavar="MINUTES",
        help="choose --scale, --train-images, --width and --epochs (those not given) from costs measured on this "
        "machine so that the whole experiment fits MINUTES (docs/experiment.md); not with --quick",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="tiny settings: configs none,viewpoint, 2 seeds, 1 epoch, width 4 (options given explicitly win)",
    )
    parser.add_argument(
        "--split", help="a folder without splits: a file listing its test images, one per line (WoodScape's lists)"
    )
    parser.add_argument("--split-seed", type=int, help="a folder without splits: draw the test images with this seed")
    parser.add_argument(
        "--test-share", type=float, default=0.2, help="--split-seed: the share of the images drawn for test"
    )
    parser.add_argument(
        "--fishcam", help="the fishcam program (a folder without splits; default: FISHCAM_BINARY, then PATH)"
    )
    parser.add_argument(
        "--rerun",
        action="store_true",
        help="recompute the stored runs made with other settings or from another dataset (refused without it)",
    )
    return parser


def _checked_options(args: argparse.Namespace) -> tuple[list[str], torch.device]:
    """(the configurations, the device) of the parsed options, after filling in
    --quick's or the default settings and checking the numbers; fishcam.Error for
    bad input."""
    if args.budget is not None:
        if args.quick:
            raise Error("--budget and --quick: choose one (--quick fixes the settings --budget would choose)")
        if not (math.isfinite(args.budget) and args.budget > 0):
            raise Error(f"--budget {args.budget:g}: expected minutes > 0")
        if int(os.environ.get("WORLD_SIZE", "1")) > 1:
            raise Error("--budget: not under torchrun (each process would measure and choose its own)")
    if args.scale is not None:
        args.scale = parse_scale(args.scale)
    elif args.budget is None:
        args.scale = 1.0
    for key, value in (QUICK if args.quick else DEFAULTS).items():
        if getattr(args, key) is None and not (args.budget is not None and key in BUDGET_CHOOSES):
            setattr(args, key, value)
    configs = parse_list("--configs", args.configs, CONFIGS)  # before anything runs or is written
    for option, value, low in (
        ("--seeds", args.seeds, 1),
        ("--epochs", args.epochs, 1),
        ("--batch-size", args.batch_size, 1),
        ("--width", args.width, 1),
        ("--train-images", args.train_images, 1),
        ("--workers", args.workers, 0),
    ):
        if value is not None and value < low:  # None: --budget chooses it
            raise Error(f"{option} {value}: must be >= {low}")
    if args.width is not None and args.width > MAX_WIDTH:
        raise Error(f"--width {args.width}: at most {MAX_WIDTH} (16 times the default; docs/experiment.md)")
    return configs, parse_device(args.device)


def parse_scale(text: str) -> float:
    """--scale: one of experiment_budget.SCALES (as written, or any spelling of the
    same number)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if value not in experiment_budget.SCALES:
        choices = ", ".join(f"{s:g}" for s in experiment_budget.SCALES)
        raise Error(f"--scale {text}: expected one of {choices}")
    return value


def _split_dataset(args: argparse.Namespace) -> str:
    """The split dataset to train on: args.dataset, or a flat one prepared under
    OUT/dataset; fishcam.Error for split options that do not fit it, or one without
    train/ and test/ images."""
    dataset: str = args.dataset
    if is_flat_layout(dataset):
        check_out(args.out, dataset)  # before OUT/dataset is written
        if (args.split is None) == (args.split_seed is None):
            raise Error(f"{dataset}: a folder without splits needs one of --split FILE and --split-seed S")
        dataset = prepare_flat_dataset(args)
    elif args.split is not None or args.split_seed is not None:
        raise Error(f"{dataset}: already split (train/, test/): --split and --split-seed are for a folder without")
    for sub in ("train", "test"):
        if not os.path.isdir(os.path.join(dataset, sub, "rgb_images")):
            raise Error(f"{dataset}: no {sub}/rgb_images (make it with fishcam sample-dataset --scenes N)")
    return dataset


def _image_count(folder: str) -> int:
    """The images of a WoodScape-layout folder (its rgb_images/)."""
    images = os.path.join(folder, "rgb_images")
    return sum(1 for f in os.listdir(images) if f.lower().endswith(IMAGE_EXTENSIONS))


def _budget_plan(
    args: argparse.Namespace, configs: typing.Sequence[str], device: torch.device, info: DatasetInfo, started: float
) -> experiment_budget.Plan:
    """--budget: the scale, training images, width and epochs (those not given) from
    the costs measured on this dataset (fishcam.experiment_budget), printed and set in
    ``args``."""
    batch = min(args.batch_size, args.train_images or info.train_images)
    free = available_memory(device)
    widths: dict[float, list[int]] = {}
    for scale in [args.scale] if args.scale is not None else experiment_budget.SCALES:
        candidates = [args.width] if args.width is not None else list(experiment_budget.WIDTHS)
        size = scaled_size(info.image_size, scale)
        widths[scale] = [
            w for w in candidates if free is None or training_memory(w, batch, size) <= free
        ] or candidates[:1]

    def loaders(scale: float) -> dict[str, typing.Iterable[typing.Any]]:
        return {
            config: training_loader(args.dataset, config, 0, args.batch_size, args.workers, scale, args.train_images)
            for config in configs
        }

    def reading(scale: float) -> typing.Iterable[typing.Any]:
        return torch.utils.data.DataLoader(
            ft.WoodScapeDataset(os.path.join(args.dataset, "test"), transform=evaluation_transform(scale)),
            batch_size=args.batch_size,
            collate_fn=ft.collate,
        )

    evaluated = sum(_image_count(folder) for _, folder in evaluation_folders(args.dataset))
    work = experiment_budget.Work(args.seeds, info.train_images, args.batch_size, evaluated)
    fixed = experiment_budget.Fixed(args.scale, args.train_images, args.width, args.epochs)
    spent = time.perf_counter() - started

    def choose(costs: experiment_budget.Costs) -> experiment_budget.Plan:
        return experiment_budget.choose(costs, args.budget, work, spent, fixed)

    counts = info.train_counts(args.train_images or info.train_images)
    weights = class_weights(counts) if args.class_weights == "balanced" else None

    def iteration(width: int, loader: typing.Iterable[typing.Any]) -> typing.Callable[[], object]:
        training = Training(width, device, weights, 100, args.amp, args.channels_last, "--budget")
        batches = experiment_budget.endless(loader)
        return lambda: training.step(next(batches))

    def shape(scale: float) -> tuple[int, int, int]:
        return (batch, *scaled_size(info.image_size, scale))

    costs = experiment_budget.measure(loaders, reading, iteration, UNet, shape, device, widths, choose)
    plan = choose(costs)
    args.scale, args.train_images, args.width, args.epochs = plan.scale, plan.train_images, plan.width, plan.epochs
    height, width = scaled_size(info.image_size, plan.scale)
    reduced = f"reduced to fit: {', '.join(plan.reduced)}; " if plan.reduced else ""
    print(
        f"--budget {args.budget:g} min: scale {plan.scale:g} ({width}x{height}), {plan.train_images} of "
        f"{info.train_images} training images, width {plan.width}, {plan.epochs} epochs ({reduced}runs predicted "
        f"{plan.predicted_seconds / 60:.1f} min; measured in {costs.measured_in:.0f} s)",
        flush=True,
    )
    return plan


def _check_memory(args: argparse.Namespace, info: DatasetInfo, device: torch.device, processes: int) -> None:
    """Refuses a --width and --batch-size whose training would not fit the memory free
    on the device (the processes of this machine together, on the CPU)."""
    local = int(os.environ.get("LOCAL_WORLD_SIZE", "1")) if device.type == "cpu" else 1
    batch = min(args.batch_size, -(-args.train_images // processes))
    size = scaled_size(info.image_size, args.scale)
    need, free = local * training_memory(args.width, batch, size), available_memory(device)
    if free is not None and need > free:
        raise Error(
            f"--width {args.width} with --batch-size {args.batch_size} at {size[1]}x{size[0]} needs about {need / 2**30:.1f} GiB to train"
            f"{f' ({local} processes)' if local > 1 else ''}, more than the {free / 2**30:.1f} GiB free on "
            f"{device.type}: lower --width or --batch-size"
        )


def _run_all(
    args: argparse.Namespace,
    configs: typing.Sequence[str],
    device: torch.device,
    weights: typing.Optional[torch.Tensor],
    record: dict[str, typing.Any],
    stored: dict[tuple[str, int], typing.Optional[dict[str, typing.Any]]],
    rank: int,
) -> list[dict[str, typing.Any]]:
    """Every configuration's runs, seed by seed (trained, or as stored); rank 0 prints
    each one's mIoU on the original test split."""
    results = []
    for config in configs:
        for seed in range(args.seeds):
            result = run_one(args, config, seed, device, weights, record, stored[config, seed])
            if result is not None:
                results.append(result)
                if rank == 0:
                    print(
                        f"{config} seed {seed}: mIoU original {100 * result['test']['original']['miou']:.1f}%",
                        flush=True,
                    )
    return results


def _write_results(
    args: argparse.Namespace,
    configs: typing.Sequence[str],
    device: torch.device,
    results: list[dict[str, typing.Any]],
    record: dict[str, typing.Any],
    weights: typing.Optional[torch.Tensor],
    start: float,
) -> None:
    """OUT/results.json, tables.md and figures/ (with the fidelity against the
    re-renders where the dataset has true viewpoint test sets); prints what it wrote."""
    os.makedirs(args.out, exist_ok=True)
    has_test_sets = any(
        os.path.exists(os.path.join(args.dataset, f"test-{name}", "changes.jsonl")) for name in TEST_SETS
    )
    fidelity = fishcam.dataset_fidelity(args.dataset) if has_test_sets and not args.no_fidelity else []
    model_fidelity = (
        fishcam.dataset_model_fidelity(args.dataset, list(FIDELITY_MODELS))
        if has_test_sets and not args.no_fidelity
        else []
    )
    written = [] if args.no_figures else figures(args, results, configs, device, model_fidelity)
    summary = {
        "dataset": os.path.abspath(args.dataset),
        "dataset_identity": record["dataset"],
        "configs": configs,
        "seeds": args.seeds,
        "scale": args.scale,
        "image_size": [*reversed(scaled_size(args.image_size, args.scale))],  # width, height: trained and scored at
        "train_images": args.train_images,
        "epochs": args.epochs,
        "width": args.width,
        "batch_size": args.batch_size,
        "budget": None if args.budget_plan is None else args.budget_plan.record(),
        "settings": record["settings"],
        "class_weights": None if weights is None else [float(w) for w in weights],
        "fishcam": fishcam.__version__,
        "torch": torch.__version__,
        "seconds": time.perf_counter() - start,
        "train_seconds_total": sum(r["train_seconds"] for r in results),
        "runs": results,
        "fidelity": fidelity,
        "model_fidelity": model_fidelity,
    }
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(finite_or_none(summary), f, indent=1)  # NaN is not JSON: null, as the program writes
    with open(os.path.join(args.out, "tables.md"), "w") as f:
        f.write(tables(results, configs, fidelity, model_fidelity, setup(args)))
    print(
        f"wrote {os.path.join(args.out, 'results.json')}, tables.md"
        + "".join(f", {os.path.relpath(w, args.out)}" for w in written)
        + f" ({summary['seconds']:.0f} s)"
    )


if __name__ == "__main__":
    raise SystemExit(main())
