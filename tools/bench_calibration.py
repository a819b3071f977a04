#!/usr/bin/env python3
"""Calibration on the real chessboard photos (../shared/data/calibration) against the
references, in one process where they have one (docs/performance.md):
- fishcam.calibrate (Kannala-Brandt, one thread) against cv2.fisheye.calibrate on the
  same corners, in-call, interleaved, median of --repeats;
- `fishcam calibrate` per model against `mrcal-calibrate-cameras` (LENSMODEL_OPENCV8
  with its board-warp solve, its richest model comparable to ours), whole processes.

Run from the repository with the build's package: PYTHONPATH=build/python
build/venv/bin/python tools/bench_calibration.py [--repeats N]."""

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
import typing
from pathlib import Path

import fishcam
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PHOTOS = ROOT.parent / "shared" / "data" / "calibration"
BINARY = ROOT / "build" / "tools" / "fishcam"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    if not (PHOTOS / "right1.jpg").exists():
        print(f"no photos at {PHOTOS}", file=sys.stderr)
        return 1
    import cv2  # noqa: PLC0415  (the venv's OpenCV)

    images = sorted(PHOTOS.glob("right*.jpg"), key=lambda p: int(re.findall(r"\d+", p.name)[0]))
    with tempfile.TemporaryDirectory() as tmp:
        corners = Path(tmp) / "corners.vnl"
        subprocess.run(
            [str(BINARY), "detect-corners", *map(str, images), "--board", "9x6", "--out", str(corners)],
            check=True,
            capture_output=True,
        )
        observations = fishcam.read_corners(str(corners), (9, 6))
        _bench_in_call(cv2, observations, args.repeats)
        mrcal = _bench_mrcal(corners, tmp)
        _bench_fishcam_calibrate(corners, tmp, mrcal)
    return 0


def _bench_in_call(cv2: typing.Any, observations: list[tuple[str, np.ndarray]], repeats: int) -> None:
    """fishcam.calibrate (Kannala-Brandt, one thread) against cv2.fisheye.calibrate on
    the same corners, interleaved so that both see the same machine; prints medians."""
    board = np.zeros((54, 3))
    board[:, 0] = np.tile(np.arange(9), 6) * 0.03
    board[:, 1] = np.repeat(np.arange(6), 9) * 0.03
    guess = np.array([[240.0, 0, 479.5], [0, 240.0, 299.5], [0, 0, 1]])
    flags = cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW | cv2.fisheye.CALIB_USE_INTRINSIC_GUESS
    criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-15)
    ours, theirs = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        fishcam.calibrate(observations, (9, 6), 0.03, (960, 600), "kannala-brandt", threads=1)
        ours.append(time.perf_counter() - start)
        start = time.perf_counter()
        cv2.fisheye.calibrate(
            [board.reshape(-1, 1, 3)] * len(observations),
            [c.reshape(-1, 1, 2) for _, c in observations],
            (960, 600),
            guess.copy(),
            np.zeros(4),
            flags=flags,
            criteria=criteria,
        )
        theirs.append(time.perf_counter() - start)
    print(
        f"in-call, {len(observations)} images, {sum(len(c) for _, c in observations)} corners, median of "
        f"{repeats} (OpenCV {cv2.__version__}):"
    )
    print(f"  fishcam.calibrate kannala-brandt, 1 thread  {statistics.median(ours):.3f} s")
    print(
        f"  cv2.fisheye.calibrate                       {statistics.median(theirs):.3f} s"
        f"   ratio {statistics.median(ours) / statistics.median(theirs):.2f}"
    )


def _process_seconds(command: list[str], cwd: str) -> float:
    """The wall time of running ``command`` in ``cwd`` to its end (it must succeed)."""
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True, cwd=cwd)
    return time.perf_counter() - start


def _bench_mrcal(corners: Path, tmp: str) -> float:
    """mrcal-calibrate-cameras (LENSMODEL_OPENCV8) on the corners, whole processes;
    prints and returns the median of 3 runs' seconds."""
    mrcal = [
        _process_seconds(
            [
                "/usr/bin/mrcal-calibrate-cameras",
                "--corners-cache",
                str(corners),
                "--lensmodel",
                "LENSMODEL_OPENCV8",
                "--focal",
                "240",
                "--object-spacing",
                "0.03",
                "--object-width-n",
                "9",
                "--object-height-n",
                "6",
                "--imagersize",
                "960",
                "600",
                "--outdir",
                tmp,
                str(PHOTOS / "right*.jpg"),
            ],
            tmp,
        )
        for _ in range(3)
    ]  # one glob: one camera
    print(f"whole processes, median of 3: mrcal-calibrate-cameras LENSMODEL_OPENCV8 {statistics.median(mrcal):.2f} s")
    return statistics.median(mrcal)


def _bench_fishcam_calibrate(corners: Path, tmp: str, mrcal_seconds: float) -> None:
    """`fishcam calibrate` per model on 1 and 2 threads, whole processes; prints the
    median of 3 runs each and its ratio to mrcal's ``mrcal_seconds``."""
    for model in ("kannala-brandt", "polynomial", "unified", "extended-unified", "double-sphere", "mei"):
        for threads in (1, 2):
            times = [
                _process_seconds(
                    [
                        str(BINARY),
                        "calibrate",
                        "--corners",
                        str(corners),
                        "--board",
                        "9x6",
                        "--spacing",
                        "0.03",
                        "--imagersize",
                        "960x600",
                        "--model",
                        model,
                        "--threads",
                        str(threads),
                        "--out",
                        "cal.json",
                        "--force",
                    ],
                    tmp,
                )
                for _ in range(3)
            ]
            print(
                f"  fishcam calibrate {model:17s} --threads {threads}  {statistics.median(times):.2f} s"
                f"  ({statistics.median(times) / mrcal_seconds:.2f} x mrcal)"
            )


if __name__ == "__main__":
    sys.exit(main())
