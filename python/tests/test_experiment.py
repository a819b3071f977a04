"""fishcam.experiment end to end on a tiny synthetic dataset: --quick, resuming, the
same numbers from the same seeds, bad input, and two DDP processes (gloo)."""

import json
import math
import os
import shutil
import subprocess
import sys

import pytest

torch = pytest.importorskip("torch")
experiment = pytest.importorskip("fishcam.experiment")

BINARY = os.environ.get("FISHCAM_BINARY")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    if not BINARY:
        pytest.skip("FISHCAM_BINARY not set (run through CTest)")
    root = tmp_path_factory.mktemp("experiment") / "sv"
    subprocess.run([BINARY, "sample-dataset", str(root), "--scenes", "4", "--size", "96x73", "--seed", "5",
                    "--splits", "0.5,0,0.5", "--test-sets", "small,large", "--supersampling", "1"],
                   check=True, capture_output=True)
    return root


def _mious(out):
    with open(os.path.join(out, "results.json")) as f:
        results = json.load(f)
    return {(r["config"], r["seed"], test_set): value["miou"]
            for r in results["runs"] for test_set, value in r["test"].items()}


def test_quick_run_writes_the_tables_and_reproduces(dataset, tmp_path):
    out = tmp_path / "a"
    assert experiment.main([str(dataset), str(out), "--quick"]) == 0
    mious = _mious(out)
    # 2 configurations x 2 seeds x (original + 2 test sets x 2 variants).
    assert len(mious) == 2 * 2 * 5
    assert all(math.isfinite(v) and 0 <= v <= 1 for v in mious.values())
    tables = (out / "tables.md").read_text()
    for heading in ("Table 2", "Table 3", "Table 5"):
        assert heading in tables
    assert "| none |" in tables and "large-rotation" in tables
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


def test_bad_input(dataset, tmp_path, capsys):
    assert experiment.main([str(tmp_path), str(tmp_path / "out"), "--quick"]) == 2
    assert "no train/rgb_images" in capsys.readouterr().err
    assert experiment.main([str(dataset), str(tmp_path / "out"), "--configs", "none,rotate"]) == 2
    assert "config: expected one of" in capsys.readouterr().err


def test_two_ddp_processes(dataset, tmp_path):
    torchrun = shutil.which("torchrun", path=os.path.dirname(sys.executable))
    if torchrun is None:
        pytest.skip("no torchrun next to this Python")
    out = tmp_path / "ddp"
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    result = subprocess.run([torchrun, "--nproc_per_node=2", "--master_port=29533", "-m", "fishcam.experiment",
                             str(dataset), str(out), "--quick"], capture_output=True, text=True, env=env, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    mious = _mious(out)
    assert len(mious) == 2 * 2 * 5 and all(math.isfinite(v) for v in mious.values())
