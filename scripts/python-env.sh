#!/usr/bin/env bash
# Makes (or updates) the Python environment the package's tests and benchmarks run
# in: a virtual environment of /usr/bin/python3 (the interpreter the extension is
# built for) with Debian's packages visible (mrcal's Python), plus
# python/requirements-test.txt from PyPI (PyTorch 2.x, torchvision, the peers).
# Usage: scripts/python-env.sh [DIR]   (default build/venv); prints nothing when current.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${1:-build/venv}"
requirements=python/requirements-test.txt
stamp="$venv/.fishcam-requirements"
if [ -x "$venv/bin/python" ] && [ -f "$stamp" ] && cmp -s "$requirements" "$stamp"; then
  exit 0
fi
echo "python-env: making $venv from $requirements"
/usr/bin/python3 -m venv --system-site-packages "$venv"
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$requirements" 2>&1 |
  { grep -v "^WARNING: Location 'file:" || true; }
cp "$requirements" "$stamp"
echo "python-env: done ($("$venv/bin/python" -c 'import torch, torchvision; print("torch", torch.__version__, "torchvision", torchvision.__version__)'))"
