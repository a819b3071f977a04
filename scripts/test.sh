#!/usr/bin/env bash
# Installs what is missing (Debian packages; the Python test environment in
# build/venv from PyPI), builds, installs the Python package into build/venv with
# `pip install .`, and runs the whole test suite (the Python tests against that
# installed package).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
./scripts/python-env.sh build/venv
./scripts/build.sh -DFISHCAM_TEST_PYTHON="$PWD/build/venv/bin/python" -DFISHCAM_TEST_INSTALLED_PACKAGE=ON
# Debian's CMake first on PATH (the first cmake may be another): pip's build uses it.
# CMAKE_BUILD_PARALLEL_LEVEL: pip's CMake build on every core (it builds serially otherwise).
PATH=/usr/bin:$PATH CMAKE_BUILD_PARALLEL_LEVEL="$(nproc)" build/venv/bin/python -m pip install --quiet --no-deps --disable-pip-version-check . 2>&1 |
  { grep -v "^WARNING: Location 'file:" || true; }
# Every test carries a label (tests/CMakeLists.txt): selections go by label.
if /usr/bin/ctest --test-dir build -N -LE . | grep -q "Test *#"; then
  echo "test.sh: tests without a label:" >&2
  /usr/bin/ctest --test-dir build -N -LE . | grep "Test *#" >&2
  exit 1
fi
# What skipped, and why (tests that read ../shared's real files skip without it): the
# Python tests append theirs to skipped-python.txt (python/tests/conftest.py), CTest
# lists the C++ ones.
rm -f build/tests/skipped-python.txt
status=0
/usr/bin/ctest --test-dir build --output-on-failure -j "$(nproc)" | tee build/tests/ctest-output.txt || status=$?
cpp_skipped=$(grep -c "(Skipped)" build/tests/ctest-output.txt || true)
python_skipped=0
[ -f build/tests/skipped-python.txt ] && python_skipped=$(wc -l < build/tests/skipped-python.txt)
shared_state="present"
[ -d ../shared/data ] || shared_state="absent: the tests of real files skip"
echo "test.sh: skipped: $cpp_skipped C++ tests (listed above), $python_skipped Python tests (../shared $shared_state)"
if [ "$python_skipped" -gt 0 ]; then
  cut -f2 build/tests/skipped-python.txt | sort | uniq -c | sort -rn | sed 's/^/test.sh:   /'
fi
exit "$status"
