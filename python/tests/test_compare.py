"""``fishcam compare`` against an independent recomputation from ``fishcam map`` outputs,
the paper's eqs. 13-14, and fishcam.compare."""

import json
import math
import os
import subprocess

import fishcam
import numpy as np
import pytest
from conftest import BINARY, DATA

CAMERA = os.path.join(DATA, "woodscape_front.json")


def cli(*args):
    if not BINARY:
        pytest.skip("FISHCAM_BINARY not set (run through CTest)")
    result = subprocess.run([BINARY, *map(str, args)], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return result.stdout


def fishcam_map(camera, change, out):
    cli(
        "map",
        camera,
        "--rotate",
        ",".join(repr(x) for x in change["rotation_deg"]),
        "--translate",
        ",".join(repr(x) for x in change["translation"]),
        "--out",
        out,
    )
    return np.load(out).astype(np.float64)


def inside(m, width, height):
    return (m[..., 0] >= -0.5) & (m[..., 0] < width - 0.5) & (m[..., 1] >= -0.5) & (m[..., 1] < height - 0.5)


def test_figures_agree_with_fishcam_map(tmp_path):
    # --out is created (it was refused as "no such folder"); the figures go into it.
    report = json.loads(
        cli(
            "compare",
            CAMERA,
            "--models",
            "kannala-brandt,stereographic",
            "--samples",
            2,
            "--seed",
            3,
            "--out",
            tmp_path / "figures" / "new",
            "--json",
        )
    )
    assert (tmp_path / "figures" / "new" / "sphere.png").is_file()
    for name in ["kannala-brandt", "stereographic"]:
        (tmp_path / f"{name}.json").write_bytes((tmp_path / "figures" / "new" / f"{name}.json").read_bytes())
    cam = fishcam.Camera.read(CAMERA)
    rays, ok = cam.unproject(
        np.stack(np.meshgrid(np.arange(cam.width), np.arange(cam.height)), -1).reshape(-1, 2).astype(float)
    )
    theta = np.degrees(np.arctan2(np.hypot(rays[:, 0], rays[:, 1]), rays[:, 2])).reshape(cam.height, cam.width)
    for model in report["models"]:
        name = model["name"]
        distances, bands, one_only, either = [], [], 0, 0
        for i, change in enumerate(report["changes"]):
            a = fishcam_map(CAMERA, change, tmp_path / f"ref{i}{name}.npy")
            b = fishcam_map(tmp_path / f"{name}.json", change, tmp_path / f"{name}{i}.npy")
            in_a, in_b = inside(a, cam.width, cam.height), inside(b, cam.width, cam.height)
            both = in_a & in_b
            one_only += np.count_nonzero(in_a != in_b)
            either += np.count_nonzero(in_a | in_b)
            distances.append(np.hypot(*(a[both] - b[both]).T))
            bands.append(theta[both])
        d, t = np.concatenate(distances), np.concatenate(bands)
        got = model["displacement"]
        assert got["pixels"] == d.size
        assert got["mean_px"] == pytest.approx(d.mean(), rel=1e-9)
        assert got["max_px"] == pytest.approx(d.max(), rel=1e-6)
        assert got["p95_px"] == pytest.approx(np.percentile(d, 95), rel=1e-6)
        assert model["validity_differs_pct"] == pytest.approx(100 * one_only / either, rel=1e-12)
        for band in model["by_angle"]:
            upper = band["to_deg"] if band["to_deg"] is not None else 360
            selected = d[(t >= band["from_deg"]) & (t < upper)]
            assert band["pixels"] == pytest.approx(selected.size, abs=2)  # float vs double angle at a band edge
            if selected.size:
                assert band["mean_px"] == pytest.approx(selected.mean(), rel=1e-4)
        assert model["identity_max_px"] < 1e-3
    kb = report["models"][0]
    assert kb["displacement"]["p95_px"] < 1 and kb["fit_rms_px"] < 0.2
    for picture in ["sphere.png", "augmented.png", "displacement-kannala-brandt.png", "displacement-stereographic.png"]:
        assert (tmp_path / "figures" / "new" / picture).stat().st_size > 10000, picture


def test_method_paper_uses_eqs_13_and_14(tmp_path):
    report = json.loads(
        cli(
            "compare",
            CAMERA,
            "--models",
            "equidistant,stereographic,kannala-brandt",
            "--method",
            "paper",
            "--samples",
            1,
            "--json",
        )
    )
    cam = fishcam.Camera.read(CAMERA)
    rho = cam.width / 2
    theta = math.radians(cam.field_of_view_deg.horizontal / 2)
    by_name = {m["name"]: m for m in report["models"]}
    assert by_name["equidistant"]["parameters"][0] == pytest.approx(rho / theta, rel=1e-12)
    assert by_name["stereographic"]["parameters"][0] == pytest.approx(rho / (2 * math.tan(theta / 2)), rel=1e-12)
    assert by_name["equidistant"]["how"] == "the paper's eqs. 13-14"
    assert by_name["kannala-brandt"]["how"] == "least-squares fit"
    text = cli("compare", CAMERA, "--models", "equidistant,kannala-brandt", "--method", "paper", "--samples", 1)
    assert "the paper's eqs. 13-14" in text and "least-squares fit" in text


def test_python_compare_equals_the_cli():
    report = json.loads(cli("compare", CAMERA, "--models", "kannala-brandt", "--samples", 1, "--seed", 9, "--json"))
    cam = fishcam.Camera.read(CAMERA)
    # The CLI adds the rendered scene's labels; Python compares the labels it is given.
    result = fishcam.compare(cam, ["kannala-brandt", ("itself", cam)], samples=1, seed=9)
    assert isinstance(result, fishcam.Comparison) and result.preset == "train" and result.seed == 9
    # Typed values, the same numbers as the CLI's JSON; to_json() is that JSON.
    assert [list(c.rotation_deg) + list(c.translation) for c in result.changes] == [
        c["rotation_deg"] + c["translation"] for c in report["changes"]
    ]
    kb = result.models[0]
    assert {
        "mean_px": kb.displacement.mean_px,
        "p95_px": kb.displacement.p95_px,
        "max_px": kb.displacement.max_px,
        "pixels": kb.displacement.pixels,
    } == {k: report["models"][0]["displacement"][k] for k in ("mean_px", "p95_px", "max_px", "pixels")}
    assert kb.name == "kannala-brandt" and kb.how == "least-squares fit" and kb.camera.model == "kannala-brandt"
    assert len(kb.by_angle) == len(result.angle_bands_deg) - 1
    assert kb.mean_displacement.shape == (cam.height, cam.width) and kb.mean_displacement.dtype == np.float32
    assert np.nanmax(kb.mean_displacement) <= kb.displacement.max_px + 1e-6
    assert result.models[1].displacement.max_px == 0 and result.models[1].name == "itself"
    assert json.loads(result.to_json())["models"][0]["displacement"] == report["models"][0]["displacement"]
    with pytest.raises(fishcam.Error, match="neither a camera file nor a model"):
        fishcam.compare(cam, ["fisheye-of-my-dreams"], samples=1)
    with pytest.raises(fishcam.Error, match="preset"):
        fishcam.compare(cam, ["equidistant"], preset="enormous")
    with pytest.raises(fishcam.Error, match="labels"):
        fishcam.compare(cam, ["equidistant"], samples=1, labels={"x": np.zeros((3, 3), np.uint8)})


def test_bad_inputs_fail_in_one_line_and_write_nothing(tmp_path):
    if not BINARY:
        pytest.skip("FISHCAM_BINARY not set (run through CTest)")
    import cv2

    cv2.imwrite(str(tmp_path / "small.png"), np.zeros((10, 10), np.uint8))
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "sphere.png").write_bytes(b"mine")
    cases = [
        (["--models", "fisheye-of-my-dreams"], "neither a camera file nor a model"),
        (["--models", "equidistant,,stereographic"], "empty entry"),
        (["--models", "equidistant,equidistant"], "given twice"),
        (["--out", tmp_path, "--models", tmp_path / "out" / "sphere.png"], "contains the input"),
        (["--out", tmp_path / "out", "--models", tmp_path / "out" / "sphere.png", "--force"], "contains the input"),
        (["--out", tmp_path / "out"], "already exists"),
        (["--image", tmp_path / "small.png"], "is 10x10 but the camera is 1280x966"),
        (["--label", tmp_path / "small.png"], "--image"),
        (["--samples", 0], "--samples"),
    ]
    for args, message in cases:
        result = subprocess.run(
            [BINARY, "compare", CAMERA, "--samples", "1", *map(str, args)], capture_output=True, text=True
        )
        assert result.returncode != 0, args
        assert message in result.stderr and result.stderr.count("\n") == 1, (args, result.stderr)
    assert (tmp_path / "out" / "sphere.png").read_bytes() == b"mine"
    assert sorted(os.listdir(tmp_path / "out")) == ["sphere.png"]
