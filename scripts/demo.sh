#!/usr/bin/env bash
# The main job on bundled data: describe the WoodScape front camera, then send two
# camera-frame points (one 109.5 deg off-axis, behind the image plane) through
# project and back through unproject. The second lands above the image (v < 0):
# outside the picture, inside the model's valid domain.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/build.sh >/dev/null
camera=data/woodscape_front.json
echo "== fishcam info $camera"
build/tools/fishcam info "$camera"
echo
echo "== points -> fishcam project -> fishcam unproject"
points=$'1 0.5 2\n1 -1 -0.5'
pixels=$(printf '%s\n' "$points" | build/tools/fishcam project "$camera")
rays=$(printf '%s\n' "$pixels" | build/tools/fishcam unproject "$camera")
paste -d '|' <(printf '%s\n' "$points") <(printf '%s\n' "$pixels") <(printf '%s\n' "$rays") |
  awk -F'|' '{ printf "point %-12s -> pixel %s -> ray %s\n", $1, $2, $3 }'
