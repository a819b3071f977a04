#!/usr/bin/env bash
# Installs the Debian packages fishcam needs. Idempotent: installs only what is missing,
# and runs apt-get update only when something must be installed.
set -euo pipefail

packages=(
  cmake g++ make pkg-config ccache
  libeigen3-dev libceres-dev libopencv-dev libopencv-contrib-dev nlohmann-json3-dev
  libmrcal-dev mrcal python3-mrcal python3-numpy python3-opencv
  libcli11-dev libgtest-dev libgmock-dev libbenchmark-dev libtbb-dev
  pybind11-dev python3-pybind11 python3-pytest python3-torch
  libyaml-cpp-dev libpugixml-dev libpng-dev
  libapriltag-dev  # AprilGrid targets (fishcam/augment/aprilgrid.hpp)
  clang libclang-rt-14-dev  # the sanitizer and fuzzing builds
  clang-format-14  # the style check (scripts/style.sh)
  chromium  # the calibration report page opened in a real browser (tests/test_report_page.sh)
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
