#!/usr/bin/env python3
"""The Python package's costs, measured in one run (docs/performance.md):

1. per-sample augmentation (1280x966 RGB bilinear + labels nearest, a new `train`
   pose each) through fishcam.ViewpointWarp.warp against the C++ `fishcam bench
   augment` total, interleaved in rounds (a Python block, then a C++ block), 1 and
   2 threads; target <= 1.05x;
2. a DataLoader over WoodScape-sized samples (PNG files from `fishcam
   sample-dataset`, 640x483 and 1280x966) with 0 and 2 persistent workers, with
   RandomViewpoint against without, per sample in steady state (target <= 1.10x),
   and the first epoch (warps built) apart;
3. the augmentation's share of a CPU training step of a small segmentation network;
4. fishcam beside albumentations' and kornia's fisheye augmentations and kornia's
   batched remap, per sample, in one process;
5. the v2 path (`--only v2-path`): per sample, one thread, fishcam.torch.RandomViewpoint
   on an HWC-backed and on a contiguous CHW tv_tensors.Image against the numpy
   transform on the HWC array, interleaved in one process, 640x483 and 1280x966
   (target <= 1.10x).

Usage: PYTHONPATH=build/python build/venv/bin/python tools/bench_python.py [--fishcam build/tools/fishcam]
       [--only per-sample|dataloader|training|peers|v2-path] [--json]   (build/venv: scripts/python-env.sh)
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np


def median_ms(fn, samples):
    times = []
    for i in range(samples):
        start = time.perf_counter()
        fn(i)
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def per_sample(fishcam, binary, data, samples, rounds):
    import cv2

    with tempfile.TemporaryDirectory() as tmp:
        # The same sample as `fishcam bench augment`: the scene at the camera's pose.
        subprocess.run(
            [binary, "render", data, "--out-image", f"{tmp}/i.png", "--out-label", f"{tmp}/l.png"],
            check=True,
            capture_output=True,
        )
        image = cv2.imread(f"{tmp}/i.png", cv2.IMREAD_UNCHANGED)
        labels = cv2.imread(f"{tmp}/l.png", cv2.IMREAD_UNCHANGED)
    camera = fishcam.Camera.read(data)
    warp = fishcam.ViewpointWarp(camera)
    rows = []
    for threads in (1, 2):
        python_ms, cpp_ms = [], []
        for r in range(rounds):
            fishcam.set_num_threads(threads)
            python_ms.append(
                median_ms(
                    lambda i, r=r: warp.warp(
                        image=image, labels=labels, change=fishcam.random_change("train", 1000 * r + i)
                    ),
                    samples,
                )
            )
            out = json.loads(
                subprocess.run(
                    [binary, "bench", "augment", data, "--json", "--samples", str(samples)],
                    check=True,
                    capture_output=True,
                    text=True,
                ).stdout
            )
            cpp_ms.append(next(x["total_ms"] for x in out["results"] if x["threads"] == threads))
        p, c = statistics.median(python_ms), statistics.median(cpp_ms)
        rows.append({"threads": threads, "python_ms": p, "cpp_ms": c, "python_over_cpp": p / c})
    return rows


def loader_cost(fishcam, binary, samples, epochs, photo=None):
    """Per sample in steady state, a DataLoader over WoodScape-layout PNG samples
    with RandomViewpoint against the same loader without it: both persistent,
    seeded, EpochSampler, fishcam.torch.collate; their epochs interleaved (A, B, A,
    B, ...) so that both see the same machine; the first epoch (warps built: every
    sample of `fishcam sample-dataset` has its own calibration) reported apart.
    With `photo`, every RGB image is that photo (resized, as PNG): real content
    decodes slower than the rendered scenes' flat colours."""
    import fishcam.torch as ft
    import torch

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for width, height in ((640, 483), (1280, 966)):
            root = f"{tmp}/ws{width}"
            _make_loader_dataset(binary, root, samples, width, height, photo)
            for workers in (0, 2):
                loaders = _plain_and_augmented_loaders(ft, torch, root, workers)
                fishcam.set_num_threads(2 if workers == 0 else 1)
                first, per_sample = _interleaved_epoch_seconds(loaders, epochs)
                plain, augmented = statistics.median(per_sample[False]), statistics.median(per_sample[True])
                rows.append(
                    {
                        "size": f"{width}x{height}",
                        "images": "photo" if photo else "rendered",
                        "workers": workers,
                        "plain_ms": 1e3 * plain,
                        "augmented_ms": 1e3 * augmented,
                        "ratio": augmented / plain,
                        "first_epoch_plain_ms": 1e3 * first[False],
                        "first_epoch_augmented_ms": 1e3 * first[True],
                    }
                )
                del loaders
    return rows


def _make_loader_dataset(binary, root, samples, width, height, photo):
    """`fishcam sample-dataset` of ``samples`` images at width x height in ``root``;
    with ``photo``, its RGB images replaced by that photo resized."""
    subprocess.run(
        [
            binary,
            "sample-dataset",
            root,
            "--images",
            str(samples),
            "--seed",
            "1",
            "--size",
            f"{width}x{height}",
        ],
        check=True,
        capture_output=True,
    )
    if photo:
        import cv2

        picture = cv2.imread(photo, cv2.IMREAD_COLOR)
        if picture is None:
            raise SystemExit(f"{photo}: cannot read image")
        picture = cv2.resize(picture, (width, height), interpolation=cv2.INTER_AREA)
        for name in os.listdir(f"{root}/rgb_images"):
            cv2.imwrite(f"{root}/rgb_images/{name}", picture)


def _plain_and_augmented_loaders(ft, torch, root, workers):
    """{False: the loader without RandomViewpoint, True: with it} over ``root``,
    persistent when they have workers, seeded, EpochSampler, fishcam.torch.collate
    (``ft``, ``torch``: the modules, imported by the caller)."""
    loaders = {}
    for augment in (False, True):
        ds = ft.WoodScapeDataset(root, transform=ft.RandomViewpoint(preset="train") if augment else None, seed=1)
        loaders[augment] = torch.utils.data.DataLoader(
            ds,
            batch_size=4,
            num_workers=workers,
            persistent_workers=workers > 0,
            sampler=ft.EpochSampler(torch.utils.data.SequentialSampler(ds)),
            worker_init_fn=ft.worker_init_fn if workers else None,
            collate_fn=ft.collate,
        )
    return loaders


def _interleaved_epoch_seconds(loaders, epochs):
    """(the first epoch's seconds per sample, {augment: [seconds per sample of each
    later epoch]}) of the loaders' epochs, A, B, A, B, ... so that both see the same
    machine; the first (warps built) apart."""
    per_sample = {False: [], True: []}
    first = {}
    for epoch in range(epochs + 1):
        for augment in (False, True):
            start = time.perf_counter()
            n = sum(len(batch["name"]) for batch in loaders[augment])
            seconds = (time.perf_counter() - start) / n
            if epoch == 0:
                first[augment] = seconds
            else:
                per_sample[augment].append(seconds)
    return first, per_sample


def peers(fishcam, data, samples, rounds, batch=8):
    """Per-sample time of fishcam beside the augmentations users would otherwise pick,
    on the same 1280x966 RGB image (+ labels where the peer takes them), in one
    process, interleaved in rounds, each library on 1 thread and then 2:
    fishcam.transforms.RandomViewpoint (image + mask), albumentations'
    OpticalDistortion(mode="fisheye") (image + mask), kornia's RandomFisheye (float
    image tensor), and the batched paths: fishcam.torch.warp_batch and kornia's
    remap (grid_sample) with the same maps precomputed, per sample of a batch."""
    import albumentations
    import cv2
    import fishcam.torch as ft
    import kornia
    import torch
    from fishcam.transforms import RandomViewpoint

    camera = fishcam.Camera.read(data)
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (camera.height, camera.width, 3), dtype=np.uint8)
    image = cv2.GaussianBlur(image, (0, 0), 3)  # some structure, as a photo has
    labels = rng.integers(0, 10, (camera.height, camera.width), dtype=np.uint8)
    ours = RandomViewpoint(camera, preset="train")
    optical = albumentations.OpticalDistortion(distort_limit=0.5, mode="fisheye", p=1.0)
    optical.set_random_seed(0)
    fisheye = kornia.augmentation.RandomFisheye(
        torch.tensor([-0.3, 0.3]), torch.tensor([-0.3, 0.3]), torch.tensor([0.9, 1.0]), p=1.0
    )
    tensor = torch.from_numpy(image).permute(2, 0, 1)[None].float() / 255
    images = torch.from_numpy(np.stack([image] * batch)).permute(0, 3, 1, 2).contiguous()
    changes = [fishcam.random_change("train", i) for i in range(batch)]
    map_x, map_y, _ = ft._batch_warps.get(camera).maps(changes[0], grid=True)
    kornia_x = torch.from_numpy(np.nan_to_num(map_x, nan=-1.0))[None].expand(batch, -1, -1)
    kornia_y = torch.from_numpy(np.nan_to_num(map_y, nan=-1.0))[None].expand(batch, -1, -1)
    float_images = images.float()
    cases = {
        "fishcam RandomViewpoint": lambda i: ours(image=image, mask=labels, seed=i),
        "albumentations OpticalDistortion fisheye": lambda i: optical(image=image, mask=labels),
        "kornia RandomFisheye": lambda i: fisheye(tensor),
        "fishcam warp_batch (per sample of %d)" % batch: lambda i: ft.warp_batch(images, camera, changes),
        "kornia remap, same maps (per sample of %d)" % batch: lambda i: kornia.geometry.transform.remap(
            float_images, kornia_x, kornia_y, align_corners=True
        ),
    }
    per_batch = {name for name in cases if "per sample of" in name}
    rows = []
    for threads in (1, 2):
        fishcam.set_num_threads(threads)
        torch.set_num_threads(threads)
        cv2.setNumThreads(threads)
        times = {name: [] for name in cases}
        for r in range(rounds):
            for name, run in cases.items():
                n = max(samples // batch, 3) if name in per_batch else samples
                ms = median_ms(lambda i, run=run, r=r: run(1000 * r + i), n)
                times[name].append(ms / batch if name in per_batch else ms)
        base = statistics.median(times["fishcam RandomViewpoint"])
        for name in cases:
            t = statistics.median(times[name])
            rows.append({"threads": threads, "case": name, "ms": t, "over_fishcam": t / base})
    return rows


def v2_path(fishcam, data, samples, rounds):
    """Per-sample ms of the numpy transform (HWC array) and of fishcam.torch.RandomViewpoint
    on the same pixels as an HWC-backed and as a contiguous CHW image, same seeds,
    interleaved sample by sample; one thread each; every case returns the image and
    the augmented camera."""
    import torch

    fishcam.set_num_threads(1)
    torch.set_num_threads(1)
    return [_v2_path_at(fishcam, data, width, height, samples, rounds) for width, height in [(640, 483), (1280, 966)]]


def _v2_path_at(fishcam, data, width, height, samples, rounds):
    import fishcam.torch as ft
    import torch
    from torchvision import tv_tensors

    camera = fishcam.Camera.read(data).resized(width, height)
    hwc = np.random.default_rng(0).integers(0, 256, (height, width, 3), dtype=np.uint8)
    numpy_transform = fishcam.transforms.RandomViewpoint(camera, preset="train")
    torch_transform = ft.RandomViewpoint(preset="train")
    backed = tv_tensors.Image(torch.from_numpy(hwc).permute(2, 0, 1))
    planar = tv_tensors.Image(backed.contiguous())
    cases = {
        "numpy": lambda seed: numpy_transform(hwc, camera=camera, seed=seed),
        "hwc_backed": lambda seed: torch_transform(backed, camera),
        "chw": lambda seed: torch_transform(planar, camera),
    }
    times = {name: [] for name in cases}
    for seed in range(rounds * samples + 3):
        for name, run in cases.items():
            with ft.sample_seed(seed):
                start = time.perf_counter()
                run(seed)
                if seed >= 3:  # after the warm-up (warps built)
                    times[name].append(time.perf_counter() - start)
    ms = {name: 1e3 * statistics.median(t) for name, t in times.items()}
    return {
        "size": f"{width}x{height}",
        **{f"{k}_ms": v for k, v in ms.items()},
        "hwc_backed_over_numpy": ms["hwc_backed"] / ms["numpy"],
        "chw_over_numpy": ms["chw"] / ms["numpy"],
    }


def training_share(fishcam, data, steps):
    """A small encoder-decoder (about 0.1 M parameters) on 640x483 batches of 4."""
    import fishcam.transforms
    import torch

    torch.manual_seed(0)
    camera = fishcam.Camera.read(data).resized(640, 483)
    net = torch.nn.Sequential(
        torch.nn.Conv2d(3, 32, 3, stride=2, padding=1),
        torch.nn.ReLU(),
        torch.nn.Conv2d(32, 64, 3, stride=2, padding=1),
        torch.nn.ReLU(),
        torch.nn.Conv2d(64, 64, 3, padding=1),
        torch.nn.ReLU(),
        torch.nn.ConvTranspose2d(64, 32, 4, stride=2, padding=1),
        torch.nn.ReLU(),
        torch.nn.ConvTranspose2d(32, 10, 4, stride=2, padding=1),
    )
    optimiser = torch.optim.SGD(net.parameters(), lr=1e-3)
    transform = fishcam.transforms.RandomViewpoint(camera, preset="train")
    rng = np.random.default_rng(0)
    images = [rng.integers(0, 256, (483, 640, 3), dtype=np.uint8) for _ in range(4)]
    masks = [rng.integers(0, 10, (483, 640), dtype=np.uint8) for _ in range(4)]
    fishcam.set_num_threads(torch.get_num_threads())
    augment_s, step_s = [], []
    for step in range(steps):
        start = time.perf_counter()
        batch = [
            transform(image=image, mask=mask, seed=4 * step + k) for k, (image, mask) in enumerate(zip(images, masks))
        ]
        middle = time.perf_counter()
        x = torch.stack([torch.from_numpy(b["image"]).permute(2, 0, 1) for b in batch]).float() / 255
        y = torch.stack([torch.from_numpy(b["mask"].astype(np.int64)) for b in batch])
        out = net(x)[:, :, :483, :640]
        loss = torch.nn.functional.cross_entropy(out, y)
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        end = time.perf_counter()
        augment_s.append(middle - start)
        step_s.append(end - middle)
    a, s = statistics.median(augment_s), statistics.median(step_s)
    return {
        "batch": 4,
        "size": "640x483",
        "torch_threads": torch.get_num_threads(),
        "augment_ms": 1e3 * a,
        "train_step_ms": 1e3 * s,
        "augment_share": a / (a + s),
    }


def print_results(result, args):
    """The results as text."""
    if "v2_path" in result:
        print("the v2 path, per sample, 1 thread (median; ratios to the numpy transform in the same run)")
        for r in result["v2_path"]:
            print(
                "  %s: numpy %.2f ms, v2 HWC-backed %.2f ms (%.2fx), v2 contiguous CHW %.2f ms (%.2fx)"
                % (
                    r["size"],
                    r["numpy_ms"],
                    r["hwc_backed_ms"],
                    r["hwc_backed_over_numpy"],
                    r["chw_ms"],
                    r["chw_over_numpy"],
                )
            )
    if "per_sample" in result:
        print(
            "per-sample augmentation 1280x966 (median of %d, median over %d interleaved rounds)"
            % (args.samples, args.rounds)
        )
        for r in result["per_sample"]:
            print(
                "  %d thread(s): python %.2f ms, C++ bench %.2f ms, ratio %.3f"
                % (r["threads"], r["python_ms"], r["cpp_ms"], r["python_over_cpp"])
            )
    if "dataloader" in result:
        print("DataLoader, WoodScape-layout PNG samples, batch 4, per sample in steady state (epochs interleaved):")
        for r in result["dataloader"]:
            print(
                "  %-9s %-8s %d workers: plain %6.2f ms, RandomViewpoint %6.2f ms, ratio %.3f; first epoch %.1f / %.1f ms"
                % (
                    r["size"],
                    r["images"],
                    r["workers"],
                    r["plain_ms"],
                    r["augmented_ms"],
                    r["ratio"],
                    r["first_epoch_plain_ms"],
                    r["first_epoch_augmented_ms"],
                )
            )
    if "peers" in result:
        print("Beside the peers, 1280x966 RGB (median per sample; ratio to fishcam's per-sample transform):")
        for r in result["peers"]:
            print("  %d thread(s) %-44s %8.2f ms  %5.2fx" % (r["threads"], r["case"], r["ms"], r["over_fishcam"]))
    if "training" in result:
        t = result["training"]
        print(
            "CPU training step, batch 4 at 640x483 (%d torch threads): augmentation %.1f ms, step %.1f ms, "
            "share %.1f %%" % (t["torch_threads"], t["augment_ms"], t["train_step_ms"], 100 * t["augment_share"])
        )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    here = os.path.dirname(os.path.abspath(__file__))
    parser.add_argument("--fishcam", default=os.path.join(here, "..", "build", "tools", "fishcam"))
    parser.add_argument("--camera", default=os.path.join(here, "..", "data", "woodscape_front.json"))
    parser.add_argument("--samples", type=int, default=41)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--loader-samples", type=int, default=16)
    shared_photo = os.path.join(here, "..", "..", "shared", "data", "woodscape", "front.jpg")
    parser.add_argument(
        "--photo",
        default=shared_photo if os.path.exists(shared_photo) else None,
        help="a real photo for the loader's RGB images (default: ../shared's WoodScape image when "
        "present; 'none' for the rendered scenes)",
    )
    parser.add_argument("--epochs", type=int, default=4, help="steady-state epochs per loader (after the first)")
    parser.add_argument(
        "--only", choices=["per-sample", "dataloader", "training", "peers", "v2-path"], help="run one part"
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.photo == "none":
        args.photo = None
    import fishcam

    parts = {
        "per_sample": lambda: per_sample(fishcam, args.fishcam, args.camera, args.samples, args.rounds),
        "dataloader": lambda: loader_cost(fishcam, args.fishcam, args.loader_samples, args.epochs, args.photo),
        "training": lambda: training_share(fishcam, args.camera, 12),
        "peers": lambda: peers(fishcam, args.camera, args.samples, args.rounds),
        "v2_path": lambda: v2_path(fishcam, args.camera, args.samples, args.rounds),
    }
    result = {name: run() for name, run in parts.items() if args.only in (None, name.replace("_", "-"))}
    if args.json:
        print(json.dumps(result, indent=2))
        return
    print_results(result, args)


if __name__ == "__main__":
    sys.exit(main())
