#!/usr/bin/env bash
# Headless end to end: the real CloudCompare (-SILENT, no X server) opens the simulator's PTX,
# calibrates with -SCANCAM_CALIB from the simulator's pairs, colours the cloud with
# -SCANCAM_COLORIZE and saves it; the colours are checked against the simulator's truth.
# -AUTO_SAVE ON saves the coloured cloud (and names the file), OFF writes nothing. Then the
# error paths: a camera / image size mismatch and a missing option make CloudCompare
# exit 1 with a message naming the problem (and nothing crashes). -PARAMS reads the colour
# options file; a bad one is refused naming the file and the key.
# Usage: cc_colorize_test.sh SCANCAM_CLI PLUGIN.so CHECKER WORKDIR
set -euo pipefail
cli="$1"; plugin="$2"; checker="$3"; work="$4"
rm -rf "$work"; mkdir -p "$work/home" "$work/xdg/CCCorp/CloudCompare/plugins" "$work/run"
cp "$plugin" "$work/xdg/CCCorp/CloudCompare/plugins/"
sim="$work/sim"
# --dropout 0: with random dropouts, the PTX reader (io/ptx.h) gives no-return cells beam
# directions from per-column azimuth / per-row elevation medians, which do not fit the
# simulated rotating scanner's grid, and Colourise then hides about a third of the visible points
# (`scancam colorize --scan scan.ptx` does the same; the rotating log scan.txt does not). That is
# a core matter; this test checks the plugin's path.
"$cli" simulate --out "$sim" --supersample 2 --dropout 0 --quiet

cc() {
  HOME="$work/home" XDG_DATA_HOME="$work/xdg" XDG_RUNTIME_DIR="$work/run" \
    QT_QPA_PLATFORM=offscreen timeout 300 CloudCompare -SILENT -AUTO_SAVE OFF -NO_TIMESTAMP "$@"
}

echo "== calibrate + colour in one CloudCompare run"
set +e
out=$(cc -O "$sim/scan.ptx" \
  -SCANCAM_CALIB -CAMERA "$sim/camera.txt" -PAIRS "$sim/pairs.csv" -OUT "$work/calib.json" \
    -IMAGE "$sim/image.png" \
  -SCANCAM_COLORIZE -CAMERA "$sim/camera.txt" -IMAGE "$sim/image.png" -CALIB "$work/calib.json" \
    -MASK "$sim/mask.png" \
  -C_EXPORT_FMT PLY -PLY_EXPORT_FMT ASCII -SAVE_CLOUDS FILE "$work/coloured.ply" 2>&1)
rc=$?
set -e
echo "$out" | grep -F "[ScanCam]" || true
if [ $rc -ne 0 ] || [ ! -s "$work/coloured.ply" ] || [ ! -s "$work/calib.json" ]; then
  echo "$out"; echo "FAIL: CloudCompare exit $rc or missing output"; exit 1
fi
# Colours right on >= 90 % of the truly visible points also means the calibration is right.
"$checker" "$work/coloured.ply" "$sim/truth.csv" 0.9 30

echo "== -AUTO_SAVE ON: the coloured cloud is saved beside the input and the file is named"
ptx_sum=$(md5sum < "$sim/scan.ptx")
set +e
out=$(cc -AUTO_SAVE ON -C_EXPORT_FMT PLY -O "$sim/scan.ptx" \
  -SCANCAM_COLORIZE -CAMERA "$sim/camera.txt" -IMAGE "$sim/image.png" -CALIB "$work/calib.json" 2>&1)
rc=$?
set -e
written=$(echo "$out" | sed -n 's/.*\[ScanCam\] wrote \(.*\) (-AUTO_SAVE OFF.*/\1/p' | head -1)
if [ $rc -ne 0 ] || [ -z "$written" ] || [ ! -s "$written" ]; then
  echo "$out"; echo "FAIL: expected '[ScanCam] wrote FILE' naming a saved file (exit $rc)"; exit 1
fi
case "$written" in *SCANCAM_COLORIZED*) ;; *) echo "FAIL: unexpected name $written"; exit 1;; esac
[ "$(md5sum < "$sim/scan.ptx")" = "$ptx_sum" ] || { echo "FAIL: the input PTX changed"; exit 1; }
echo "wrote $written"
echo "== -AUTO_SAVE OFF: nothing written, and it says so"
before=$(ls "$sim" | wc -l)
out=$(cc -O "$sim/scan.ptx" \
  -SCANCAM_COLORIZE -CAMERA "$sim/camera.txt" -IMAGE "$sim/image.png" -CALIB "$work/calib.json" 2>&1)
echo "$out" | grep -q "coloured in memory (-AUTO_SAVE OFF)" || {
  echo "$out"; echo "FAIL: no message about -AUTO_SAVE OFF"; exit 1; }
[ "$(ls "$sim" | wc -l)" = "$before" ] || { echo "FAIL: a file was written with -AUTO_SAVE OFF"; exit 1; }

echo "== -PARAMS: the colour options file (the window's File > Save colour options)"
occluded() { echo "$1" | sed -n 's/.*points coloured, \([0-9]*\) occluded.*/\1/p' | head -1; }
default_occluded=$(occluded "$out")
printf '{"scancam": "colour options", "version": 1, "occlusion": false}\n' > "$work/no-occlusion.json"
out=$(cc -O "$sim/scan.ptx" -SCANCAM_COLORIZE -CAMERA "$sim/camera.txt" -IMAGE "$sim/image.png" \
  -CALIB "$work/calib.json" -PARAMS "$work/no-occlusion.json" 2>&1)
echo "$out" | grep -F "[ScanCam]" | head -3
echo "$out" | grep -q "colour options from .*no-occlusion.json" || {
  echo "$out"; echo "FAIL: -PARAMS not read"; exit 1; }
# Without the z-buffer no point is occluded; with the defaults some are.
if [ -z "$default_occluded" ] || [ "$default_occluded" -eq 0 ] || [ "$(occluded "$out")" != 0 ]; then
  echo "$out"; echo "FAIL: occluded $default_occluded by default, $(occluded "$out") with occlusion off"
  exit 1
fi
printf '{"edge_fill": -1}\n' > "$work/bad-params.json"
set +e
out=$(cc -O "$sim/scan.ptx" -SCANCAM_COLORIZE -CAMERA "$sim/camera.txt" -IMAGE "$sim/image.png" \
  -CALIB "$work/calib.json" -PARAMS "$work/bad-params.json" 2>&1)
rc=$?
set -e
if [ $rc -ne 1 ] || ! echo "$out" | grep -q "bad-params.json.*'edge_fill'.*must be >= 0"; then
  echo "$out"; echo "FAIL: expected exit 1 naming bad-params.json and edge_fill (got $rc)"; exit 1
fi
echo "$out" | grep "bad-params.json" | head -1

echo "== size mismatch: an error, exit 1"
printf 'P5\n4 3\n255\n%012d' 0 > "$work/small.pgm"
set +e
out=$(cc -O "$sim/scan.ptx" -SCANCAM_COLORIZE -CAMERA "$sim/camera.txt" -IMAGE "$work/small.pgm" \
  -CALIB "$work/calib.json" 2>&1)
rc=$?
set -e
if [ $rc -ne 1 ] || ! echo "$out" | grep -q "small.pgm.*4x3"; then
  echo "$out"; echo "FAIL: expected exit 1 and a message naming small.pgm (got $rc)"; exit 1
fi
echo "$out" | grep "small.pgm" | head -2

echo "== missing option: an error, exit 1"
set +e
out=$(cc -O "$sim/scan.ptx" -SCANCAM_COLORIZE -CAMERA "$sim/camera.txt" -IMAGE "$sim/image.png" 2>&1)
rc=$?
set -e
if [ $rc -ne 1 ] || ! echo "$out" | grep -q "missing option -CALIB"; then
  echo "$out"; echo "FAIL: expected exit 1 and 'missing option -CALIB' (got $rc)"; exit 1
fi
echo "$out" | grep "missing option" | head -1
echo "OK"
