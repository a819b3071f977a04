#!/usr/bin/env bash
# The C++ test suite under AddressSanitizer + UndefinedBehaviorSanitizer (clang).
#   scripts/test-sanitizers.sh        every C++ test, in build-asan/ (~25 min on 2 cores)
#   scripts/test-sanitizers.sh --ci   what CI runs (.ci/run), in build-asan-ci/: every
#                                     C++ test but the numeric sweeps (label sweep)
#                                     (~9 min on 2 cores: build 6, tests 3)
# Left out of both, and why: the Python tests (the interpreter itself is not
# instrumented; they run in the normal build) and install_and_find_package (it
# installs and builds a consumer: nothing of ours runs under the sanitizers there).
# Leak detection is off: Debian's OpenCV/TBB/Ceres keep allocations until exit;
# memory errors and undefined behaviour abort the test.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=full
case "${1:-}" in
  "") ;;
  --ci) mode=ci ;;
  *) echo "usage: scripts/test-sanitizers.sh [--ci]" >&2; exit 2 ;;
esac
./scripts/install-deps.sh
build=build-asan
[ "$mode" = ci ] && build=build-asan-ci
# clang, not g++: the same files compile about 1.8x faster under the sanitizers
# (tools/info.cpp: 23 s against 41 s), which is what lets CI afford this job.
# A unity build (CMake batches several sources per compiler run): the headers
# (OpenCV, Eigen, CLI11, JSON) are parsed once per batch, not once per file; the
# normal build keeps one file per run, so every file still compiles on its own there.
# Library, program and all: 5.8 min here against 10.5 min without.
# -O1 without -g: stack traces keep function names; Ceres' templates take minutes
# per file at higher levels under the sanitizers. The fishcam program's own files at
# -O0 (tools/info.cpp: 12 s against 26 s, every check kept): the work it starts runs
# in the library.
# EIGEN_MALLOC_ALREADY_ALIGNED=1: under the address sanitizer Eigen stops trusting
# malloc's 16-byte alignment and allocates with an offset pointer of its own, while
# Debian's (uninstrumented) libceres frees the same matrices with plain free():
# ASan then reports "free on address not malloc()-ed" inside Ceres' covariance
# (Eigen's BDCSVD). Telling our objects what Ceres assumes makes both sides agree;
# Eigen asserts the alignment it then relies on (this build keeps assertions on).
sanitize="-fsanitize=address,undefined"
/usr/bin/cmake -S . -B "$build" -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=None -DFISHCAM_BUILD_PYTHON=OFF \
  -DCMAKE_UNITY_BUILD=ON -DFISHCAM_TEST_TIMEOUT=1200 -DFISHCAM_TOOLS_CXX_FLAGS=-O0 \
  -DCMAKE_CXX_FLAGS="-O1 $sanitize -fno-sanitize-recover=undefined -fno-omit-frame-pointer -DEIGEN_MALLOC_ALREADY_ALIGNED=1" \
  -DCMAKE_EXE_LINKER_FLAGS="$sanitize" -DCMAKE_SHARED_LINKER_FLAGS="$sanitize" >/dev/null
/usr/bin/cmake --build "$build" -j "$(nproc)"
# By label (tests/CMakeLists.txt): never python (no Python build here) or install.
excluded='python|install'
if [ "$mode" = ci ]; then
  # The numeric sweeps (label sweep): every model or many poses against an exact
  # reference or through a full calibration, and the targets' render-detect-calibrate
  # runs (6-7 min each here, 30-40 s in the normal build), 1300 of the suite's 1700 CPU seconds
  # under the sanitizers. Their code paths run in the other tests (one model, one
  # pose); the full run above runs them too.
  excluded+='|sweep'
fi
ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  /usr/bin/ctest --test-dir "$build" --output-on-failure -j "$(nproc)" -LE "^($excluded)\$"
