#!/usr/bin/env bash
# The main job on bundled data: render the bundled street scene through the
# WoodScape front camera, augment it as in the paper's Fig. 5 and with the
# small/medium/large presets, and write contact sheets to fishcam-demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/build.sh >/dev/null
# fishcam-demo/ is the demo's own folder: a second run replaces its contact sheets.
build/tools/fishcam demo --out fishcam-demo --force
