"""The Python blocks of docs/python.md and README.md pass mypy --strict against the
package under test, and run (the blocks are extracted from the docs, not copied
here): what the docs pass (tuples for vectors, ints for floats, dicts of fills) is
what the stubs accept and what the package does. The names a block takes as given
(an image, a camera, a model) are declared once below with the types the docs
describe (GIVEN), and given_values holds a real value of that type for each."""

import importlib.util
import os
import re
import subprocess
import sys

import fishcam
import numpy as np
import pytest
from conftest import BINARY, DATA

REPO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
DOCS = ["docs/python.md", "README.md"]

GIVEN = """\
import typing
import numpy as np
import numpy.typing as npt
import torch
import fishcam
import fishcam.torch
import fishcam.torch as ft
from torchvision import tv_tensors

# What the docs' blocks take as given.
root: str
path: str
epochs: int
seed: int
n: int
model: torch.nn.Module
test_loader: torch.utils.data.DataLoader[dict[str, typing.Any]]
cam: fishcam.Camera
camera: fishcam.Camera
cameras: list[fishcam.Camera]
changes: list[fishcam.ViewpointChange]
image: npt.NDArray[np.uint8]
img: npt.NDArray[np.uint8]
images: torch.Tensor
labels: npt.NDArray[np.uint8]
lab: npt.NDArray[np.uint8]
part_labels: npt.NDArray[np.uint8]
instance_masks: npt.NDArray[np.bool_]
masks: torch.Tensor
boxes: npt.NDArray[np.float64]
xyxy: npt.NDArray[np.float64]
classes: list[int]
points: npt.NDArray[np.float64]
xy: npt.NDArray[np.float64]
pixels: npt.NDArray[np.float64]
rays: npt.NDArray[np.float64]
rho: npt.NDArray[np.float64]
depth: npt.NDArray[np.float32]
depth_map: npt.NDArray[np.float32]
p: npt.NDArray[np.float64]
outlines: list[npt.NDArray[np.float64]]
right_image: npt.NDArray[np.uint8]
left: list[tuple[str, npt.NDArray[np.float64]]]
right: list[tuple[str, npt.NDArray[np.float64]]]
"""


def python_blocks():
    """(file, first line, code) of every ```python block of the docs."""
    blocks = []
    for doc in DOCS:
        with open(os.path.join(REPO, doc), encoding="utf-8") as f:
            text = f.read()
        for match in re.finditer(r"```python\n(.*?)```", text, re.S):
            blocks.append((doc, text.count("\n", 0, match.start()) + 2, match.group(1)))
    return blocks


def test_every_python_block_of_the_docs_passes_mypy_strict(tmp_path):
    pytest.importorskip("mypy")
    blocks = python_blocks()
    assert len(blocks) >= 8, f"expected the 8 blocks of docs/python.md at least, found {len(blocks)}"
    names = {}
    for k, (doc, line, code) in enumerate(blocks):
        name = f"block{k}.py"
        (tmp_path / name).write_text(GIVEN + code)
        names[name] = (doc, line - GIVEN.count("\n") - 1)
    # The fishcam under test, with its stubs: an installed one mypy finds through the
    # interpreter's site-packages (which MYPYPATH may not hold), a built one through MYPYPATH.
    package_parent = os.path.dirname(os.path.dirname(os.path.abspath(fishcam.__file__)))
    env = dict(os.environ)
    if os.path.basename(package_parent) not in ("site-packages", "dist-packages"):
        env["MYPYPATH"] = package_parent
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "mypy",
            "--config-file",
            os.path.join(REPO, "pyproject.toml"),
            "--cache-dir",
            str(tmp_path / "cache"),
            *sorted(names),
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )

    def where(match):  # blockK.py:N -> docs/python.md:M
        doc, offset = names[match.group(1)]
        return f"{doc}:{int(match.group(2)) + offset}"

    report = re.sub(r"(block\d+\.py):(\d+)", where, result.stdout + result.stderr)
    assert result.returncode == 0, report


# Where the tree cites its docs: sources, scripts, stubs, the docs themselves.
CITING = ["lib", "tools", "python", "tests", "scripts", "cmake", "docs", "README.md", "CHANGELOG.md", "CMakeLists.txt"]
TEXT = (".cpp", ".hpp", ".py", ".pyi", ".md", ".sh", ".txt", ".cmake", ".toml")


def test_every_docs_reference_resolves():
    """Every "docs/NAME.ext" a file names, and every relative link of a Markdown file,
    is a file of the tree (the stubs once cited a models page that never existed)."""
    cited = 0
    missing = []
    for top in CITING:
        path = os.path.join(REPO, top)
        files = (
            [path]
            if os.path.isfile(path)
            else [os.path.join(d, f) for d, _, fs in os.walk(path) for f in fs if f.endswith(TEXT)]
        )
        for file in files:
            if f"{os.sep}fuzz{os.sep}" in file or f"{os.sep}build" in file:
                continue
            with open(file, encoding="utf-8", errors="replace") as f:
                text = f.read()
            for name in re.findall(r"\bdocs/[A-Za-z0-9_.-]+\.(?:md|svg|png|json)", text):
                cited += 1
                if not os.path.exists(os.path.join(REPO, name)):
                    missing.append(f"{os.path.relpath(file, REPO)}: {name}")
            if file.endswith(".md"):
                for link in re.findall(r"\]\(([^)#:\s]+)(?:#[^)]*)?\)", text):
                    cited += 1
                    if not os.path.exists(os.path.join(os.path.dirname(file), link)):
                        missing.append(f"{os.path.relpath(file, REPO)}: ({link})")
    assert cited > 100, f"only {cited} references found: is the tree there?"
    assert not missing, "\n".join(missing)


def test_every_recipe_of_the_architecture_names_files_that_exist():
    """docs/architecture.md's recipes ("Add a radial model in 3 steps", ...): the steps
    are numbered as the title counts them, and every file a recipe names exists (a
    placeholder NAME: its folder), so a recipe cannot outlive the code it describes."""
    with open(os.path.join(REPO, "docs/architecture.md"), encoding="utf-8") as f:
        text = f.read()
    words = {"3": 3, "4": 4, "5": 5, "three": 3, "four": 4, "five": 5}
    recipes = re.findall(r"^## (Add .*?) in (\w+) steps\n(.*?)(?=^## |\Z)", text, re.S | re.M)
    assert len(recipes) >= 3, [r[0] for r in recipes]
    basenames = {
        name
        for top in ("lib", "tools", "python", "docs", "tests", "cmake", "scripts")
        for _, _, files in os.walk(os.path.join(REPO, top))
        for name in files
    }
    checked = 0
    for title, count, body in recipes:
        steps = re.findall(r"^(\d+)\. ", body, re.M)
        assert steps == [str(i) for i in range(1, words[count] + 1)], f"{title}: steps {steps}, title says {count}"
        for name in re.findall(r"`([A-Za-z0-9_./-]+\.(?:hpp|cpp|md|py|cmake))`", body):
            checked += 1
            if "NAME" in name:
                assert os.path.isdir(os.path.join(REPO, os.path.dirname(name))), f"{title}: {name}"
            elif "/" in name:
                assert os.path.exists(os.path.join(REPO, name)), f"{title}: {name}"
            else:
                assert name in basenames, f"{title}: {name}"
    assert checked >= 10, f"only {checked} files named by the recipes"


# ---------------------------------------------------------------- the blocks, run

# What the fishcam program makes for the blocks, and how a block names it: a block
# that needs one skips without FISHCAM_BINARY.
PROGRAM_MADE = {"root": r"\broot\b", "sv": r'"sv"', "corners.vnl": r"corners\.vnl", "grid.vnl": r"grid\.vnl"}
SIZE = (160, 121)  # the given camera's (width, height): WoodScape's front lens, resized
BOARD = (9, 6)
PEERS = ("torch", "torchvision", "albumentations")  # what the blocks import besides fishcam and numpy


def _rotation(v):
    """The rotation of axis-angle v (Rodrigues)."""
    angle = np.linalg.norm(v)
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]]) / angle
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def _stereo_corners(camera, count, seed):
    """Corners of 9x6 boards (0.03 m) seen by a stereo pair of `camera` (camera 1 at
    0.1 m along x, turned 10 degrees): each camera's boards seen whole, by instant."""
    rng = np.random.default_rng(seed)
    board = np.stack(np.meshgrid(np.arange(BOARD[0]), np.arange(BOARD[1])), -1).reshape(-1, 2) * 0.03
    board = np.hstack([board - board.mean(axis=0), np.zeros((len(board), 1))])
    turn = _rotation(np.radians([0, 10, 0]))
    left, right = [], []
    for i in range(count):
        points = board @ _rotation(rng.uniform(-0.5, 0.5, 3)).T + [*rng.uniform(-0.1, 0.1, 2), rng.uniform(0.3, 0.5)]
        for corners, seen in ((left, points), (right, (points - [0.1, 0, 0]) @ turn)):
            pixels, ok = camera.project(seen)
            if ok.all() and (pixels >= 0).all() and (pixels <= [camera.width - 1, camera.height - 1]).all():
                corners.append((f"{i:03d}.png", pixels))
    return left, right


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """The files the blocks read, made once: data/ (the repository's), a camera file,
    and what the fishcam program makes: a WoodScape-layout sample set (root), a
    surround-view set with true test sets (sv) and a 960x600 camera's chessboard and
    AprilGrid corners."""
    folder = tmp_path_factory.mktemp("docs-inputs")
    (folder / "data").symlink_to(os.path.abspath(DATA))
    camera = fishcam.Camera.read(os.path.join(DATA, "woodscape_front.json")).resized(*SIZE)
    camera.write(str(folder / "camera.json"))
    lens = fishcam.Camera.read(os.path.join(DATA, "kannala_brandt.yaml")).cropped(160, 183, 960, 600)
    lens.write(str(folder / "lens960.json"))
    if BINARY:
        for args in (
            ["sample-dataset", "root", "--images", "4", "--size", f"{SIZE[0]}x{SIZE[1]}", "--seed", "1"],
            ["sample-dataset", "sv", "--scenes", "2", "--size", "96x73", "--seed", "1", "--depth"],
            ["synth-corners", "lens960.json", "--boards", "10", "--noise", "0.2", "--seed", "1"]
            + ["--board", f"{BOARD[0]}x{BOARD[1]}", "--spacing", "0.03", "--out", "corners.vnl"],
            ["synth-corners", "lens960.json", "--boards", "15", "--noise", "0.2", "--seed", "1"]
            + ["--target", "aprilgrid:6x6:0.088:0.3", "--out", "grid.vnl"],
        ):
            subprocess.run([os.path.abspath(BINARY), *args], cwd=folder, check=True, capture_output=True, timeout=300)
    return folder


def missing_peer():
    """The first of the packages the blocks import that is not installed (None: all
    are, or FISHCAM_REQUIRE_PEERS=1 says they must be)."""
    if os.environ.get("FISHCAM_REQUIRE_PEERS") == "1":
        return None
    return next((name for name in PEERS if importlib.util.find_spec(name) is None), None)


def given_values(inputs):
    """A value for every name GIVEN declares, each of the kind the docs describe."""
    import torch

    rng = np.random.default_rng(0)
    width, height = SIZE
    camera = fishcam.Camera.read(str(inputs / "camera.json"))
    image = rng.integers(0, 256, (height, width, 3), dtype=np.uint8)
    labels = rng.integers(0, 10, (height, width), dtype=np.uint8)
    instance_masks = np.zeros((2, height, width), dtype=bool)
    instance_masks[0, 40:80, 30:70] = instance_masks[1, 60:100, 90:140] = True
    boxes = np.array([[30.0, 40.0, 70.0, 80.0], [90.0, 60.0, 140.0, 100.0]])  # the instances' boxes
    outline = np.array([[40.0, 50.0], [120.0, 50.0], [80.0, 100.0]])
    depth = np.full((height, width), 5.0, dtype=np.float32)
    xy = np.array([[80.0, 60.0], [30.0, 90.0], [150.0, 20.0]])
    test_set = [
        {"image": torch.rand(3, height, width), "mask": torch.randint(0, 10, (height, width))} for _ in range(2)
    ]
    left, right = _stereo_corners(fishcam.Camera.read(str(inputs / "lens960.json")), 30, 1)
    return {
        "root": str(inputs / "root"),
        "path": str(inputs / "camera.json"),
        "epochs": 1,
        "seed": 7,
        "n": fishcam.get_num_threads(),  # set_num_threads(n) changes nothing for the other tests
        "model": torch.nn.Conv2d(3, 10, 1),  # 10 classes, WoodScape's
        "test_loader": torch.utils.data.DataLoader(test_set, batch_size=2),
        "cam": camera,
        "camera": camera,
        "cameras": [camera, camera],
        "changes": [fishcam.random_change("train", 1), fishcam.random_change("train", 2)],
        "image": image,
        "img": image,
        "right_image": image[:, ::-1].copy(),
        "images": torch.from_numpy(np.stack([image, image[::-1]])).permute(0, 3, 1, 2).contiguous(),
        "labels": labels,
        "lab": labels,
        "part_labels": labels // 2,
        "instance_masks": instance_masks,
        "masks": torch.from_numpy(np.stack([labels, labels[::-1]])),
        "boxes": boxes,
        "xyxy": boxes,
        "classes": [1, 2],
        "points": np.array([[1.0, 0.5, 2.0], [-0.5, 0.2, 1.0], [0.0, 0.0, 3.0]]),
        "xy": xy,
        "pixels": np.array([[480.0, 300.0], [100.0, 80.0]]),  # of the calibrated 960x600 camera
        "rays": np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]]),
        "rho": np.array([0.0, 20.0, 50.0]),
        "depth": depth,
        "depth_map": depth,
        "p": outline,
        "outlines": [outline],
        "left": left,
        "right": right,
    }


def test_given_values_are_what_given_declares(inputs):
    if missing_peer():
        pytest.skip(f"{missing_peer()} not installed")
    declared = re.findall(r"^(\w+): ", GIVEN, re.M)
    assert sorted(declared) == sorted(given_values(inputs))


def block_id(doc, line):
    return f"{os.path.basename(doc)}:{line}"


BLOCKS = python_blocks()
RAN = {}  # block id -> "passed", or why it skipped


@pytest.mark.parametrize("doc,line,code", BLOCKS, ids=[block_id(doc, line) for doc, line, _ in BLOCKS])
def test_every_python_block_of_the_docs_runs(doc, line, code, inputs, tmp_path, monkeypatch):
    """Each block as a user would copy it: in a fresh namespace of GIVEN's imports and a
    real value for each given name, in a folder of its own (blocks write files) that
    holds data/ and the files the blocks read; tracebacks give the doc's lines."""
    key = block_id(doc, line)
    needed = [name for name, pattern in PROGRAM_MADE.items() if re.search(pattern, code)]
    if needed and not BINARY:
        RAN[key] = reason = f"FISHCAM_BINARY not set: the block reads {', '.join(needed)}, made by the fishcam program"
        pytest.skip(reason)
    if missing_peer():
        RAN[key] = reason = f"{missing_peer()} not installed"
        pytest.skip(reason)
    for name in ("data", "sv", "corners.vnl", "grid.vnl"):
        if (inputs / name).exists():
            (tmp_path / name).symlink_to(inputs / name)
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__docs__"}
    exec(GIVEN, namespace)
    namespace.update(given_values(inputs))
    try:
        exec(compile("\n" * (line - 1) + code, os.path.join(REPO, doc), "exec"), namespace)
    finally:
        namespace.clear()  # a DataLoader's persistent workers end here
    RAN[key] = "passed"


def test_every_python_block_of_the_docs_ran():
    """The test above ran every block of python_blocks(), none forgotten, none failed."""
    expected = [block_id(doc, line) for doc, line, _ in python_blocks()]
    assert len(expected) > 0, "no ```python block found in the docs"
    if not RAN:
        pytest.skip("the blocks' test was deselected")
    did_not_run = sorted(set(expected) - set(RAN))
    assert not did_not_run and len(RAN) == len(expected), f"blocks that failed or did not run: {did_not_run}"
