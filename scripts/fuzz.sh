#!/usr/bin/env bash
# Coverage-guided fuzzing of every reader with libFuzzer (clang), under ASan and
# UBSan: builds build-fuzz/ and runs each harness for SECONDS (default 60; the
# readers were fuzzed ~3 minutes each for the reliability issue). New findings go
# to build-fuzz/findings/HARNESS/; turn each into a regression reproducer under
# tests/fuzz/regressions/ (CTest replays those on every run).
#   scripts/fuzz.sh [SECONDS] [HARNESS ...]   harnesses: camera, camera_FORMAT for every
#   format (woodscape fishcam mrcal opencv kalibr basalt colmap ros camodocal orbslam3),
#   corners npy stdin_records correspondence_csv
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
seconds=${1:-60}
shift || true
harnesses=("$@")
failed=()
formats=(woodscape fishcam mrcal opencv kalibr basalt colmap ros camodocal orbslam3)
[ ${#harnesses[@]} -eq 0 ] && harnesses=(camera "${formats[@]/#/camera_}" corners npy stdin_records correspondence_csv)
/usr/bin/cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DFISHCAM_FUZZ=ON -DFISHCAM_BUILD_PYTHON=OFF -DFISHCAM_BUILD_TOOLS=OFF \
  -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer" >/dev/null
/usr/bin/cmake --build build-fuzz -j "$(nproc)" --target $(printf 'fuzz_%s ' "${harnesses[@]}")
for h in "${harnesses[@]}"; do
  corpus=build-fuzz/corpus/$h findings=build-fuzz/findings/$h
  mkdir -p "$corpus" "$findings"
  case $h in
    camera*) seeds=(data tests/fuzz/seeds/camera tests/fuzz/regressions/camera) ;;
    *) seeds=(tests/fuzz/seeds/$h tests/fuzz/regressions/$h) ;;
  esac
  echo "fuzz: $h for ${seconds}s"
  # A finding stops that harness, not the run: the others still get their time.
  if ! build-fuzz/tests/fuzz/fuzz_"$h" "$corpus" "${seeds[@]}" -max_total_time="$seconds" -max_len=65536 \
    -rss_limit_mb=4096 -artifact_prefix="$findings/" -print_final_stats=1 >"build-fuzz/$h.log" 2>&1; then
    failed+=("$h")
    grep -m1 -E "^(multi-line|SUMMARY|==[0-9]+== ERROR)" "build-fuzz/$h.log" || true
  fi
  tail -3 "build-fuzz/$h.log"
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: findings in ${failed[*]} (build-fuzz/findings/HARNESS/, logs build-fuzz/HARNESS.log)" >&2
  exit 1
fi
