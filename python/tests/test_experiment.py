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
ft = pytest.importorskip("fishcam.torch")


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
    # Two configurations, one seed, 8 training images in batches of 2, 10 evaluated images: a run of E
    # epochs on n images costs 2 x (E x ceil(n / 2) x (pipeline + step) + 10 x evaluation).
    work = budget.Work(seeds=1, train_images=8, batch_size=2, evaluated_images=10)
    costs = budget.Costs(
        {1.0: {"none": 0.5, "viewpoint": 0.5}, 0.5: {"none": 0.1, "viewpoint": 0.1}},
        {1.0: {16: 2.0, 24: 4.0}, 0.5: {8: 0.2, 12: 0.3, 16: 0.4, 24: 0.9}},
        {1.0: {16: 0.2, 24: 0.4}, 0.5: {8: 0.05, 12: 0.05, 16: 0.1, 24: 0.2}},
        0.0,
    )
    assert budget.predicted_seconds(costs, work, 1.0, 8, 16, 10) == pytest.approx(204)  # 2 x (10 x 4 x 2.5 + 2)

    def chosen(seconds, **fixed):  # what fits `seconds` after the margin
        plan = budget.choose(costs, seconds / 60 / (1 - budget.MARGIN), work, fixed=budget.Fixed(**fixed))
        return plan.scale, plan.train_images, plan.width, plan.epochs, plan.reduced

    # Full resolution, every image: width 16 (204 s; 24: 368 s), then 14 epochs: 2 x (14 x 10 + 2) = 284 <= 300.
    assert chosen(300) == (1.0, 8, 16, 14, ())
    # The resolution first: at 0.5 width 24 trains 10 epochs (84 s), 18 fit: 2 x (18 x 4 + 2) = 148 <= 150.
    assert chosen(150) == (0.5, 8, 24, 18, ("resolution",))
    # Then the images, at width 16: 8 (42 s) do not fit 33 s, 6 (3 batches: 32 s) do; 10 epochs (11: 35 s).
    assert chosen(33) == (0.5, 6, 16, 10, ("resolution", "training images"))
    # Then the width on half the images: 16 takes 22 s, 12 2 x (10 x 2 x 0.4 + 0.5) = 17 s; 11 epochs (18.6 s).
    assert chosen(20) == (0.5, 4, 12, 11, ("resolution", "training images", "width"))
    # Then the epochs at width 8: 10 take 13 s, 7 take 2 x (7 x 2 x 0.3 + 0.5) = 9.4 s.
    assert chosen(10) == (0.5, 4, 8, 7, ("resolution", "training images", "width", "epochs"))
    with pytest.raises(fishcam.Error, match="1 epoch.* at scale 0.5 on 4 training image.* at width 8"):
        chosen(1)
    # Settings given are kept: at scale 1, 4 images (2 batches: 104 s; 6 take 154 s), 14 epochs (144 s).
    assert chosen(150, scale=1.0) == (1.0, 4, 16, 14, ("training images",))
    # Width 24 for 5 epochs on all 8 images: 188 s at scale 1, 44 s at 0.5.
    assert chosen(150, train_images=8, width=24, epochs=5) == (0.5, 8, 24, 5, ("resolution",))
    with pytest.raises(fishcam.Error, match="5 epoch.* at scale 1 on 8 training image.* at width 24"):
        chosen(150, scale=1.0, train_images=8, width=24, epochs=5)


def test_budget_measures_coarser_scales_and_narrower_widths_only_when_needed(monkeypatch):
    """measure() stops at the first scale holding every image at width >= 16 for 10
    epochs, measures only those widths there, and the narrower ones at the last scale;
    each measurement here is the action's value (the step seconds below), nothing else
    costs."""
    budget = experiment.experiment_budget
    monkeypatch.setattr(budget, "_median_seconds", lambda action, repeats=3: action())
    steps = {
        1.0: {8: 0.3, 12: 0.6, 16: 1.0, 24: 2.0, 32: 4.0, 48: 8.0},
        0.75: {8: 0.1, 12: 0.3, 16: 0.5, 24: 0.7, 32: 1.0, 48: 2.0},
        0.5: {8: 0.05, 12: 0.08, 16: 0.2, 24: 0.3, 32: 0.5, 48: 1.0},
    }

    class Loader(list):  # one batch, "read" in 0 s; the iteration knows its scale
        def __init__(self, scale):
            super().__init__([0.0])
            self.scale = scale

    class Free(torch.nn.Module):  # an evaluation that costs 0 s
        def forward(self, images):
            return 0.0

    # One configuration, one seed, 8 images in one batch, nothing evaluated: 10 epochs cost 10 x step.
    work = budget.Work(seeds=1, train_images=8, batch_size=8, evaluated_images=0)

    def measured(seconds):
        def choose(costs):
            return budget.choose(costs, seconds / 60 / (1 - budget.MARGIN), work)

        costs = budget.measure(
            lambda scale: {"none": Loader(scale)},
            lambda scale: [],
            lambda width, loader: lambda: steps[loader.scale][width],
            lambda width: Free(),
            lambda scale: (8, 4, 4),
            torch.device("cpu"),
            {scale: list(budget.WIDTHS) for scale in budget.SCALES},
            choose,
        )
        plan = choose(costs)
        return {s: sorted(w) for s, w in costs.step.items()}, (plan.scale, plan.width)

    # 25 s: full resolution holds width 24 (20 s; 32: 40 s); nothing narrower or coarser is measured.
    assert measured(25) == ({1.0: [16, 24, 32]}, (1.0, 24))
    # 8 s: width 16 at full resolution takes 10 s; at 0.75 width 24 takes 7 s (32: 10 s).
    assert measured(8) == ({1.0: [16], 0.75: [16, 24, 32]}, (0.75, 24))
    # 1 s: only the last scale, from the narrowest: 12 takes 0.8 s, 16 2 s.
    assert measured(1) == ({1.0: [16], 0.75: [16], 0.5: [8, 12, 16]}, (0.5, 12))


def test_scale_downscales_images_labels_and_cameras_together(dataset):
    """--scale resizes through fishcam.torch.Resize before the augmentation: the camera
    describes the downscaled image (the viewpoint change would refuse one that does
    not), labels nearest-neighbour (no value that was not there), the test images as
    the training images."""
    assert experiment.scaled_size((73, 96), 0.5) == (37, 48)
    assert experiment.scaled_size((73, 96), 0.75) == (55, 72)
    for config in ("none", "viewpoint", "viewpoint:equidistant:paper"):
        train = ft.WoodScapeDataset(dataset / "train", transform=experiment.transform_for(config, 0.5), seed=0)
        sample = train[(0, 0)]
        assert sample["image"].shape == (3, 37, 48) and sample["mask"].shape == (37, 48), config
        assert (sample["camera"].width, sample["camera"].height) == (48, 37), config
    test = ft.WoodScapeDataset(dataset / "test", transform=experiment.evaluation_transform(0.5))
    sample, original = test[0], ft.WoodScapeDataset(dataset / "test")[0]
    assert sample["image"].shape == (3, 37, 48) and sample["image"].dtype == torch.float32
    assert set(sample["mask"].unique().tolist()) <= set(original["mask"].unique().tolist())
    assert (sample["camera"].width, sample["camera"].height) == (48, 37)
    assert sample["camera"] == original["camera"].resized(48, 37)


def test_budget_chooses_the_resolution_and_the_training_images(dataset, tmp_path, capsys, monkeypatch):
    """What --budget chooses reaches the runs: trained and scored at the chosen scale on
    the chosen images, recorded in results.json, tables.md and each run's settings, so
    that a run with other settings is refused. The costs are given (the choice itself is
    tested above); the runs are real."""
    budget = experiment.experiment_budget
    # Two configs x 1 seed; 8 training images in batches of 2. At scale 0.5, width 16 costs 2 x E x batches
    # x 1.0 s: 10 epochs on 8 images (4 batches) 80 s, on 6 (3) 60 s, on 4 (2) 40 s <= the ~51 s of a minute
    # after the margin; then 12 epochs (48 s; 13: 52 s). Scale 1 fits nothing.
    costs = budget.Costs(
        {1.0: {"none": 1.0, "viewpoint": 1.0}, 0.5: {"none": 0.1, "viewpoint": 0.1}},
        {1.0: {16: 10.0}, 0.5: {16: 0.9, 24: 5.0}},
        {1.0: {16: 0.0}, 0.5: {16: 0.0, 24: 0.0}},
        0.0,
    )
    monkeypatch.setattr(budget, "measure", lambda *args, **kwargs: costs)
    out = tmp_path / "chosen"
    common = ["--configs", "none,viewpoint", "--seeds", "1", "--batch-size", "2", "--no-figures", "--no-fidelity"]
    # run, not main: main counts the age of this (pytest's) process against the budget.
    assert experiment.run([str(dataset), str(out), "--budget", "1"] + common) == 0
    assert (
        "--budget 1 min: scale 0.5 (48x37), 4 of 8 training images, width 16, 12 epochs (reduced to fit: "
        "resolution, training images; runs predicted 0.8 min" in capsys.readouterr().out
    )
    results = json.loads((out / "results.json").read_text())
    assert (results["scale"], results["image_size"], results["train_images"]) == (0.5, [48, 37], 4)
    assert (results["budget"]["scale"], results["budget"]["train_images"]) == (0.5, 4)
    assert results["budget"]["reduced"] == ["resolution", "training images"]
    assert results["budget"]["step_seconds"] == {"1": {"16": 10.0}, "0.5": {"16": 0.9, "24": 5.0}}
    # The class weights of the 4 images trained on (the first scene's 4 cameras), not of all 8.
    first = experiment.class_weights(experiment.scan_dataset(str(dataset)).train_counts(4))
    assert results["class_weights"] == pytest.approx(first.tolist())
    assert results["class_weights"] != pytest.approx(
        experiment.class_weights(experiment.scan_dataset(str(dataset)).train_counts(8)).tolist()
    )
    assert (
        "Trained and scored at 48 × 37 (--scale 0.5 of the dataset's 96 × 73) on the first 4"
        in (out / "tables.md").read_text()
    )
    run = out / "runs" / "none-seed0.json"
    settings = json.loads(run.read_text())["settings"]
    assert (settings["scale"], settings["train_images"], settings["width"], settings["epochs"]) == (0.5, 4, 16, 12)
    stored = run.read_bytes()
    # The same settings by hand reuse the runs; another scale or number of images is refused.
    by_hand = ["--scale", "0.5", "--train-images", "4", "--width", "16", "--epochs", "12"] + common
    assert experiment.main([str(dataset), str(out)] + by_hand) == 0
    assert run.read_bytes() == stored
    for option, value, message in (
        ("--scale", "1", "--scale 0.5, now 1.0"),
        ("--train-images", "8", "--train-images 4, now 8"),
    ):
        changed = by_hand + [option, value]
        assert experiment.main([str(dataset), str(out)] + changed) == 2
        assert message in capsys.readouterr().err
    assert run.read_bytes() == stored


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
    assert chosen["scale"] in experiment.experiment_budget.SCALES and 4 <= chosen["train_images"] <= 8
    for key in ("scale", "train_images", "width", "epochs"):
        assert results[key] == chosen[key], key
    height, width = experiment.scaled_size((73, 96), chosen["scale"])
    assert (
        f"--budget 1 min: scale {chosen['scale']:g} ({width}x{height}), {chosen['train_images']} of 8 training "
        f"images, width {chosen['width']}, {chosen['epochs']} epochs" in result.stdout
    )
    assert wall <= 1.5 * 60
    assert results["seconds"] <= 1.5 * chosen["predicted_run_seconds"]
    assert chosen["predicted_run_seconds"] <= 1.5 * results["seconds"]
    for bad, message in (
        (["--budget", "0"], "--budget 0: expected minutes > 0"),
        (["--budget", "nan"], "--budget nan: expected minutes > 0"),
        (["--budget", "5", "--quick"], "--budget and --quick: choose one"),
        (["--quick", "--train-images", "0"], "--train-images 0: must be >= 1"),
        (["--quick", "--train-images", "9"], "--train-images 9: " + str(dataset / "train") + " has 8 images"),
        (["--budget", "5", "--scale", "0.3"], "--scale 0.3: expected one of 1, 0.75, 0.5"),
        (["--quick", "--scale", "half"], "--scale half: expected one of 1, 0.75, 0.5"),
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
