#!/usr/bin/env bash
# Installs what is missing (Debian packages; the Python test environment in
# build/venv from PyPI), builds, and runs the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
./scripts/python-env.sh build/venv
./scripts/build.sh -DFISHCAM_TEST_PYTHON="$PWD/build/venv/bin/python"
/usr/bin/ctest --test-dir build --output-on-failure -j "$(nproc)"
