"""fishcam.experiment's reliability (issue 40): a stored run is reused only when it was
made with the same settings from the same dataset (otherwise refused, naming the
first difference, or recomputed with --rerun); OUT is neither the dataset, nor inside
it, nor a file; --configs is checked as a list; bad arguments and bad datasets are
refused in one line on stderr, exit status 2, before anything is written."""

import json
import os
import shutil
import subprocess
import sys

import pytest
from conftest import BINARY

torch = pytest.importorskip("torch")
cv2 = pytest.importorskip("cv2")
experiment = pytest.importorskip("fishcam.experiment")


# One run (none, seed 0, 1 epoch, width 4), without the fidelity table and figures.
TINY = ["--quick", "--configs", "none", "--seeds", "1", "--no-figures", "--no-fidelity"]
RUN = os.path.join("runs", "none-seed0.json")


def _make(root, seed):
    subprocess.run(
        [
            BINARY,
            "sample-dataset",
            str(root),
            "--scenes",
            "2",
            "--size",
            "64x49",
            "--seed",
            str(seed),
            "--splits",
            "0.5,0,0.5",
            "--test-sets",
            "small",
            "--supersampling",
            "1",
        ],
        check=True,
        capture_output=True,
    )
    return root


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    if not BINARY:
        pytest.skip("FISHCAM_BINARY not set (run through CTest)")
    return _make(tmp_path_factory.mktemp("reliability") / "sv", 5)


def _refused(capsys, argv, *expected):
    """main(argv) exits 2 with one line on stderr holding each of ``expected``."""
    code = experiment.main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("fishcam-experiment: error: "), err
    for text in expected:
        assert text in lines[0]
    return lines[0]


def _tree(root):
    return sorted(
        (os.path.relpath(os.path.join(d, f), root), os.path.getsize(os.path.join(d, f)))
        for d, _, files in os.walk(root)
        for f in files
    )


def test_a_run_made_with_other_settings_is_refused_or_rerun(dataset, tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    assert experiment.main([str(dataset), str(out)] + TINY) == 0
    run = json.loads((out / RUN).read_text())
    assert run["settings"] == {
        "scale": 1.0,
        "train_images": 4,
        "epochs": 1,
        "batch_size": 8,
        "width": 4,
        "class_weights": "balanced",
        "device": "cpu",
        "amp": False,
        "channels_last": False,
        "processes": 1,
    }
    # 2 scenes x 4 cameras: train, test, test-small, test-small-rotation, test-small-paper; image, label,
    # calibration each.
    assert run["dataset"]["files"] == 4 * 5 * 3 and len(run["dataset"]["sha256"]) == 64
    stored = (out / RUN).read_bytes()
    # The probe's case: --epochs 3 --width 8 after a --quick run named the first difference.
    _refused(
        capsys,
        [
            dataset,
            out,
            "--configs",
            "none",
            "--seeds",
            "1",
            "--epochs",
            "3",
            "--width",
            "8",
            "--no-figures",
            "--no-fidelity",
        ],
        str(out / RUN),
        "--epochs 1, now 3",
        "--rerun",
    )
    for option, value, named in (
        ("--width", "8", "--width 4, now 8"),
        ("--batch-size", "4", "--batch-size 8, now 4"),
        ("--class-weights", "none", "--class-weights balanced, now none"),
    ):
        _refused(capsys, [dataset, out] + TINY + [option, value], named)
    monkeypatch.setenv("WORLD_SIZE", "2")  # refused before torchrun's process group would be needed
    _refused(capsys, [dataset, out] + TINY, "--nproc_per_node (torchrun's processes) 1, now 2")
    monkeypatch.delenv("WORLD_SIZE")
    assert (out / RUN).read_bytes() == stored
    # The same settings spelt out (what --quick means) reuse it.
    assert (
        experiment.main(
            [
                str(dataset),
                str(out),
                "--configs",
                "none",
                "--seeds",
                "1",
                "--epochs",
                "1",
                "--width",
                "4",
                "--no-figures",
                "--no-fidelity",
            ]
        )
        == 0
    )
    assert (out / RUN).read_bytes() == stored
    # --rerun recomputes it under the new settings, which are reused from then on.
    assert experiment.main([str(dataset), str(out)] + TINY + ["--width", "8", "--rerun"]) == 0
    run = json.loads((out / RUN).read_text())
    assert run["settings"]["width"] == 8
    assert torch.load(out / "runs" / "none-seed0.pt")["head.weight"].shape[1] == 8
    stored = (out / RUN).read_bytes()
    assert experiment.main([str(dataset), str(out)] + TINY + ["--width", "8"]) == 0
    assert (out / RUN).read_bytes() == stored
    # A run of a harness that did not record them.
    del run["settings"]
    (out / RUN).write_text(json.dumps(run))
    _refused(capsys, [dataset, out] + TINY + ["--width", "8"], "stored without its settings")


def test_a_run_from_another_dataset_is_refused_or_rerun(dataset, tmp_path, capsys):
    out = tmp_path / "out"
    assert experiment.main([str(dataset), str(out)] + TINY) == 0
    stored = (out / RUN).read_bytes()
    # A copy (other path, other times) is the same dataset.
    copy = tmp_path / "copy"
    shutil.copytree(dataset, copy, copy_function=shutil.copyfile)
    assert experiment.main([str(copy), str(out)] + TINY) == 0
    assert (out / RUN).read_bytes() == stored
    # One label pixel changed (a valid class) is another.
    label = copy / "test-small" / "semantic_annotations" / "gtLabels" / "00001_FV.png"
    mask = cv2.imread(str(label), cv2.IMREAD_UNCHANGED)
    mask[0, 0] = (mask[0, 0] + 1) % 10
    cv2.imwrite(str(label), mask)
    _refused(capsys, [copy, out] + TINY, str(out / RUN), "made from another dataset", str(copy))
    # So is a dataset made with another seed (the probe's case).
    other = _make(tmp_path / "other", 6)
    _refused(capsys, [other, out] + TINY, "made from another dataset")
    assert (out / RUN).read_bytes() == stored
    assert experiment.main([str(other), str(out)] + TINY + ["--rerun"]) == 0
    run = json.loads((out / RUN).read_text())
    assert run["dataset"]["path"] == str(other) and run["dataset"]["sha256"] != json.loads(stored)["dataset"]["sha256"]
    assert experiment.main([str(other), str(out)] + TINY) == 0


def test_out_is_neither_the_dataset_nor_inside_it_nor_a_file(dataset, tmp_path, capsys):
    before = _tree(dataset)
    link = tmp_path / "link"
    link.symlink_to(dataset)
    a_file = tmp_path / "a-file"
    a_file.write_text("keep")
    for data, out, named in (
        (dataset, dataset, "OUT is the dataset"),
        (dataset, dataset / "results", "OUT is inside the dataset"),
        (dataset, dataset / "train", "OUT is inside the dataset"),
        (dataset, link, "OUT is the dataset"),
        (dataset, link / "results", "OUT is inside the dataset"),
        (link, dataset / "results", "OUT is inside the dataset"),
        (dataset, a_file, "exists and is not a folder"),
    ):
        _refused(capsys, [data, out] + TINY, named)
    assert _tree(dataset) == before and a_file.read_text() == "keep"


def test_configs_must_be_a_list_of_distinct_names(dataset, tmp_path, capsys):
    out = tmp_path / "out"
    for configs, named in (
        ("", "--configs: empty"),
        (" ", "--configs: empty"),
        (",", "an empty name"),
        ("none,,viewpoint", "an empty name"),
        ("none,", "an empty name"),
        ("none,none", "none is given twice"),
        ("none,viewpoint,none", "none is given twice"),
        ("none,rotate", "--configs: expected one of"),
    ):
        _refused(capsys, [dataset, out, "--configs", configs, "--no-figures"], named)
    assert not out.exists()


def test_bad_arguments_are_one_line(dataset, tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    cases = [
        (["--workers", "-1"], "--workers -1: must be >= 0"),
        (["--seeds", "0"], "--seeds 0: must be >= 1"),
        (["--batch-size", "0"], "--batch-size 0"),
        (["--width", "0"], "--width 0"),
        (["--width", "100000"], "--width 100000: at most 256"),
        (["--width", "257"], "at most 256"),
        (["--device", "x"], "--device 'x': expected cpu or cuda"),
        (["--device", "cpu:3"], "expected cpu or cuda"),
        (["--device", "tpu"], "expected cpu or cuda"),
    ]
    if not torch.cuda.is_available():
        cases += [(["--device", "cuda"], "--device cuda: no CUDA device"), (["--device", "cuda:0"], "no CUDA device")]
    for extra, named in cases:
        _refused(capsys, [dataset, out] + TINY + extra, named)
    # A width the memory cannot hold (the available memory made small).
    monkeypatch.setattr(experiment, "available_memory", lambda device: 2**20)
    _refused(capsys, [dataset, out] + TINY, "--width 4 with --batch-size 8 at 64x49 needs about", "lower --width")
    assert not out.exists()
    # And through the command line: no traceback.
    result = subprocess.run(
        [sys.executable, "-m", "fishcam.experiment", str(dataset), str(out), "--workers", "-1"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 2 and result.stderr.splitlines() == [
        "fishcam-experiment: error: --workers -1: must be >= 0"
    ], result.stderr


def test_a_bad_dataset_names_the_file(dataset, tmp_path, capsys):
    copy = tmp_path / "sv"
    shutil.copytree(dataset, copy)
    out = tmp_path / "out"
    label = copy / "test-small" / "semantic_annotations" / "gtLabels" / "00001_MVL.png"
    original = label.read_bytes()
    mask = cv2.imread(str(label), cv2.IMREAD_UNCHANGED)
    mask[3, 4] = 200
    cv2.imwrite(str(label), mask)
    _refused(capsys, [copy, out] + TINY, f"{label}: label 200 is outside the 10 classes")
    label.write_bytes(original)
    calibration = copy / "train" / "calibration" / "00000_RV.json"
    calibration.unlink()
    _refused(capsys, [copy, out] + TINY, f"{calibration}: missing")
    calibration.write_text('{"not": "a camera"}')
    _refused(capsys, [copy, out] + TINY, f"{calibration}: ")
    assert not out.exists()
