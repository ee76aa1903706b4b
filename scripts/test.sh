#!/usr/bin/env bash
# The README's second command: install every dependency, build everything and
# run every test (the Release build with the plugin, then the core again under
# AddressSanitizer + UndefinedBehaviorSanitizer, then the libFuzzer harnesses briefly).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/install-deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
# ccache: paths relative to the checkout, so a fresh clone elsewhere hits the cache.
export CCACHE_BASEDIR="$root" CCACHE_NOHASHDIR=1

echo "== Release build, all tests =="
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$HOME/.local"
cmake --build build -j"$jobs"
(cd build && ctest --output-on-failure -j"$jobs")

if [ "${SCANCAM_SKIP_SANITIZERS:-0}" != "1" ]; then
  echo "== ASan + UBSan build, core tests =="
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSCANCAM_SANITIZE=ON \
        -DSCANCAM_BUILD_PLUGIN=OFF -DSCANCAM_BUILD_BENCH=OFF -DSCANCAM_BUILD_TOOLS=OFF
  cmake --build build-asan -j"$jobs"
  # LeakSanitizer on: the whole core suite runs leak-free (tests/sanitizers/lsan.supp is for
  # third-party allocations, should one ever need suppressing; it is empty).
  export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0"
  export LSAN_OPTIONS="suppressions=$root/tests/sanitizers/lsan.supp:print_suppressions=0"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
  (cd build-asan && ctest --output-on-failure -j"$jobs")
fi

if [ "${SCANCAM_SKIP_FUZZ:-0}" != "1" ]; then
  echo "== libFuzzer harnesses (clang, ASan + UBSan), brief runs =="
  cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
        -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DSCANCAM_BUILD_FUZZERS=ON \
        -DSCANCAM_BUILD_TESTS=OFF -DSCANCAM_BUILD_PLUGIN=OFF -DSCANCAM_BUILD_BENCH=OFF \
        -DSCANCAM_BUILD_TOOLS=OFF
  cmake --build build-fuzz -j"$jobs" --target fuzzers
  (cd build-fuzz && ctest -L fuzz --output-on-failure)
fi
