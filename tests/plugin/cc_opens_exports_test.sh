#!/usr/bin/env bash
# The real CloudCompare (-SILENT, no X server) opens what `scancam colorize` exports: the
# textured OBJ (with its MTL and texture: every triangle, the texture coordinates and the
# materials) and the coloured PLY (every point, with its RGB and the scancam_state and quality
# fields, which CloudCompare saves back out).
# Usage: cc_opens_exports_test.sh SCANCAM_CLI WORKDIR
set -euo pipefail
cli="$1"; work="$2"
rm -rf "$work"; mkdir -p "$work/home" "$work/run"; chmod 700 "$work/run"
sim="$work/sim"
"$cli" simulate --out "$sim" --quiet
cli_out=$("$cli" colorize --scan "$sim/scan.txt" --camera "$sim/camera.txt" --image "$sim/image.png" \
  --mask "$sim/mask.png" --calib "$sim/ground_truth.json" --out "$work/coloured.ply" \
  --mesh "$work/model.obj" 2>&1)
triangles=$(echo "$cli_out" | sed -n 's/^mesh: \([0-9]*\) triangles.*/\1/p')
coloured=$(echo "$cli_out" | sed -n 's/^total: coloured \([0-9]*\) .*/\1/p')
[ -n "$triangles" ] && [ -n "$coloured" ] || { echo "$cli_out"; echo "FAIL: no counts from the CLI"; exit 1; }

cc() {
  HOME="$work/home" XDG_RUNTIME_DIR="$work/run" QT_QPA_PLATFORM=offscreen \
    timeout 300 CloudCompare -SILENT -AUTO_SAVE OFF -NO_TIMESTAMP "$@"
}
fail() { echo "$out"; echo "FAIL: $1"; exit 1; }

out=$(cc -O "$work/model.obj" 2>&1) || fail "CloudCompare could not open model.obj"
echo "$out" | grep -F "[OBJ]"
echo "$out" | grep -q "model.obj' loaded successfully" || fail "model.obj not loaded"
echo "$out" | grep -q "\[OBJ\] [0-9]* points, $triangles faces" || fail "not $triangles faces"
texcoords=$(echo "$out" | sed -n 's/^\[OBJ\] \([0-9]*\) tex. coords.*/\1/p')
[ "${texcoords:-0}" -gt 0 ] || fail "no texture coordinates"
echo "$out" | grep -q "\[OBJ\] [1-9][0-9]* materials loaded" || fail "no material (MTL) loaded"
echo "$out" | grep -qi "error\|cannot\|failed" && fail "CloudCompare reported an error"

out=$(cc -O "$work/coloured.ply" -C_EXPORT_FMT PLY -PLY_EXPORT_FMT ASCII \
  -SAVE_CLOUDS FILE "$work/resaved.ply" 2>&1) || fail "CloudCompare could not open coloured.ply"
echo "$out" | grep -q "coloured.ply' loaded successfully" || fail "coloured.ply not loaded"
# CloudCompare strips the "scalar_" prefix when it loads a field and adds it back on saving.
header=$(sed -n '1,/end_header/p' "$work/resaved.ply")
echo "$header" | grep -q "property uchar red" || fail "no colours after CloudCompare's round trip"
echo "$header" | grep -q "property .* scalar_scancam_state$" || fail "scancam_state field lost"
echo "$header" | grep -q "property .* scalar_quality$" || fail "quality field lost"
# Points CloudCompare kept with scancam_state = 3 (coloured) = the CLI's count.
cols=$(echo "$header" | grep -c "^property")
state_col=$(echo "$header" | grep "^property" | grep -n "scalar_scancam_state$" | cut -d: -f1)
n3=$(sed '1,/end_header/d' "$work/resaved.ply" | awk -v c="$state_col" -v n="$cols" \
  'NF == n && $c + 0 == 3 { k++ } END { print k + 0 }')
[ "$n3" = "$coloured" ] || fail "CloudCompare sees $n3 coloured points, the CLI said $coloured"
echo "OK: CloudCompare opened model.obj ($triangles faces, $texcoords texture coordinates) and" \
  "coloured.ply ($n3 coloured points, colours and fields kept)"
