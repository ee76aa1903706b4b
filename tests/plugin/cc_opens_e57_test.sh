#!/usr/bin/env bash
# The real CloudCompare (-SILENT, no X server) with the qScanCamIO plugin (beside qScanCam, in a
# throw-away per-user plugin folder) opens E57 files:
#   - the coloured E57 that `scancam colorize --e57` writes: every point (the count `scancam
#     e57-info` gives), its 360 x 361 grid, colours and intensity exported to ASCII;
#   - saves it back as E57 (-C_EXPORT_FMT E57): the same scan (points, fields, grid bounds), and
#     reopened it exports the very same ASCII (points, colours, intensity, colour-valid flags);
#   - a dataset E57 without grid indices (every record kept);
#   - a file with a CRC mismatch: exit code 1 and the core's message, no crash.
# Usage: cc_opens_e57_test.sh SCANCAM_CLI IO_PLUGIN.so STD_PLUGIN.so DATASETS_E57_DIR WORKDIR
set -euo pipefail
cli="$1"; io_plugin="$2"; std_plugin="$3"; e57dir="$4"; work="$5"
rm -rf "$work"; mkdir -p "$work/home" "$work/run" "$work/xdg/CCCorp/CloudCompare/plugins"
chmod 700 "$work/run"
cp "$io_plugin" "$std_plugin" "$work/xdg/CCCorp/CloudCompare/plugins/"
cc() {
  HOME="$work/home" XDG_DATA_HOME="$work/xdg" XDG_RUNTIME_DIR="$work/run" QT_QPA_PLATFORM=offscreen \
    timeout 300 CloudCompare -SILENT -AUTO_SAVE OFF -NO_TIMESTAMP "$@"
}
fail() { echo "${out:-}"; echo "FAIL: $1"; exit 1; }
# "N points" of scan 0 and its invalid-colour count, from the CLI.
points_of() { "$cli" e57-info "$1" | sed -n 's/^  scan 0: .*, \([0-9]*\) points,.*/\1/p'; }

sim="$work/sim"
"$cli" simulate --out "$sim" --quiet
"$cli" colorize --scan "$sim/scan.txt" --camera "$sim/camera.txt" --image "$sim/image.png" \
  --mask "$sim/mask.png" --calib "$sim/ground_truth.json" --e57 "$work/coloured.e57" >/dev/null 2>&1
n=$(points_of "$work/coloured.e57")
[ -n "$n" ] && [ "$n" -gt 1000 ] || fail "no point count from scancam e57-info"

out=$(cc -O "$work/coloured.e57" -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE "$work/coloured.asc" 2>&1) ||
  fail "CloudCompare could not open coloured.e57"
echo "$out" | grep -q "New file extensions registered: .*E57" || fail "the E57 filter is not registered"
echo "$out" | grep -q "Plugin found: ScanCam (camera" || fail "qScanCam not loaded beside qScanCamIO"
echo "$out" | grep -q "coloured.e57' loaded successfully" || fail "coloured.e57 not loaded"
echo "$out" | grep -q "\[E57\] .*: $n points, grid 360 x 361 (the file's row/column indices), intensity, colours" ||
  fail "not $n points on the file's 360 x 361 grid with intensity and colours"
lines=$(wc -l < "$work/coloured.asc")
[ "$lines" = "$n" ] || fail "the ASCII export has $lines points, the file $n"
# x y z r g b, then the scalar fields (Intensity, E57 colour valid)
cols=$(awk 'NR == 1 { print NF }' "$work/coloured.asc")
[ "$cols" -ge 7 ] || fail "the ASCII export has $cols columns: colours or intensity missing"
awk '$4 < 0 || $4 > 255 || $6 < 0 || $6 > 255 { bad++ } END { exit bad > 0 }' "$work/coloured.asc" ||
  fail "colour values out of range"

out=$(cc -O "$work/coloured.e57" -C_EXPORT_FMT E57 -SAVE_CLOUDS FILE "$work/resaved.e57" 2>&1) ||
  fail "CloudCompare could not save as E57"
info_a=$("$cli" e57-info "$work/coloured.e57" | grep "^  scan 0")
info_b=$("$cli" e57-info "$work/resaved.e57" | grep "^  scan 0")
[ "$info_a" = "$info_b" ] || fail "resaved.e57 differs: '$info_b' (was '$info_a')"
# Reopened, it exports the very same points, colours, intensities and colour-valid flags.
out=$(cc -O "$work/resaved.e57" -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE "$work/resaved.asc" 2>&1) ||
  fail "CloudCompare could not reopen resaved.e57"
cmp -s "$work/coloured.asc" "$work/resaved.asc" || fail "resaved.e57 does not export as coloured.e57"

out=$(cc -O "$e57dir/bunnyFloat.e57" -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE "$work/bunny.asc" 2>&1) ||
  fail "CloudCompare could not open bunnyFloat.e57"
nb=$(points_of "$e57dir/bunnyFloat.e57")
[ "$(wc -l < "$work/bunny.asc")" = "$nb" ] || fail "bunnyFloat.e57: not its $nb points"

set +e
out=$(cc -O "$e57dir/bad-crc.e57" 2>&1); rc=$?
set -e
[ "$rc" = 1 ] || fail "bad-crc.e57: exit code $rc, not 1"
echo "$out" | grep -q "bad-crc.e57:byte 0: CRC mismatch in page 0" || fail "bad-crc.e57: no plain message"
echo "OK: CloudCompare opened coloured.e57 ($n points, 360 x 361 grid, colours, intensity)," \
  "saved it back as E57 unchanged ($info_b), opened bunnyFloat.e57 ($nb points) and refused" \
  "bad-crc.e57 with the core's message"
