#!/usr/bin/python3
"""Augmentation speed against the reference implementations, as ratios in one run.

    /usr/bin/python3 tools/bench_reference.py [--fishcam build/tools/fishcam] [--samples N]

- fishcam: `fishcam bench augment --json` (1 and 2 threads), on the bundled
  stereographic camera (which mrcal can represent) and the WoodScape front camera.
- mrcal's Python path: mrcal.image_transformation_map(distance=1) +
  mrcal.transform_image for the RGB image and the labels, stereographic camera.
- WoodScape's per-pixel method: numpy.roots of the 4th-order polynomial for each
  pixel (what the WoodScape tooling and the paper's look-up table are built from),
  timed on a random subsample of pixels and extrapolated to the whole image; the
  rest of that pipeline (rotate, project, remap) is not even counted.
Run with Debian's /usr/bin/python3 (python3-mrcal, python3-numpy, python3-opencv).
"""
import argparse
import json
import os
import subprocess
import tempfile
import time

import cv2
import mrcal
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(os.path.dirname(HERE), "data")


def fishcam_bench(fishcam, camera, samples):
    out = subprocess.run([fishcam, "bench", "augment", camera, "--json", "--samples", str(samples)],
                         check=True, capture_output=True, text=True).stdout
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
        subprocess.run([fishcam, "render", source, "--out-image", image, "--out-label", labels],
                       check=True, capture_output=True)
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


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fishcam", default=os.path.join(os.path.dirname(HERE), "build", "tools", "fishcam"))
    parser.add_argument("--samples", type=int, default=20)
    parser.add_argument("--subsample", type=int, default=20000, help="pixels for the np.roots timing")
    args = parser.parse_args()

    stereo = fishcam_bench(args.fishcam, os.path.join(DATA, "stereographic.cameramodel"), args.samples)
    woodscape = fishcam_bench(args.fishcam, os.path.join(DATA, "woodscape_front.json"), args.samples)
    mrcal_ms = mrcal_path_ms(args.fishcam, max(3, args.samples // 4))
    roots_ms = np_roots_ms(args.subsample)
    result = {
        "fishcam_total_ms": {"stereographic": {t: r["total_ms"] for t, r in stereo.items()},
                             "woodscape": {t: r["total_ms"] for t, r in woodscape.items()}},
        "mrcal_python_ms": mrcal_ms,
        "np_roots_extrapolated_ms": roots_ms,
        "mrcal_over_fishcam_1_thread": mrcal_ms / stereo[1]["total_ms"],
        "mrcal_over_fishcam_2_threads": mrcal_ms / stereo[2]["total_ms"],
        "np_roots_over_fishcam_1_thread": roots_ms / woodscape[1]["total_ms"],
        "np_roots_over_fishcam_2_threads": roots_ms / woodscape[2]["total_ms"],
    }
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
