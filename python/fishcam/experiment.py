"""The paper's experiment on fishcam's synthetic surround-view streets (docs/experiment.md).

Trains a small segmentation network (a compact U-Net in plain PyTorch, no downloaded
weights) on the train split of a ``fishcam sample-dataset --scenes N`` dataset under
each augmentation configuration, for several training seeds, and evaluates every
run on the original test split and on the true viewpoint test sets (the test scenes
re-rendered from moved cameras). Writes ``runs/CONFIG-seedS.json`` and the trained
weights ``runs/CONFIG-seedS.pt`` per run (a run already there is not repeated: the
experiment resumes), ``results.json``, ``tables.md`` (the paper's Tables 2-5 as mean
± std over the seeds, and the augmentation's fidelity against the re-renders) and
``figures/`` (mIoU against change size; example predictions; needs matplotlib).

    build/tools/fishcam sample-dataset sv --scenes 48 --size 192x145 --seed 1 --depth
    python -m fishcam.experiment sv results/ [--seeds 3] [--epochs 12] [--quick]

Under ``torchrun --nproc_per_node=N`` each process trains on its share of every
batch (``DistributedSampler`` inside ``fishcam.torch.EpochSampler``, gloo on the CPU,
NCCL with ``--device cuda``); rank 0 evaluates and writes.
"""

import argparse
import json
import math
import os
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

from . import Error

CLASSES = 10
NO_SOURCE = 255
TEST_SETS = ("small", "medium", "large")

# Augmentation configurations: Table 3 (none, base, viewpoint, base + viewpoint),
# Table 4 (affine vs viewpoint), Table 5 (viewpoint computed with a model fitted to
# the camera instead of its own: equidistant, stereographic, Kannala-Brandt; the
# paper's fit, which defines the first two only, and least squares).
CONFIGS = ("none", "base", "viewpoint", "base+viewpoint", "affine",
           "viewpoint:equidistant:paper", "viewpoint:equidistant:lsq",
           "viewpoint:stereographic:paper", "viewpoint:stereographic:lsq",
           "viewpoint:kannala-brandt:lsq")


class UNet(torch.nn.Module):
    """A compact U-Net: three levels, ``width`` channels at the top, doubled per level."""

    def __init__(self, width: int = 16, classes: int = CLASSES) -> None:
        super().__init__()

        def block(a: int, b: int) -> torch.nn.Sequential:
            return torch.nn.Sequential(torch.nn.Conv2d(a, b, 3, padding=1), torch.nn.BatchNorm2d(b), torch.nn.ReLU(),
                                       torch.nn.Conv2d(b, b, 3, padding=1), torch.nn.BatchNorm2d(b), torch.nn.ReLU())

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
        self._fits: typing.Dict[fishcam.Camera, fishcam.Camera] = {}

    def __call__(self, sample: typing.Dict[str, typing.Any]) -> typing.Dict[str, typing.Any]:
        camera = sample["camera"]
        if camera not in self._fits:
            self._fits[camera] = fishcam.convert(camera, self.model, self.method).camera
        return {**sample, "camera": self._fits[camera]}


def transform_for(config: str) -> typing.Optional[typing.Callable[[typing.Any], typing.Any]]:
    """The training transform of a configuration (None: no augmentation)."""
    if config not in CONFIGS:
        raise Error(f"config: expected one of {', '.join(CONFIGS)}, got {config!r}")
    to_float = v2.ToDtype({tv_tensors.Image: torch.float32, "others": None}, scale=True)
    base = [v2.ColorJitter(brightness=0.3, contrast=0.3, saturation=0.3), v2.GaussianBlur(5, sigma=(0.1, 1.5)),
            v2.RandomHorizontalFlip()]
    steps: typing.List[typing.Any] = []
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


def evaluation_transform() -> typing.Callable[[typing.Any], typing.Any]:
    to_float: typing.Callable[[typing.Any], typing.Any] = v2.ToDtype({tv_tensors.Image: torch.float32, "others": None},
                                                                       scale=True)
    return to_float


def distributed() -> typing.Tuple[int, int]:
    """(rank, world size); initialises the process group under torchrun."""
    if "WORLD_SIZE" not in os.environ or int(os.environ["WORLD_SIZE"]) < 2:
        return 0, 1
    if not dist.is_initialized():
        dist.init_process_group("nccl" if torch.cuda.is_available() and os.environ.get("FISHCAM_DEVICE") == "cuda"
                                else "gloo")
    return dist.get_rank(), dist.get_world_size()


def class_weights(root: str) -> torch.Tensor:
    """ENet's class weights 1 / ln(1.02 + p) from the label shares p of a split (the
    un-augmented masks), so that the small classes (persons, riders, signs) are
    learnt beside road and background; absent classes weigh 0."""
    counts = np.zeros(CLASSES, np.int64)
    dataset = ft.WoodScapeDataset(root)
    for i in range(len(dataset)):
        mask = np.asarray(dataset[i]["mask"]).ravel()
        counts += np.bincount(mask[mask < CLASSES], minlength=CLASSES)[:CLASSES]
    share = counts / max(int(counts.sum()), 1)
    weights = np.where(counts > 0, 1.0 / np.log(1.02 + share), 0.0)
    return torch.tensor(weights, dtype=torch.float32)


def train(dataset_root: str, config: str, seed: int, epochs: int, batch_size: int, width: int, workers: int,
          device: torch.device, weights: typing.Optional[torch.Tensor]) -> torch.nn.Module:
    rank, world = distributed()
    dataset = ft.WoodScapeDataset(os.path.join(dataset_root, "train"), transform=transform_for(config), seed=seed)
    if world > 1:
        inner: typing.Any = torch.utils.data.DistributedSampler(dataset, num_replicas=world, rank=rank, seed=seed)
    else:
        inner = torch.utils.data.RandomSampler(dataset, generator=torch.Generator().manual_seed(seed))
    loader = torch.utils.data.DataLoader(dataset, batch_size=batch_size, sampler=ft.EpochSampler(inner),
                                         num_workers=workers, persistent_workers=workers > 0,
                                         worker_init_fn=ft.worker_init_fn, collate_fn=ft.collate)
    torch.manual_seed(seed)
    net: torch.nn.Module = UNet(width).to(device)
    if world > 1:
        net = torch.nn.parallel.DistributedDataParallel(net)
    optimiser = torch.optim.AdamW(net.parameters(), lr=2e-3, weight_decay=1e-4)
    steps = epochs * len(loader)
    schedule = torch.optim.lr_scheduler.OneCycleLR(optimiser, max_lr=2e-3, total_steps=max(steps, 1))
    net.train()
    for _ in range(epochs):
        for batch in loader:
            image, mask = batch["image"].to(device), batch["mask"].to(device)
            loss = torch.nn.functional.cross_entropy(net(image), mask, weight=None if weights is None else weights.to(device),
                                                     ignore_index=NO_SOURCE)
            if not torch.isfinite(loss):
                raise Error(f"{config}, seed {seed}: the loss is not finite")
            optimiser.zero_grad()
            loss.backward()  # type: ignore[no-untyped-call]
            optimiser.step()
            schedule.step()
    return net.module if isinstance(net, torch.nn.parallel.DistributedDataParallel) else net


@torch.no_grad()
def evaluate(net: torch.nn.Module, root: str, device: torch.device, batch_size: int) -> typing.Dict[str, typing.Any]:
    """mIoU and per-class IoU over a WoodScape-layout folder."""
    dataset = ft.WoodScapeDataset(root, transform=evaluation_transform())
    loader = torch.utils.data.DataLoader(dataset, batch_size=batch_size, collate_fn=ft.collate)
    confusion = fishcam.metrics.ConfusionMatrix(CLASSES, NO_SOURCE)
    net.eval()
    for batch in loader:
        prediction = net(batch["image"].to(device)).argmax(1).cpu().numpy().astype(np.uint8)
        for p, t in zip(prediction, batch["mask"].numpy()):
            confusion.update(p, t)
    iou = confusion.iou()
    return {"miou": float(confusion.miou()), "iou": [None if math.isnan(x) else float(x) for x in iou]}


def run_path(out: str, config: str, seed: int) -> str:
    """runs/CONFIG-seedS (without extension: .json the result, .pt the weights)."""
    return os.path.join(out, "runs", f"{config.replace(':', '_')}-seed{seed}")


def run_one(args: argparse.Namespace, config: str, seed: int, device: torch.device,
            weights: typing.Optional[torch.Tensor]) -> typing.Optional[typing.Dict[str, typing.Any]]:
    """One training run and its evaluation, or the stored result of an earlier run."""
    rank, _ = distributed()
    path = run_path(args.out, config, seed) + ".json"
    if os.path.exists(path):
        with open(path) as f:
            return typing.cast(typing.Dict[str, typing.Any], json.load(f))
    start = time.perf_counter()
    net = train(args.dataset, config, seed, args.epochs, args.batch_size, args.width, args.workers, device, weights)
    if rank != 0:
        return None
    result: typing.Dict[str, typing.Any] = {"config": config, "seed": seed, "train_seconds": time.perf_counter() - start,
                                            "test": {"original": evaluate(net, os.path.join(args.dataset, "test"),
                                                                          device, args.batch_size)}}
    for name in TEST_SETS:
        for variant in (f"test-{name}", f"test-{name}-rotation"):
            folder = os.path.join(args.dataset, variant)
            if os.path.isdir(folder):
                result["test"][variant[len("test-"):]] = evaluate(net, folder, device, args.batch_size)
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


def class_names() -> typing.List[str]:
    return [name for name, _ in fishcam.woodscape_classes()][:CLASSES]


def fidelity_table(rows: typing.Sequence[typing.Dict[str, typing.Any]]) -> typing.List[str]:
    """fishcam.dataset_fidelity's rows as markdown."""
    lines = ["### Fidelity - the augmentation against the re-rendered truth", "",
             "Each test sample augmented by its test set's change under each depth prior (`map`: the sample's own "
             "depth map) against the re-render from the moved camera; labels compared away from class boundaries; "
             "means over the samples.", "",
             "| test set | prior | samples | with a source (%) | labels agree (%) | PSNR (dB) |",
             "|---|---|---:|---:|---:|---:|"]
    lines += [f"| {r['test_set'][len('test-'):]} | {r['prior']} | {r['samples']} | {100 * r['valid_share']:.1f} | "
              f"{100 * r['label_agreement']:.2f} | {r['psnr_db']:.1f} |" for r in rows]
    return lines + [""]


def tables(results: typing.List[typing.Dict[str, typing.Any]], configs: typing.Sequence[str],
           fidelity: typing.Sequence[typing.Dict[str, typing.Any]] = ()) -> str:
    """The paper's tables as markdown: mIoU (%) per test set, mean ± std over seeds;
    then the fidelity rows."""
    sets = ["original"] + [s for name in TEST_SETS for s in (name, f"{name}-rotation")]
    present = [s for s in sets if any(s in r["test"] for r in results)]

    def miou(config: str, test_set: str) -> typing.List[float]:
        return [r["test"][test_set]["miou"] for r in results if r["config"] == config and test_set in r["test"]]

    lines = ["mIoU (%) on the original test split and the true viewpoint test sets (`small` = the re-rendered "
             "test scenes from cameras moved by the preset's changes; `-rotation`: the same changes without "
             "translation); mean ± std over training seeds.", ""]
    for title, chosen in (("Table 3 - augmentation", ("none", "base", "viewpoint", "base+viewpoint")),
                          ("Table 4 - affine baseline vs viewpoint", ("affine", "viewpoint")),
                          ("Table 5 - the model used for augmenting",
                           ("viewpoint",) + tuple(c for c in CONFIGS if c.startswith("viewpoint:")))):
        rows = [c for c in chosen if c in configs]
        if not rows:
            continue
        lines += [f"### {title}", "", "| configuration | " + " | ".join(present) + " |",
                  "|---|" + "---:|" * len(present)]
        lines += [f"| {c} | " + " | ".join(mean_std(miou(c, s)) for s in present) + " |" for c in rows]
        lines.append("")
    if "none" in configs:
        lines += ["### Table 2 - no augmentation: per-class IoU (%) and degradation", "",
                  "| test set | mIoU | degrades (%) | " + " | ".join(class_names()) + " |",
                  "|---|---:|---:|" + "---:|" * CLASSES]
        base = [r for r in results if r["config"] == "none"]
        original = np.mean([r["test"]["original"]["miou"] for r in base])
        for s in present:
            runs = [r["test"][s] for r in base if s in r["test"]]
            m = float(np.mean([x["miou"] for x in runs]))
            per_class = []
            for k in range(CLASSES):
                values = [x["iou"][k] for x in runs if x["iou"][k] is not None]
                per_class.append(f"{100 * np.mean(values):.1f}" if values else "–")
            lines.append(f"| {s} | {100 * m:.1f} | {100 * (original - m) / original:.1f} | " + " | ".join(per_class) + " |")
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


def figures(args: argparse.Namespace, results: typing.List[typing.Dict[str, typing.Any]], configs: typing.Sequence[str],
            device: torch.device) -> typing.List[str]:
    """figures/miou_vs_change.png (mean ± std over seeds against the change size) and
    figures/predictions.png (seed 0 of each configuration on test-large samples);
    returns the files written."""
    import matplotlib  # type: ignore[import-untyped]
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # type: ignore[import-untyped]

    folder = os.path.join(args.out, "figures")
    os.makedirs(folder, exist_ok=True)
    written = []
    sizes = ["original"] + list(TEST_SETS)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, suffix, title in ((axes[0], "", "rotation + translation"), (axes[1], "-rotation", "rotation only")):
        for config in configs:
            xs: typing.List[int] = []
            means: typing.List[float] = []
            stds: typing.List[float] = []
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
        ax.set_title(f"true viewpoint test sets: {title}")
        ax.set_xlabel("test set (change size)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("mIoU (%), mean ± std over seeds")
    axes[1].legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    written.append(os.path.join(folder, "miou_vs_change.png"))
    fig.savefig(written[-1], dpi=110)
    plt.close(fig)

    test_set = next((f"test-{name}" for name in reversed(TEST_SETS)
                     if os.path.isdir(os.path.join(args.dataset, f"test-{name}"))), "test")
    dataset = ft.WoodScapeDataset(os.path.join(args.dataset, test_set), transform=evaluation_transform())
    picks = sorted({0, len(dataset) // 3, 2 * len(dataset) // 3})
    shown = [c for c in configs if os.path.exists(run_path(args.out, c, 0) + ".pt")]
    fig, axes = plt.subplots(len(picks), 2 + len(shown), figsize=(2.2 * (2 + len(shown)), 1.9 * len(picks)),
                             squeeze=False)
    nets = {}
    for config in shown:
        net = UNet(args.width)
        net.load_state_dict(torch.load(run_path(args.out, config, 0) + ".pt", map_location="cpu"))
        nets[config] = net.to(device).eval()
    with torch.no_grad():
        for row, index in enumerate(picks):
            sample = dataset[index]
            image = sample["image"]
            panels = [("image", (image.permute(1, 2, 0).numpy() * 255).astype(np.uint8)),
                      ("truth", colourise(sample["mask"].numpy().astype(np.uint8)))]
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
    written.append(os.path.join(folder, "predictions.png"))
    fig.savefig(written[-1], dpi=110)
    plt.close(fig)
    return written


def main(argv: typing.Optional[typing.Sequence[str]] = None) -> int:
    """The command line (``python -m fishcam.experiment``, ``fishcam-experiment``): one
    line on stderr and exit status 2 for bad input."""
    try:
        return run(argv)
    except Error as e:
        print(f"fishcam-experiment: error: {e}", file=sys.stderr)
        return 2


def run(argv: typing.Optional[typing.Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="fishcam-experiment", description=__doc__.split("\n")[0])
    parser.add_argument("dataset", help="a dataset of `fishcam sample-dataset --scenes N` (train/, test/, test-PRESET/)")
    parser.add_argument("out", help="output folder (runs/, results.json, tables.md); existing runs are kept")
    parser.add_argument("--configs", default=",".join(CONFIGS), help="comma-separated configurations")
    parser.add_argument("--seeds", type=int, default=3, help="training seeds per configuration")
    parser.add_argument("--epochs", type=int, default=10)
    parser.add_argument("--batch-size", type=int, default=8)
    parser.add_argument("--width", type=int, default=16, help="the U-Net's channels at full resolution")
    parser.add_argument("--workers", type=int, default=0, help="DataLoader workers")
    parser.add_argument("--device", default="cpu", help="cpu or cuda")
    parser.add_argument("--class-weights", choices=("balanced", "none"), default="balanced",
                        help="cross-entropy class weights: balanced (ENet's 1/ln(1.02 + share) from train/) or none")
    parser.add_argument("--no-figures", action="store_true", help="skip figures/ (they need matplotlib)")
    parser.add_argument("--no-fidelity", action="store_true", help="skip the fidelity table")
    parser.add_argument("--quick", action="store_true", help="tiny settings: 2 configs, 2 seeds, 1 epoch, width 4")
    args = parser.parse_args(argv)
    configs = [c for c in args.configs.split(",") if c]
    for c in configs:
        transform_for(c)  # refuses unknown names before anything runs
    if args.quick:
        configs, args.seeds, args.epochs, args.width = ["none", "viewpoint"], 2, 1, 4
    if args.seeds < 1 or args.epochs < 1 or args.batch_size < 1 or args.width < 1:
        raise Error("--seeds, --epochs, --batch-size and --width must be >= 1")
    for sub in ("train", "test"):
        if not os.path.isdir(os.path.join(args.dataset, sub, "rgb_images")):
            raise Error(f"{args.dataset}: no {sub}/rgb_images (make it with fishcam sample-dataset --scenes N)")
    if args.device == "cuda" and not torch.cuda.is_available():
        raise Error("--device cuda: no CUDA device")
    if not args.no_figures:
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            raise Error("the figures need matplotlib (pip install matplotlib), or give --no-figures") from None
    os.environ["FISHCAM_DEVICE"] = args.device
    device = torch.device(args.device)
    rank, _ = distributed()
    start = time.perf_counter()
    weights = class_weights(os.path.join(args.dataset, "train")) if args.class_weights == "balanced" else None
    results = []
    for config in configs:
        for seed in range(args.seeds):
            result = run_one(args, config, seed, device, weights)
            if result is not None:
                results.append(result)
                if rank == 0:
                    print(f"{config} seed {seed}: mIoU original {100 * result['test']['original']['miou']:.1f}%",
                          flush=True)
    if rank == 0:
        os.makedirs(args.out, exist_ok=True)
        has_test_sets = any(os.path.exists(os.path.join(args.dataset, f"test-{name}", "changes.jsonl"))
                            for name in TEST_SETS)
        fidelity = fishcam.dataset_fidelity(args.dataset) if has_test_sets and not args.no_fidelity else []
        written = [] if args.no_figures else figures(args, results, configs, device)
        summary = {"dataset": os.path.abspath(args.dataset), "configs": configs, "seeds": args.seeds,
                   "epochs": args.epochs, "width": args.width, "batch_size": args.batch_size,
                   "class_weights": None if weights is None else [float(w) for w in weights],
                   "fishcam": fishcam.__version__, "torch": torch.__version__, "seconds": time.perf_counter() - start,
                   "train_seconds_total": sum(r["train_seconds"] for r in results),
                   "runs": results, "fidelity": fidelity}
        with open(os.path.join(args.out, "results.json"), "w") as f:
            json.dump(summary, f, indent=1)
        with open(os.path.join(args.out, "tables.md"), "w") as f:
            f.write(tables(results, configs, fidelity))
        print(f"wrote {os.path.join(args.out, 'results.json')}, tables.md" + "".join(f", {os.path.relpath(w, args.out)}"
                                                                                    for w in written) +
              f" ({summary['seconds']:.0f} s)")
    if dist.is_initialized():
        dist.destroy_process_group()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
