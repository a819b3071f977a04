#!/usr/bin/python3
"""Augmentation speed against the reference implementations, as ratios in one run.

    /usr/bin/python3 tools/bench_reference.py [--fishcam build/tools/fishcam] [--python-dir build/python]
                                              [--samples N]

- fishcam: `fishcam bench augment --json` (1 and 2 threads), on the bundled
  stereographic camera (which mrcal can represent) and the WoodScape front camera.
- mrcal's Python path: mrcal.image_transformation_map(distance=1) +
  mrcal.transform_image for the RGB image and the labels, stereographic camera.
- WoodScape's per-pixel method: numpy.roots of the 4th-order polynomial for each
  pixel (what the WoodScape tooling and the paper's look-up table are built from),
  timed on a random subsample of pixels and extrapolated to the whole image; the
  rest of that pipeline (rotate, project, remap) is not even counted.
- PyTorch (CPU, same thread counts), WoodScape camera: torch's grid_sample with a
  grid computed beforehand (what a PyTorch/kornia user does with a fixed map; the
  image already float), and the kornia-style per-sample grid: the change applied to
  cached rays and the WoodScape polynomial projected in torch ops, then grid_sample.
- OpenCV's fisheye model: cv2.fisheye.initUndistortRectifyMap (the Kannala-Brandt fit
  of the WoodScape camera, the change as R, a pinhole output) + cv2.remap, per sample.
Run with Debian's /usr/bin/python3 (python3-mrcal, python3-numpy, python3-opencv).
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import cv2
import mrcal
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(os.path.dirname(HERE), "data")


def fishcam_bench(fishcam, camera, samples):
    out = subprocess.run(
        [fishcam, "bench", "augment", camera, "--json", "--samples", str(samples)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    return {r["threads"]: r for r in json.loads(out)["results"]}


def median_ms(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * sorted(times)[len(times) // 2]


def mrcal_path_ms(fishcam, repeats):
    source = os.path.join(DATA, "stereographic.cameramodel")
    with tempfile.TemporaryDirectory() as tmp:
        image, labels = os.path.join(tmp, "image.png"), os.path.join(tmp, "labels.png")
        subprocess.run(
            [fishcam, "render", source, "--out-image", image, "--out-label", labels], check=True, capture_output=True
        )
        rgb, lab = cv2.imread(image), cv2.imread(labels, cv2.IMREAD_UNCHANGED)
    model = mrcal.cameramodel(source)
    target = mrcal.cameramodel(model)
    rng = np.random.default_rng(1)

    def one_sample():
        r = np.radians(rng.uniform(-30, 30, 3))
        t = rng.uniform(-0.5, 0.5, 3)
        target.extrinsics_rt_fromref(np.concatenate([r, t]))
        mapxy = mrcal.image_transformation_map(model, target, distance=1.0)
        mrcal.transform_image(rgb, mapxy)
        mrcal.transform_image(lab, mapxy, interpolation=cv2.INTER_NEAREST)

    model.extrinsics_rt_fromref(np.zeros(6))
    return median_ms(one_sample, repeats)


def np_roots_ms(subsample):
    calibration = json.load(open(os.path.join(DATA, "woodscape_front.json")))["intrinsic"]
    k = [calibration[f"k{i}"] for i in range(1, 5)]
    w, h = int(calibration["width"]), int(calibration["height"])
    cx, cy = w / 2 + calibration["cx_offset"] - 0.5, h / 2 + calibration["cy_offset"] - 0.5
    rng = np.random.default_rng(2)
    u, v = rng.uniform(0, w, subsample), rng.uniform(0, h, subsample)
    rho = np.hypot(u - cx, v - cy)
    t0 = time.perf_counter()
    for r in rho:
        roots = np.roots([k[3], k[2], k[1], k[0], -r])
        real = roots[np.abs(roots.imag) < 1e-6].real
        real = real[real > 0]
        _ = real.min() if real.size else 0.0
    per_pixel = (time.perf_counter() - t0) / subsample
    return 1e3 * per_pixel * w * h


def woodscape_scene(fishcam, tmp):
    source = os.path.join(DATA, "woodscape_front.json")
    image, labels = os.path.join(tmp, "ws.png"), os.path.join(tmp, "ws_labels.png")
    subprocess.run(
        [fishcam, "render", source, "--out-image", image, "--out-label", labels], check=True, capture_output=True
    )
    return cv2.imread(image), cv2.imread(labels, cv2.IMREAD_UNCHANGED)


def torch_paths_ms(fishcam, repeats, threads):
    """grid_sample with a precomputed grid, and the per-sample torch grid (kornia style)."""
    import fishcam as fc
    import torch
    import torch.nn.functional as F

    torch.set_num_threads(threads)
    cam = fc.Camera.read(os.path.join(DATA, "woodscape_front.json"))
    w, h = cam.width, cam.height
    with tempfile.TemporaryDirectory() as tmp:
        rgb, lab = woodscape_scene(fishcam, tmp)
    image = torch.from_numpy(rgb).permute(2, 0, 1)[None].float()
    labels = torch.from_numpy(lab)[None, None].float()
    map_x, map_y, _ = fc.ViewpointWarp(cam).maps(fc.random_change("train", 1))
    grid = torch.from_numpy(np.stack([map_x / (w - 1) * 2 - 1, map_y / (h - 1) * 2 - 1], -1))[None].float()

    def precomputed():
        F.grid_sample(image, grid, mode="bilinear", align_corners=True)
        F.grid_sample(labels, grid, mode="nearest", align_corners=True)

    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    rays, _ = cam.unproject(np.stack([u.ravel(), v.ravel()], -1))
    rays = torch.from_numpy(rays).float()
    k = torch.tensor(cam.parameters, dtype=torch.float32)
    (cx, cy), (ax, ay) = cam.principal_point, cam.pixel_scale
    rng = np.random.default_rng(3)

    def per_sample():
        change = fc.random_change("train", int(rng.integers(1 << 62)))
        r = torch.from_numpy(change.rotation).float()
        t = torch.from_numpy(np.array(change.translation)).float()
        b = rays @ t
        s = b + torch.sqrt(b * b - (t @ t - 1))  # the source-sphere prior
        q = (s[:, None] * rays - t) @ r  # R^T q for row vectors
        x, y, z = q.unbind(-1)
        rxy = torch.sqrt(x * x + y * y).clamp_min(1e-12)
        theta = torch.atan2(rxy, z)
        rho = theta * (k[0] + theta * (k[1] + theta * (k[2] + theta * k[3])))
        gx = (cx + ax * rho * x / rxy) / (w - 1) * 2 - 1
        gy = (cy + ay * rho * y / rxy) / (h - 1) * 2 - 1
        g = torch.stack([gx, gy], -1).reshape(1, h, w, 2)
        F.grid_sample(image, g, mode="bilinear", align_corners=True)
        F.grid_sample(labels, g, mode="nearest", align_corners=True)

    return median_ms(precomputed, repeats), median_ms(per_sample, repeats)


def opencv_fisheye_ms(fishcam, repeats):
    import fishcam as fc

    cam = fc.Camera.read(os.path.join(DATA, "woodscape_front.json"))
    kb, _ = fc.convert(cam, "kannala-brandt")
    f, k1, k2, k3, k4 = kb.parameters
    (cx, cy), (ax, ay) = kb.principal_point, kb.pixel_scale
    K = np.array([[f * ax, 0, cx], [0, f * ay, cy], [0, 0, 1]])
    D = np.array([k1, k2, k3, k4])
    with tempfile.TemporaryDirectory() as tmp:
        rgb, lab = woodscape_scene(fishcam, tmp)
    size = (cam.width, cam.height)
    rng = np.random.default_rng(4)

    def one_sample():
        change = fc.random_change("train", int(rng.integers(1 << 62)))
        m1, m2 = cv2.fisheye.initUndistortRectifyMap(K, D, change.rotation, K, size, cv2.CV_16SC2)
        cv2.remap(rgb, m1, m2, cv2.INTER_LINEAR)
        cv2.remap(lab, m1, m2, cv2.INTER_NEAREST)

    return median_ms(one_sample, repeats)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fishcam", default=os.path.join(os.path.dirname(HERE), "build", "tools", "fishcam"))
    parser.add_argument(
        "--python-dir",
        default=os.path.join(os.path.dirname(HERE), "build", "python"),
        help="where the fishcam Python package was built (for the torch paths)",
    )
    parser.add_argument("--samples", type=int, default=20)
    parser.add_argument("--subsample", type=int, default=20000, help="pixels for the np.roots timing")
    args = parser.parse_args()
    sys.path.insert(0, args.python_dir)

    stereo = fishcam_bench(args.fishcam, os.path.join(DATA, "stereographic.cameramodel"), args.samples)
    woodscape = fishcam_bench(args.fishcam, os.path.join(DATA, "woodscape_front.json"), args.samples)
    mrcal_ms = mrcal_path_ms(args.fishcam, max(3, args.samples // 4))
    roots_ms = np_roots_ms(args.subsample)
    torch_ms = {t: torch_paths_ms(args.fishcam, args.samples, t) for t in (1, 2)}
    cv2.setNumThreads(2)
    fisheye_ms = opencv_fisheye_ms(args.fishcam, args.samples)
    result = {
        "fishcam_total_ms": {
            "stereographic": {t: r["total_ms"] for t, r in stereo.items()},
            "woodscape": {t: r["total_ms"] for t, r in woodscape.items()},
        },
        "mrcal_python_ms": mrcal_ms,
        "np_roots_extrapolated_ms": roots_ms,
        "mrcal_over_fishcam_1_thread": mrcal_ms / stereo[1]["total_ms"],
        "mrcal_over_fishcam_2_threads": mrcal_ms / stereo[2]["total_ms"],
        "np_roots_over_fishcam_1_thread": roots_ms / woodscape[1]["total_ms"],
        "np_roots_over_fishcam_2_threads": roots_ms / woodscape[2]["total_ms"],
        "torch_precomputed_grid_ms": {t: v[0] for t, v in torch_ms.items()},
        "torch_per_sample_grid_ms": {t: v[1] for t, v in torch_ms.items()},
        "torch_precomputed_over_fishcam": {t: torch_ms[t][0] / woodscape[t]["total_ms"] for t in (1, 2)},
        "torch_per_sample_over_fishcam": {t: torch_ms[t][1] / woodscape[t]["total_ms"] for t in (1, 2)},
        "opencv_fisheye_ms_2_threads": fisheye_ms,
        "opencv_fisheye_over_fishcam_2_threads": fisheye_ms / woodscape[2]["total_ms"],
    }
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
