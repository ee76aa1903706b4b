#!/usr/bin/env bash
# Runs the libFuzzer harnesses (fuzz/, README "Fuzzing") one after the other and prints, per
# harness, the executions, executions per second, time and what was found.
#
#   scripts/fuzz.sh [--build-dir DIR] [--no-build] [--fresh] [--seconds N | --runs N]
#                   [--seed N] [--keep-going] [--nice] [HARNESS...]
#
#   --build-dir DIR  the clang build (default: build-fuzz); configured and built here unless
#                    --no-build (SCANCAM_FUZZ_JOBS build jobs, default: all cores)
#   --seconds N      time per harness (default 60); --runs N: executions per harness instead
#   --fresh          start each harness's corpus from the seeds alone (CI); by default the
#                    corpus grown by earlier runs (DIR/fuzz/corpus/HARNESS) is kept
#   --seed N         libFuzzer's random seed (CI: 1, so that a brief run explores the same
#                    inputs on every machine); default: a new one per run
#   --keep-going     do not stop at the first finding: libFuzzer's fork mode (-fork=1
#                    -ignore_crashes/timeouts/ooms), every finding saved (for long campaigns)
#   --nice           run the harnesses under nice -n 10
#   HARNESS...       default: every harness
# Seeds: DIR/fuzz/seeds, made by fuzz_make_seeds when missing. Findings (crash-*, timeout-*,
# oom-*, leak-* reproducers) go to DIR/fuzz/artifacts/HARNESS/; a harness's log to
# DIR/fuzz/logs/HARNESS.log. Results (tab-separated) are appended to DIR/fuzz/results.tsv.
# Exit status 1 when any harness found something.
# A finding counts: crash / sanitizer report, exception other than scancam::Error, more than
# 10 s for one input (-timeout=10), more than 2 GB RSS (-rss_limit_mb=2048).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$root/build-fuzz"
do_build=1
fresh=0
seconds=60
runs=""
seed_opt=()
keep_going=()
nice_cmd=()
harnesses=()
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) build="$(cd "$2" 2>/dev/null && pwd || echo "$2")"; shift 2 ;;
    --no-build) do_build=0; shift ;;
    --fresh) fresh=1; shift ;;
    --seconds) seconds="$2"; runs=""; shift 2 ;;
    --runs) runs="$2"; shift 2 ;;
    --seed) seed_opt=(-seed="$2"); shift 2 ;;
    --keep-going) keep_going=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1); shift ;;
    --nice) nice_cmd=(nice -n 10); shift ;;
    -h|--help) sed -n '2,24p' "$0"; exit 0 ;;
    -*) echo "fuzz.sh: unknown option $1" >&2; exit 2 ;;
    *) harnesses+=("$1"); shift ;;
  esac
done
all=(fuzz_ptx fuzz_rotating_log fuzz_pcd fuzz_pcd_organised fuzz_rawlog fuzz_pairs_csv
     fuzz_camera_opencv_yaml fuzz_camera_opencv_json fuzz_camera_ocamcalib fuzz_camera_kalibr
     fuzz_camera_ros fuzz_camera_opencalib fuzz_calibration_json fuzz_image fuzz_float_tiff
     fuzz_kitti fuzz_e57)
[ ${#harnesses[@]} -gt 0 ] || harnesses=("${all[@]}")

if [ "$do_build" = 1 ]; then
  export CCACHE_BASEDIR="$root" CCACHE_NOHASHDIR=1
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
        -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DSCANCAM_BUILD_FUZZERS=ON \
        -DSCANCAM_FUZZ_COVERAGE=ON -DSCANCAM_BUILD_PLUGIN=OFF -DSCANCAM_BUILD_BENCH=OFF \
        -DSCANCAM_BUILD_TOOLS=OFF >/dev/null
  cmake --build "$build" -j"${SCANCAM_FUZZ_JOBS:-$(nproc)}" --target fuzzers
fi
fdir="$build/fuzz"
if [ ! -d "$fdir/seeds" ]; then
  "$fdir/fuzz_make_seeds" "$fdir/seeds" "$root" "$root/../shared/datasets"
fi
mkdir -p "$fdir/logs"

# UBSan aborts on the first report (the build has -fno-sanitize-recover=undefined); ASan's leak
# check stays on (a leak is a finding).
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
export ASAN_OPTIONS="abort_on_error=0${ASAN_OPTIONS:+:$ASAN_OPTIONS}"

status=0
printf '%-26s %12s %9s %8s  %s\n' harness executions exec/s seconds result
for h in "${harnesses[@]}"; do
  bin="$fdir/$h"
  [ -x "$bin" ] || { echo "fuzz.sh: $bin is not built" >&2; exit 2; }
  corpus="$fdir/corpus/$h"
  art="$fdir/artifacts/$h"
  [ "$fresh" = 1 ] && rm -rf "$corpus"
  mkdir -p "$corpus" "$art" "$fdir/seeds/$h"
  limit=(-max_total_time="$seconds")
  [ -n "$runs" ] && limit=(-runs="$runs")
  log="$fdir/logs/$h.log"
  # Findings of this run: the reproducers written after it started (moving older ones away
  # while it runs does not change the count).
  marker="$fdir/logs/$h.started"
  touch "$marker"
  start=$(date +%s.%N)
  rc=0
  "${nice_cmd[@]}" "$bin" "${limit[@]}" "${seed_opt[@]}" "${keep_going[@]}" -timeout=10 -rss_limit_mb=2048 \
      -print_final_stats=1 -artifact_prefix="$art/" "$corpus" "$fdir/seeds/$h" >"$log" 2>&1 || rc=$?
  end=$(date +%s.%N)
  secs=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.0f", b - a }')
  # Executions: the final stats (normal mode) or the last status line "#N" (fork mode).
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  [ -n "$execs" ] || execs=$(sed -n 's/^#\([0-9]*\)[: \t].*/\1/p' "$log" | tail -1)
  [ -n "$execs" ] || execs=0
  rate=$(awk -v n="$execs" -v s="$secs" 'BEGIN { printf "%.0f", (s > 0 ? n / s : 0) }')
  found=$(find "$art" -maxdepth 1 -type f -newer "$marker" | wc -l)
  if [ "$rc" = 0 ] && [ "$found" = 0 ]; then
    result="clean"
  else
    status=1
    what=$(grep -m1 -o 'ERROR: [A-Za-z]*: [^(]*\|ERROR: libFuzzer: [a-z-]*\|runtime error: .*\|fuzz harness: .*' "$log" || true)
    result="FOUND $found (exit $rc): ${what:-see $log}; newest: $art/$(ls -t "$art" | head -1)"
  fi
  printf '%-26s %12s %9s %8s  %s\n' "$h" "$execs" "$rate" "$secs" "$result"
  printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$(date -u +%FT%TZ)" "$h" "$execs" "$rate" "$secs" \
      "$result" >>"$fdir/results.tsv"
  if [ "$rc" != 0 ] && [ ${#keep_going[@]} = 0 ]; then
    # The report's first lines and the project's frames (the whole report is in the log).
    { grep -m1 'ERROR\|runtime error\|fuzz harness' "$log"
      grep -E '^ *#[0-9]+ .*(/core/|/fuzz/|/usr/include/)' "$log" | head -12
      grep -m1 '^SUMMARY' "$log"; } | cut -c1-240 >&2 || true
  fi
done
exit $status
