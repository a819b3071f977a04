#!/usr/bin/env bash
# The C++ test suite under AddressSanitizer + UndefinedBehaviorSanitizer (g++),
# in build-asan/. Left out, and why: the Python tests (the interpreter itself is
# not instrumented; they run in the normal build) and install_and_find_package
# (it installs and builds a consumer: nothing of ours runs under the sanitizers
# there). Leak detection is off: Debian's OpenCV/TBB/Ceres keep allocations until
# exit; memory errors and undefined behaviour abort the test.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
# -O1 without -g: Ceres' templates take 186 s per file at RelWithDebInfo under the
# sanitizers, 52 s at -O1 (and stack traces keep function names).
# EIGEN_MALLOC_ALREADY_ALIGNED=1: under __SANITIZE_ADDRESS__ Eigen stops trusting
# malloc's 16-byte alignment and allocates with an offset pointer of its own, while
# Debian's (uninstrumented) libceres frees the same matrices with plain free():
# ASan then reports "free on address not malloc()-ed" inside Ceres' covariance
# (Eigen's BDCSVD). Telling our objects what Ceres assumes makes both sides agree;
# Eigen asserts the alignment it then relies on (this build keeps assertions on).
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=None -DFISHCAM_BUILD_PYTHON=OFF -DFISHCAM_TEST_TIMEOUT=1200 \
  -DCMAKE_CXX_FLAGS="-O1 -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -DEIGEN_MALLOC_ALREADY_ALIGNED=1" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" \
  >/dev/null
cmake --build build-asan -j "$(nproc)"
ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -E '^(install_and_find_package|python_tests)$'
