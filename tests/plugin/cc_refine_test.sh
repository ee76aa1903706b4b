#!/usr/bin/env bash
# Headless: the real CloudCompare (-SILENT, no X server) opens the simulator's PTX and refines a
# calibration from the picked pairs with -SCANCAM_REFINE (a small -PARAMS file keeps it short);
# the result must equal `scancam refine` on the same files and lie near the simulator's truth.
# Then the error paths: a missing -INIT file, a bad -PARAMS key, a bad pair noise option
# (-SIGMA_PX -1, -PAIRS_WEIGHT not a number) and no cloud loaded make
# CloudCompare exit 1 with a message naming the problem, and write no -OUT.
# Usage: cc_refine_test.sh SCANCAM_CLI PLUGIN.so CHECKER WORKDIR
set -euo pipefail
cli="$1"; plugin="$2"; checker="$3"; work="$4"
rm -rf "$work"; mkdir -p "$work/home" "$work/xdg/CCCorp/CloudCompare/plugins" "$work/run"
cp "$plugin" "$work/xdg/CCCorp/CloudCompare/plugins/"
sim="$work/sim"
"$cli" simulate --out "$sim" --dropout 0 --quiet
"$cli" calibrate --camera "$sim/camera.txt" --pairs "$sim/pairs.csv" --scan "$sim/scan.ptx" \
  --out "$work/picks.json" --quiet
printf '{"scancam": "refine options", "version": 1, "starts": 2, "max_evaluations": 1500}\n' \
  > "$work/small.json"

cc() {
  HOME="$work/home" XDG_DATA_HOME="$work/xdg" XDG_RUNTIME_DIR="$work/run" \
    QT_QPA_PLATFORM=offscreen timeout 600 CloudCompare -SILENT -AUTO_SAVE OFF -NO_TIMESTAMP "$@"
}

echo "== -SCANCAM_REFINE against scancam refine"
"$cli" refine --camera "$sim/camera.txt" --scan "$sim/scan.ptx" --image "$sim/image.png" \
  --init "$work/picks.json" --params "$work/small.json" --out "$work/cli.json" --quiet
ptx_sum=$(md5sum < "$sim/scan.ptx")
set +e
out=$(cc -O "$sim/scan.ptx" -SCANCAM_REFINE -CAMERA "$sim/camera.txt" -IMAGE "$sim/image.png" \
  -INIT "$work/picks.json" -PARAMS "$work/small.json" -OUT "$work/cc.json" 2>&1)
rc=$?
set -e
echo "$out" | grep -F "[ScanCam]" || true
if [ $rc -ne 0 ] || [ ! -s "$work/cc.json" ]; then
  echo "$out"; echo "FAIL: CloudCompare exit $rc or no -OUT"; exit 1
fi
echo "$out" | grep -q "\[ScanCam\] verdict: " || { echo "FAIL: no verdict printed"; exit 1; }
echo "$out" | grep -q "refine options from .*small.json" || { echo "FAIL: -PARAMS not read"; exit 1; }
[ "$(md5sum < "$sim/scan.ptx")" = "$ptx_sum" ] || { echo "FAIL: the input PTX changed"; exit 1; }
"$checker" "$work/cc.json" "$work/cli.json" "$sim/ground_truth.json" 0.5 0.05

echo "== error paths"
expect_error() {  # expect_error WHAT PATTERN ARGS...: exit 1, the message, no -OUT
  local what="$1" pattern="$2"; shift 2
  rm -f "$work/bad.json"
  set +e
  local o; o=$(cc "$@" 2>&1); local r=$?
  set -e
  if [ $r -eq 0 ] || ! echo "$o" | grep -q -- "$pattern" || [ -e "$work/bad.json" ]; then
    echo "$o"; echo "FAIL ($what): exit $r, expected a message matching '$pattern' and no output"
    exit 1
  fi
  echo "ok ($what): $(echo "$o" | grep -- "$pattern" | head -1)"
}
expect_error "missing -INIT file" "no-such-start.json" -O "$sim/scan.ptx" -SCANCAM_REFINE \
  -CAMERA "$sim/camera.txt" -IMAGE "$sim/image.png" -INIT "$work/no-such-start.json" \
  -OUT "$work/bad.json"
printf '{"scancam": "refine options", "version": 1, "starts": 0}\n' > "$work/bad-params.json"
expect_error "bad -PARAMS" "starts" -O "$sim/scan.ptx" -SCANCAM_REFINE \
  -CAMERA "$sim/camera.txt" -IMAGE "$sim/image.png" -INIT "$work/picks.json" \
  -PARAMS "$work/bad-params.json" -OUT "$work/bad.json"
expect_error "bad -SIGMA_PX" "\-SIGMA_PX: must be >= 0" -O "$sim/scan.ptx" -SCANCAM_REFINE \
  -CAMERA "$sim/camera.txt" -IMAGE "$sim/image.png" -INIT "$work/picks.json" \
  -PAIRS "$sim/pairs.csv" -SIGMA_PX -1 -OUT "$work/bad.json"
expect_error "-PAIRS_WEIGHT not a number" "\-PAIRS_WEIGHT: 'heavy' is not a number" \
  -O "$sim/scan.ptx" -SCANCAM_REFINE -CAMERA "$sim/camera.txt" -IMAGE "$sim/image.png" \
  -INIT "$work/picks.json" -PAIRS "$sim/pairs.csv" -PAIRS_WEIGHT heavy -OUT "$work/bad.json"
expect_error "no cloud" "no point cloud loaded" -SCANCAM_REFINE -CAMERA "$sim/camera.txt" \
  -IMAGE "$sim/image.png" -INIT "$work/picks.json" -OUT "$work/bad.json"
echo "PASS"
