#!/usr/bin/env bash
# Installs every Debian bookworm package ScanCam needs to build, test and run.
# Non-interactive and idempotent: packages already installed are left alone.
# Also fetches the CloudCompare 2.11.3 source package (headers only; Debian ships
# none) into third_party/cloudcompare-src, from Debian's archive.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive

PKGS=(
  build-essential cmake ninja-build ccache pkg-config dpkg-dev git
  libeigen3-dev libceres-dev libgoogle-glog-dev
  libopencv-dev libopencv-contrib-dev
  libpcl-dev libvtk9-dev
  qtbase5-dev libqt5opengl5-dev qttools5-dev-tools libqt5svg5-dev
  libmrpt-dev libopengv-dev zlib1g-dev
  cloudcompare
  libtiff-dev libjpeg-dev nlohmann-json3-dev libtinygltf-dev libpugixml-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  xvfb xauth openbox xdotool x11-apps imagemagick clang-format
  clang libclang-rt-14-dev libomp-14-dev
)

missing=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "[install-deps] installing: ${missing[*]}"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "[install-deps] all ${#PKGS[@]} packages already installed"
fi

bash "$here/scripts/fetch-cloudcompare-src.sh"
