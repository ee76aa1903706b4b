#!/usr/bin/env bash
# The README's first command: install every dependency, build, install the
# `scancam` CLI and the CloudCompare plugin for this user, and run the main job
# on the bundled sample. Idempotent; safe to run again.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/install-deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
# ccache: paths relative to the checkout, so a fresh clone elsewhere hits the cache.
export CCACHE_BASEDIR="$root" CCACHE_NOHASHDIR=1
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$HOME/.local"
cmake --build build -j"$jobs"
cmake --install build
echo "[setup] installed: $HOME/.local/bin/scancam and the qScanCam and qScanCamIO (E57) plugins in" \
     "$(grep -E '^SCANCAM_PLUGIN_INSTALL_DIR' build/CMakeCache.txt | cut -d= -f2)"
bash scripts/demo.sh "$root/build/core/scancam" "$root/out/sample"
