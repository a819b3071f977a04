#!/usr/bin/env bash
# CTest `report_page_in_chromium` (label cli): a calibration's report (calibrate
# --report, on synthetic corners of a 1280x966 camera) opened in headless Chromium
# (Debian's package): the page loads with every figure decoded, as its own script
# counts them into <body data-figures-loaded>; with a figure removed, the page says
# so. Usage: tests/test_report_page.sh FISHCAM WORK_DIR. Exits 77 (skipped) without
# Chromium; scripts/install-deps.sh installs it.
set -euo pipefail
fishcam=$1
work=$(realpath -m "$2")
root=$(cd "$(dirname "$0")/.." && pwd)
browser=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$browser" ]; then
  echo "report_page_in_chromium: skipped: no chromium (scripts/install-deps.sh installs it)"
  exit 77
fi
rm -rf "$work" && mkdir -p "$work"
"$fishcam" synth-corners "$root/data/woodscape_front.json" --boards 10 --noise 0.2 --seed 2 --board 8x6 \
  --spacing 0.05 --out "$work/c.vnl" >/dev/null
"$fishcam" calibrate --corners "$work/c.vnl" --board 8x6 --spacing 0.05 --imagersize 1280x966 \
  --model kannala-brandt --theta-limit data --out "$work/kb.json" --report "$work/report" >/dev/null
# The DOM after the page's load event (a virtual-time budget lets every image load).
body() {
  HOME="$work" timeout 120 "$browser" --headless --no-sandbox --disable-gpu --no-first-run \
    --user-data-dir="$work/profile" --virtual-time-budget=10000 --dump-dom "file://$work/report/index.html" \
    2>"$work/chromium.log" | tee "$work/dom.html" | grep -o '<body[^>]*>'
}
tag=$(body)
figures=$(sed -n 's/.*data-figures="\([0-9]*\)".*/\1/p' <<<"$tag")
loaded=$(sed -n 's/.*data-figures-loaded="\([0-9]*\)".*/\1/p' <<<"$tag")
pngs=$(find "$work/report" -name '*.png' | wc -l)
echo "report_page_in_chromium: $loaded of $figures figures loaded ($pngs PNG files)"
[ "$figures" -eq "$pngs" ] && [ "$figures" -ge 16 ] && [ "$loaded" = "$figures" ] || exit 1
rm "$work/report/coverage.png"
body >/dev/null
grep -q "1 of $figures figures did not load" "$work/dom.html" || { echo "no note of the missing figure"; exit 1; }
echo "report_page_in_chromium: with coverage.png removed the page says so"
