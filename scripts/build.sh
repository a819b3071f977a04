#!/usr/bin/env bash
# Installs what is missing, then configures and builds fishcam (Release) in build/.
# Extra arguments go to CMake's configure step (-DNAME=VALUE).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
/usr/bin/cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
/usr/bin/cmake --build build -j "$(nproc)"
