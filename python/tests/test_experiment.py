"""fishcam.experiment end to end on a tiny synthetic dataset: --quick, resuming, the
same numbers from the same seeds, the fidelity table and the figures, bad input, and
two DDP processes (gloo); fishcam.dataset_fidelity; --budget.

CTest: RUN_SERIAL (--budget measures this machine and is held to its time: nothing
else runs beside this file)."""

import json
import math
import os
import shutil
import subprocess
import sys
import time

import fishcam
import pytest
from conftest import BINARY

torch = pytest.importorskip("torch")
experiment = pytest.importorskip("fishcam.experiment")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    if not BINARY:
        pytest.skip("FISHCAM_BINARY not set (run through CTest)")
    root = tmp_path_factory.mktemp("experiment") / "sv"
    subprocess.run(
        [
            BINARY,
            "sample-dataset",
            str(root),
            "--scenes",
            "4",
            "--size",
            "96x73",
            "--seed",
            "5",
            "--splits",
            "0.5,0,0.5",
            "--test-sets",
            "small,large",
            "--supersampling",
            "1",
            "--depth",
        ],
        check=True,
        capture_output=True,
    )
    return root


def _mious(out):
    with open(os.path.join(out, "results.json")) as f:
        results = json.load(f)
    return {
        (r["config"], r["seed"], test_set): value["miou"]
        for r in results["runs"]
        for test_set, value in r["test"].items()
    }


def test_quick_run_writes_the_tables_and_reproduces(dataset, tmp_path):
    out = tmp_path / "a"
    assert experiment.main([str(dataset), str(out), "--quick"]) == 0
    mious = _mious(out)
    # 2 configurations x 2 seeds x (original + 2 test sets x 3 variants: true, rotation, the paper's protocol).
    assert len(mious) == 2 * 2 * 7
    assert all(math.isfinite(v) and 0 <= v <= 1 for v in mious.values())
    tables = (out / "tables.md").read_text()
    for heading in ("Table 2", "Table 3", "Table 5", "Fidelity", "Differences from none"):
        assert heading in tables
    assert "| none |" in tables and "large-rotation" in tables and "large-paper" in tables
    assert "| test set | mIoU | degrades (%) | background | road |" in tables
    with open(out / "results.json") as f:
        results = json.load(f)
    # 4 test sets (small, large, each with its rotation-only variant) x 4 priors.
    assert len(results["fidelity"]) == 4 * 4
    # Table 5 by geometry: 4 test sets x the camera's own model and the Table 5 models.
    assert len(results["model_fidelity"]) == 4 * len(experiment.FIDELITY_MODELS)
    assert "Table 5 by geometry" in tables
    assert len(results["class_weights"]) == 10
    for name in ("miou_vs_change.png", "predictions.png", "model_fidelity.png"):
        assert (out / "figures" / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out / "runs" / "viewpoint-seed1.pt").stat().st_size > 0
    # Resuming: stored runs are not repeated (a changed run file is taken as it is).
    run_file = out / "runs" / "none-seed0.json"
    stored = json.loads(run_file.read_text())
    stored["test"]["original"]["miou"] = 0.5
    run_file.write_text(json.dumps(stored))
    assert experiment.main([str(dataset), str(out), "--quick"]) == 0
    assert _mious(out)[("none", 0, "original")] == 0.5
    # The same seeds give the same numbers.
    again = tmp_path / "b"
    assert experiment.main([str(dataset), str(again), "--quick"]) == 0
    b = _mious(again)
    for key, value in _mious(tmp_path / "a").items():
        if key != ("none", 0, "original"):
            assert b[key] == pytest.approx(value, abs=1e-9), key


def test_dataset_fidelity(dataset, tmp_path):
    rows = fishcam.dataset_fidelity(str(dataset))
    assert [(r["test_set"], r["prior"]) for r in rows] == [
        (s, p)
        for s in ("test-large", "test-large-rotation", "test-small", "test-small-rotation")
        for p in ("source-sphere", "target-sphere", "infinity", "map")
    ]
    for r in rows:
        assert r["samples"] == 8 and 0.5 < r["valid_share"] <= 1
        # Rotations are exact under every prior; the depth map is exact for translations too.
        if r["test_set"].endswith("-rotation") or r["prior"] == "map":
            assert r["label_agreement"] >= 0.995, r
    with pytest.raises(fishcam.Error, match="no test/ folder"):
        fishcam.dataset_fidelity(str(tmp_path))
    broken = tmp_path / "broken"
    shutil.copytree(dataset, broken)
    (broken / "test-small" / "changes.jsonl").write_text('{"name": "00002_FV"}\n')
    with pytest.raises(fishcam.Error, match="changes.jsonl: a line lacks name, rotation_deg or translation"):
        fishcam.dataset_fidelity(str(broken))


def test_paired_differences_against_a_hand_computation():
    # Differences 0.10, 0.15, 0.05: mean 0.10, sd 0.05, t(0.975, 2) = 4.303.
    mean, low, high = experiment.paired_difference([0.5, 0.6, 0.7], [0.4, 0.45, 0.65])
    half = 4.303 * 0.05 / math.sqrt(3)
    assert (mean, low, high) == pytest.approx((0.10, 0.10 - half, 0.10 + half), abs=1e-12)
    assert experiment.paired_difference([0.5], [0.4]) is None
    lines = experiment.difference_table(
        [
            {"config": c, "seed": s, "test": {"original": {"miou": v}}}
            for c, s, v in [("none", 0, 0.40), ("none", 1, 0.42), ("base", 0, 0.50), ("base", 1, 0.51)]
        ],
        ["none", "base"],
        ["original"],
    )
    # 0.10 and 0.09: mean 9.5 points, half-width 12.706 * 0.7071 / sqrt(2) = 6.4: significant.
    assert lines[4] == "| base | +9.5 [+3.1, +15.9]* |"


def test_dataset_model_fidelity(dataset):
    rows = fishcam.dataset_model_fidelity(str(dataset), ["own", "equidistant:paper", "stereographic:lsq"])
    assert [(r["test_set"], r["model"]) for r in rows] == [
        (s, m)
        for s in ("test-large", "test-large-rotation", "test-small", "test-small-rotation")
        for m in ("own", "equidistant:paper", "stereographic:lsq")
    ]
    by = {(r["test_set"], r["model"]): r for r in rows}
    for s in ("test-large-rotation", "test-small-rotation"):
        own, paper = by[s, "own"], by[s, "equidistant:paper"]
        # The camera's own model is the truth on rotations; a fitted model moves pixels.
        assert own["label_agreement"] >= 0.995 and own["endpoint_px"] == 0, own
        assert paper["endpoint_px"] > 0.5 and paper["label_agreement"] < own["label_agreement"], paper
        assert len(paper["endpoint_by_angle_px"]) == 4
    # The same rows as the program prints.
    out = subprocess.run(
        [BINARY, "fidelity", str(dataset), "--models", "own,equidistant:paper,stereographic:lsq", "--json"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    program = json.loads(out)["rows"]
    assert [(r["test_set"], r["model"], r["samples"]) for r in program] == [
        (r["test_set"], r["model"], r["samples"]) for r in rows
    ]
    for a, b in zip(program, rows):
        assert a["label_agreement"] == pytest.approx(b["label_agreement"], abs=1e-12)
    with pytest.raises(fishcam.Error, match="given twice"):
        fishcam.dataset_model_fidelity(str(dataset), ["own", "own"])
    with pytest.raises(fishcam.Error, match="depth"):
        fishcam.dataset_model_fidelity(str(dataset), ["own"], depth="sphere")


def test_figures_need_matplotlib(dataset, tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib raises ImportError
    assert experiment.main([str(dataset), str(tmp_path / "out"), "--quick"]) == 2
    assert "the figures need matplotlib" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_bad_input(dataset, tmp_path, capsys):
    assert experiment.main([str(tmp_path), str(tmp_path / "out"), "--quick"]) == 2
    assert "no train/rgb_images" in capsys.readouterr().err
    assert experiment.main([str(dataset), str(tmp_path / "out"), "--configs", "none,rotate"]) == 2
    assert "--configs: expected one of" in capsys.readouterr().err


def test_budget_chooses_the_widest_width_that_trains_ten_epochs_then_the_most_epochs():
    budget = experiment.experiment_budget
    # Per run: epochs x 2 batches x (pipeline 0.5 + step) + 10 images x evaluation.
    costs = budget.Costs({"none": 0.5, "viewpoint": 0.5}, {8: 1.0, 16: 2.0, 24: 4.0}, {8: 0.1, 16: 0.2, 24: 0.4}, 0.0)
    # Two configs x one seed: width 16 costs 2 x (10 x 2 x 2.5 + 2) = 104 s for 10 epochs, width 24 184 s.
    assert budget.predicted_seconds(costs, 16, 10, 1, 2, 10) == pytest.approx(104)
    plan = budget.choose(costs, 150 / 60 / (1 - budget.MARGIN), 1, 2, 10)  # 150 s after the margin
    assert (plan.width, plan.epochs) == (16, 14)  # 2 x (14 x 5 + 2) = 144 <= 150 < 2 x (15 x 5 + 2)
    assert budget.choose(costs, 150 / 60 / (1 - budget.MARGIN), 1, 2, 10, epochs=4).width == 24
    assert budget.choose(costs, 30 / 60 / (1 - budget.MARGIN), 1, 2, 10).width == 8  # not even 10 epochs fit
    with pytest.raises(fishcam.Error, match="--budget 0.01: 1 epoch"):
        budget.choose(costs, 0.01, 1, 2, 10)


def test_budget_keeps_a_quick_run_inside_its_time(dataset, tmp_path, capsys):
    """--budget 1: the whole process (imports, measurement, runs, tables) within 1.5
    minutes, and the runs' predicted time within a factor of 1.5 of what they took."""
    out = tmp_path / "budget"
    started = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "fishcam.experiment", str(dataset), str(out), "--budget", "1"]
        + ["--configs", "none,viewpoint", "--seeds", "2", "--no-figures", "--no-fidelity"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    wall = time.perf_counter() - started
    assert result.returncode == 0, result.stderr[-2000:]
    with open(out / "results.json") as f:
        results = json.load(f)
    chosen = results["budget"]
    assert chosen["width"] in experiment.experiment_budget.WIDTHS and chosen["epochs"] >= 1
    assert (results["width"], results["epochs"]) == (chosen["width"], chosen["epochs"])
    assert f"--budget 1 min: width {chosen['width']}, {chosen['epochs']} epochs" in result.stdout
    assert wall <= 1.5 * 60
    assert results["seconds"] <= 1.5 * chosen["predicted_run_seconds"]
    assert chosen["predicted_run_seconds"] <= 1.5 * results["seconds"]
    for bad, message in (
        (["--budget", "0"], "--budget 0: expected minutes > 0"),
        (["--budget", "nan"], "--budget nan: expected minutes > 0"),
        (["--budget", "5", "--quick"], "--budget and --quick: choose one"),
    ):
        assert experiment.main([str(dataset), str(tmp_path / "bad"), *bad]) == 2
        assert message in capsys.readouterr().err


def test_two_ddp_processes(dataset, tmp_path):
    torchrun = shutil.which("torchrun", path=os.path.dirname(sys.executable))
    if torchrun is None:
        pytest.skip("no torchrun next to this Python")
    out = tmp_path / "ddp"
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    result = subprocess.run(
        [
            torchrun,
            "--nproc_per_node=2",
            "--master_port=29533",
            "-m",
            "fishcam.experiment",
            str(dataset),
            str(out),
            "--quick",
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    mious = _mious(out)
    assert len(mious) == 2 * 2 * 7 and all(math.isfinite(v) for v in mious.values())


def test_a_folder_without_splits(tmp_path):
    """The real dataset's layout (rgb_images/ at the top): split by a file or a seed, the
    paper-protocol test sets made by augment-dataset, no truth and so no fidelity."""
    if not BINARY:
        pytest.skip("FISHCAM_BINARY not set (run through CTest)")
    flat = tmp_path / "woodscape"
    subprocess.run(
        [BINARY, "sample-dataset", str(flat), "--images", "6", "--size", "64x49", "--seed", "3"],
        check=True,
        capture_output=True,
    )
    split = tmp_path / "test.txt"
    split.write_text("# WoodScape's list format: one image per line\n00001_FV.png\n00004_FV\n")
    out = tmp_path / "out"
    common = ["--quick", "--configs", "none", "--seeds", "1", "--no-figures", "--fishcam", BINARY]
    assert experiment.main([str(flat), str(out), "--split", str(split)] + common) == 0
    assert sorted(os.listdir(out / "dataset" / "test" / "rgb_images")) == ["00001_FV.png", "00004_FV.png"]
    assert len(os.listdir(out / "dataset" / "train" / "rgb_images")) == 4
    with open(out / "results.json") as f:
        results = json.load(f)
    assert sorted(results["runs"][0]["test"]) == ["large-paper", "medium-paper", "original", "small-paper"]
    assert results["fidelity"] == [] and results["model_fidelity"] == []
    assert "small-paper" in (out / "tables.md").read_text()
    fifo = tmp_path / "split.fifo"
    os.mkfifo(fifo)  # never opened: refused before any read
    # A seeded split, and what is refused.
    assert experiment.main([str(flat), str(tmp_path / "seeded"), "--split-seed", "4"] + common) == 0
    assert len(os.listdir(tmp_path / "seeded" / "dataset" / "test" / "rgb_images")) == 1  # 20 % of 6
    for extra, message in (
        ([], "needs one of --split FILE and --split-seed S"),
        (["--split", str(split), "--split-seed", "1"], "needs one of --split FILE and --split-seed S"),
        (["--split", str(tmp_path / "none.txt")], "not a regular file"),
        (["--split", "/dev/zero"], "not a regular file"),
        (["--split", str(fifo)], "not a regular file"),
    ):
        with pytest.raises(fishcam.Error, match=message):
            experiment.run([str(flat), str(tmp_path / "bad")] + extra + common)
    (tmp_path / "missing.txt").write_text("00009_FV.png\n")
    (tmp_path / "empty.txt").write_text("# nothing\n")
    for name, message in (("missing.txt", "not in"), ("empty.txt", "names no image")):
        with pytest.raises(fishcam.Error, match=message):
            experiment.run([str(flat), str(tmp_path / "bad"), "--split", str(tmp_path / name)] + common)
    other = tmp_path / "other.txt"
    other.write_text("00002_FV.png\n")
    with pytest.raises(fishcam.Error, match="another split"):
        experiment.run([str(flat), str(out), "--split", str(other)] + common)


def test_the_gpu_recipe_runs_on_the_cpu(dataset, tmp_path):
    """--amp --channels-last (the one-GPU recipe) exercised on the CPU: bfloat16 autocast,
    NHWC layout; recorded in the run's settings, so it never resumes a float32 run."""
    out = tmp_path / "amp"
    tiny = ["--quick", "--configs", "none", "--seeds", "1", "--no-figures", "--no-fidelity"]
    assert experiment.main([str(dataset), str(out), "--amp", "--channels-last"] + tiny) == 0
    with open(out / "results.json") as f:
        results = json.load(f)
    assert results["settings"]["amp"] is True and results["settings"]["channels_last"] is True
    assert all(math.isfinite(t["miou"]) for t in results["runs"][0]["test"].values())
    # The same OUT without --amp: the stored run was made with other settings.
    with pytest.raises(fishcam.Error, match="amp"):
        experiment.run([str(dataset), str(out)] + tiny)
