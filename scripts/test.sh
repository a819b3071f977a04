#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/build.sh
/usr/bin/ctest --test-dir build --output-on-failure -j "$(nproc)"
