"""The Python blocks of docs/python.md and README.md pass mypy --strict against the
package under test (the blocks are extracted from the docs, not copied here): what
the docs pass (tuples for vectors, ints for floats, dicts of fills) is what the stubs
accept. The names a block takes as given (an image, a camera, a model) are declared
once below with the types the docs describe."""

import os
import re
import subprocess
import sys

import fishcam
import pytest

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
left: list[tuple[str, npt.NDArray[np.float64]]]
right: typing.Any  # an image in one block, a camera's corners in another
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
