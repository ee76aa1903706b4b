#!/usr/bin/env bash
# The real CloudCompare (-SILENT, no X server) with the qScanCamIO plugin opens spinning-lidar
# files it cannot open alone (Debian builds no PCL plugin):
#   - road-pinhole/scan.pcd (ring field): a 64-row grid with intensity, every point of the
#     file (its POINTS: the file has no NaN point) exported to ASCII;
#   - KITTI velodyne.bin: every 16-byte record a point;
#   - a CloudCompare BIN file still opens with CloudCompare's own BIN filter;
#   - a 17-byte .bin: exit code 1 and the core's message, no crash.
# Usage: cc_opens_lidar_test.sh IO_PLUGIN.so DATASETS_DIR WORKDIR
set -euo pipefail
io_plugin="$1"; data="$2"; work="$3"
rm -rf "$work"; mkdir -p "$work/home" "$work/run" "$work/xdg/CCCorp/CloudCompare/plugins"
chmod 700 "$work/run"
cp "$io_plugin" "$work/xdg/CCCorp/CloudCompare/plugins/"
cc() {
  HOME="$work/home" XDG_DATA_HOME="$work/xdg" XDG_RUNTIME_DIR="$work/run" QT_QPA_PLATFORM=offscreen \
    timeout 300 CloudCompare -SILENT -AUTO_SAVE OFF -NO_TIMESTAMP "$@"
}
fail() { echo "${out:-}"; echo "FAIL: $1"; exit 1; }

pcd="$data/road-pinhole/scan.pcd"
n=$(sed -n 's/^POINTS \([0-9]*\)$/\1/p' "$pcd" | head -1)
[ -n "$n" ] || fail "no POINTS in $pcd"
out=$(cc -O "$pcd" -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE "$work/road.asc" 2>&1) ||
  fail "CloudCompare could not open $pcd"
echo "$out" | grep -q "\[PCD\] scan.pcd: 64 rows x [0-9]* columns, .*, intensity" ||
  fail "no console line for a 64-row grid with intensity"
[ "$(wc -l < "$work/road.asc")" = "$n" ] || fail "road.asc has $(wc -l < "$work/road.asc") points, the PCD $n"

bin="$data/kitti-000000/velodyne.bin"
nk=$(( $(stat -c %s "$bin") / 16 ))
out=$(cc -O "$bin" -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE "$work/kitti.asc" 2>&1) ||
  fail "CloudCompare could not open $bin"
echo "$out" | grep -q "\[KITTI\] velodyne.bin: 64 rows x" || fail "KITTI not a 64-row grid"
[ "$(wc -l < "$work/kitti.asc")" = "$nk" ] || fail "kitti.asc has $(wc -l < "$work/kitti.asc") points, the file $nk"

# CloudCompare's own BIN files still open (handed to its BIN filter).
out=$(cc -O "$bin" -C_EXPORT_FMT BIN -SAVE_CLOUDS FILE "$work/kitti_cc.bin" 2>&1) ||
  fail "CloudCompare could not save a BIN file"
out=$(cc -O "$work/kitti_cc.bin" -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE "$work/kitti_cc.asc" 2>&1) ||
  fail "CloudCompare could not reopen its own BIN file"
[ "$(wc -l < "$work/kitti_cc.asc")" = "$nk" ] || fail "its own BIN file lost points"

head -c 17 "$bin" > "$work/odd.bin"
set +e
out=$(cc -O "$work/odd.bin" 2>&1); rc=$?
set -e
[ "$rc" = 1 ] || fail "odd.bin: exit code $rc, not 1"
echo "$out" | grep -q "odd.bin.*16" || fail "odd.bin: no plain message"
echo "OK: CloudCompare opened road-pinhole/scan.pcd ($n points, 64 rows) and velodyne.bin ($nk" \
  "points, 64 rows), still opens its own BIN files, and refused a 17-byte .bin"
