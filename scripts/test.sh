#!/usr/bin/env bash
# The README's second command: install every dependency, build everything and
# run every test: the Release build with the plugin, then one clang build with
# AddressSanitizer + UndefinedBehaviorSanitizer (+ LeakSanitizer) and libFuzzer's
# coverage, in which the core suite runs and then the fuzz harnesses briefly.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/install-deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
# ccache: paths relative to the checkout, so a fresh clone elsewhere hits the cache.
export CCACHE_BASEDIR="$root" CCACHE_NOHASHDIR=1
t0=$SECONDS
stage() { echo "== [$((SECONDS - t0)) s] $*"; }

stage "Release build, all tests"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$HOME/.local"
cmake --build build -j"$jobs"
(cd build && ctest --output-on-failure -j"$jobs")

# One sanitizer build serves both the core suite and the fuzz harnesses (a GCC sanitizer build
# beside a clang fuzz build compiled the core twice and took most of CI's time): clang, ASan +
# UBSan, line tables only; libFuzzer's coverage on the harnesses' own code only
# (SCANCAM_FUZZ_COVERAGE=OFF: on the whole core it slowed the core tests ~1.6x). A fuzzing
# campaign (scripts/fuzz.sh) builds build-fuzz/ with the coverage on.
if [ "${SCANCAM_SKIP_SANITIZERS:-0}" != "1" ] || [ "${SCANCAM_SKIP_FUZZ:-0}" != "1" ]; then
  stage "clang ASan + UBSan build (core, CLI, core tests, fuzz harnesses)"
  cmake -S . -B build-san -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
        -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DSCANCAM_BUILD_FUZZERS=ON \
        -DSCANCAM_FUZZ_COVERAGE=OFF -DSCANCAM_BUILD_TESTS=ON -DSCANCAM_BUILD_PLUGIN=OFF \
        -DSCANCAM_BUILD_BENCH=OFF -DSCANCAM_BUILD_TOOLS=OFF
  cmake --build build-san -j"$jobs"
fi

if [ "${SCANCAM_SKIP_SANITIZERS:-0}" != "1" ]; then
  stage "core tests under ASan + UBSan + LSan"
  # LeakSanitizer on: the whole core suite runs leak-free (tests/sanitizers/lsan.supp is for
  # third-party allocations, should one ever need suppressing; it is empty).
  (cd build-san &&
   ASAN_OPTIONS="detect_leaks=1:abort_on_error=0" \
   LSAN_OPTIONS="suppressions=$root/tests/sanitizers/lsan.supp:print_suppressions=0" \
   UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
   ctest -LE fuzz --output-on-failure -j"$jobs")
fi

if [ "${SCANCAM_SKIP_FUZZ:-0}" != "1" ]; then
  stage "libFuzzer harnesses, brief runs and the findings' replays"
  (cd build-san && ctest -L fuzz --output-on-failure -j"$jobs")
fi
stage "done"
