#!/usr/bin/env bash
# The tree's style, one line length (120) for both languages:
#   C++     .clang-format (clang-format 14, Debian's clang-format-14)
#   Python  pyproject.toml's [tool.ruff] (ruff, python/requirements-test.txt)
#   Both    no function over 80 lines in the library, the CLI, the bindings and the
#           package (lizard, python/requirements-test.txt; tests are exempt)
# scripts/style.sh [--fix] [PYTHON]   checks (CTest entry `style`), or with --fix
# rewrites the files; PYTHON is the interpreter whose ruff runs (default: the
# virtual environment scripts/python-env.sh makes, build/venv).
set -euo pipefail
cd "$(dirname "$0")/.."
fix=0
if [ "${1:-}" = --fix ]; then fix=1; shift; fi
python=${1:-build/venv/bin/python}
clang_format=$(command -v clang-format-14 || true)
if [ -z "$clang_format" ]; then
  echo "style: clang-format-14 not found (scripts/install-deps.sh installs it)" >&2
  exit 1
fi
for tool in ruff lizard; do
  if ! "$python" -m "$tool" --version >/dev/null 2>&1; then
    echo "style: $python has no $tool (scripts/python-env.sh installs python/requirements-test.txt)" >&2
    exit 1
  fi
done
mapfile -t cpp < <(git ls-files '*.cpp' '*.hpp')
status=0
if [ "$fix" = 1 ]; then
  "$clang_format" -i "${cpp[@]}"
  "$python" -m ruff check --fix --quiet . || status=1
  "$python" -m ruff format --quiet .
else
  "$clang_format" --dry-run --Werror "${cpp[@]}" || status=1
  "$python" -m ruff check --quiet . || status=1
  "$python" -m ruff format --check --quiet . || status=1
fi
# Function length is not rewritten by --fix: a long function is split by hand.
"$python" -m lizard --length 80 --CCN 100000 --arguments 100 --warnings_only -x '*/tests/*' \
  lib tools python/src python/fishcam || status=1
[ "$status" = 0 ] && echo "style: ${#cpp[@]} C++ files and the Python tree as .clang-format and pyproject.toml say, no function over 80 lines"
exit "$status"
