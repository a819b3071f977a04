#!/usr/bin/env bash
# CTest `wheel_installs_anywhere` (label install): scripts/wheel.sh's repaired wheel
# installed into a fresh virtual environment without system site-packages (numpy from
# PyPI), then tests/wheel_check.py there with an empty environment (no
# LD_LIBRARY_PATH, no PYTHONPATH) and the manylinux policy's list of the system
# libraries a wheel may assume. Usage: tests/test_wheel.sh WORK_DIR
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(realpath -m "$1")
rm -rf "$work" && mkdir -p "$work"
wheel=$("$root/scripts/wheel.sh" "$work/wheelhouse" | tee /dev/stderr | tail -1)
policy=$(basename "$wheel" | sed -n 's/.*-\(manylinux_[0-9]*_[0-9]*\)_x86_64\.whl$/\1/p')
[ -n "$policy" ] || { echo "test_wheel: $wheel has no manylinux tag" >&2; exit 1; }
# The system libraries that policy lets a wheel assume (auditwheel's own table).
whitelist=$("$root/build/venv/bin/python" -c '
import json, os, sys, auditwheel.policy as p
policies = json.load(open(os.path.join(os.path.dirname(p.__file__), "manylinux-policy.json")))
print(",".join(next(x["lib_whitelist"] for x in policies if x["name"] == sys.argv[1])))' "$policy")
/usr/bin/python3 -m venv "$work/venv"
"$work/venv/bin/python" -m pip install --quiet --disable-pip-version-check "$wheel"
cd "$work"
env -i PATH=/usr/bin:/bin HOME="${HOME:-/tmp}" "$work/venv/bin/python" -I "$root/tests/wheel_check.py" "$root/data" "$whitelist"
