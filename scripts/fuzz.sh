#!/usr/bin/env bash
# Coverage-guided fuzzing of every reader with libFuzzer (clang), under ASan and
# UBSan. The whole library is instrumented for coverage (-fsanitize=fuzzer-no-link),
# not only the harness: without it libFuzzer saw 45 edges and fuzzed blind.
#
# Per harness: SECONDS (default 60) with inputs up to 64 KiB, then SECONDS/4 with
# inputs up to the readers' 16 MiB limit, each input limited to 10 s and the process
# to 1 GiB (the readers stay under 256 MB; ASan adds its share). The corpus found
# is minimised (-merge=1) into tests/fuzz/corpus/HARNESS/, which is kept in the
# repository and replayed by CTest on every run; commit what it adds. Findings go
# to build-fuzz/findings/HARNESS/: turn each into a regression reproducer under
# tests/fuzz/regressions/. The last lines give each harness's coverage.
#   scripts/fuzz.sh [SECONDS] [HARNESS ...]   harnesses: camera, camera_FORMAT for every
#   format of lib/io/include/fishcam/io/camera_format_list.hpp, corners npy stdin_records
#   correspondence_csv
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
seconds=${1:-60}
shift || true
harnesses=("$@")
failed=()
coverage=()
# The formats, from the library's one list of them.
mapfile -t formats < <(grep -o 'X([a-z0-9_]*)' lib/io/include/fishcam/io/camera_format_list.hpp | sed 's/X(\(.*\))/\1/')
[ ${#harnesses[@]} -eq 0 ] && harnesses=(camera "${formats[@]/#/camera_}" corners npy stdin_records correspondence_csv)
sanitize="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
/usr/bin/cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DFISHCAM_FUZZ=ON -DFISHCAM_BUILD_PYTHON=OFF -DFISHCAM_BUILD_TOOLS=OFF \
  -DCMAKE_CXX_FLAGS="$sanitize -fsanitize=fuzzer-no-link" >/dev/null
/usr/bin/cmake --build build-fuzz -j "$(nproc)" --target $(printf 'fuzz_%s ' "${harnesses[@]}")
# "#N DONE cov: C ft: F corp: K/..." -> "C edges, F features, K inputs"
final_coverage() { grep -E "^#[0-9]+[[:space:]]+DONE" "$1" | tail -1 | sed -E 's/.*cov: ([0-9]+) ft: ([0-9]+) corp: ([0-9]+).*/\1 edges, \2 features, \3 inputs/'; }
for h in "${harnesses[@]}"; do
  work=build-fuzz/corpus/$h findings=build-fuzz/findings/$h kept=tests/fuzz/corpus/$h
  mkdir -p "$work" "$findings" "$kept"
  case $h in
    camera*) seeds=(data tests/fuzz/seeds/camera tests/fuzz/regressions/camera) ;;
    *) seeds=(tests/fuzz/seeds/$h tests/fuzz/regressions/$h) ;;
  esac
  echo "fuzz: $h for ${seconds}s (64 KiB inputs), then $((seconds / 4 + 1))s (up to 16 MiB)"
  options=(-timeout=10 -rss_limit_mb=1024 -malloc_limit_mb=1024 -artifact_prefix="$findings/" -print_final_stats=1)
  # A finding stops that harness, not the run: the others still get their time.
  if ! build-fuzz/tests/fuzz/fuzz_"$h" "$work" "$kept" "${seeds[@]}" -max_total_time="$seconds" -max_len=65536 \
         "${options[@]}" >"build-fuzz/$h.log" 2>&1 ||
     ! build-fuzz/tests/fuzz/fuzz_"$h" "$work" -max_total_time="$((seconds / 4 + 1))" -max_len=16777216 \
         -len_control=0 "${options[@]}" >"build-fuzz/$h.large.log" 2>&1; then
    failed+=("$h")
    grep -h -m1 -E "^(multi-line|SUMMARY|==[0-9]+== ERROR)" "build-fuzz/$h.log" "build-fuzz/$h.large.log" 2>/dev/null || true
  fi
  # Minimised into the repository's corpus: only inputs that add coverage, at most 64 KiB each.
  rm -rf "build-fuzz/merged/$h" && mkdir -p "build-fuzz/merged/$h"
  build-fuzz/tests/fuzz/fuzz_"$h" -merge=1 -max_len=65536 "build-fuzz/merged/$h" "$kept" "$work" \
    >"build-fuzz/$h.merge.log" 2>&1 || true
  if [ -n "$(ls -A "build-fuzz/merged/$h")" ]; then
    rm -rf "$kept" && mv "build-fuzz/merged/$h" "$kept"
  fi
  coverage+=("$h: $(final_coverage "build-fuzz/$h.log" || true); $(ls "$kept" | wc -l) inputs kept")
done
printf 'fuzz: coverage %s\n' "${coverage[@]}"
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: findings in ${failed[*]} (build-fuzz/findings/HARNESS/, logs build-fuzz/HARNESS*.log)" >&2
  exit 1
fi
