#!/usr/bin/env bash
# Outputs that a refactoring must leave byte-identical: the bundled sample's main job
# (calibration JSON, coloured PLY, textured meshes, overlays) and a real road scan
# (../shared/datasets/road-pinhole: calibration from tests/data/road_pairs.csv, colouring with
# and without occlusion, a mesh). Writes OUT_DIR/SHA256SUMS; compare two runs with
#   diff A/SHA256SUMS B/SHA256SUMS
# Input paths are written into calib.json and model.glb: compare runs made into the same OUT_DIR.
# Usage: golden.sh SCANCAM_BINARY OUT_DIR
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
scancam="$1"
out="$2"
road="${SCANCAM_DATASETS:-$root/../shared/datasets}/road-pinhole"
mkdir -p "$out"
bash "$root/scripts/demo.sh" "$scancam" "$out/sample" >"$out/sample.log"
if [ -d "$road" ]; then
  r="$out/road"
  mkdir -p "$r"
  "$scancam" calibrate --scan "$road/scan.pcd" --camera "$road/camera-intrinsic.json" \
    --image "$road/image.png" --pairs "$root/tests/data/road_pairs.csv" \
    --out "$r/calib.json" >"$r/calibrate.log"
  "$scancam" colorize --scan "$road/scan.pcd" --camera "$road/camera-intrinsic.json" \
    --image "$road/image.png" --calib "$road/reference-extrinsic.json" \
    --out "$r/coloured.ply" --mesh "$r/model.obj" --overlay "$r/overlay.png" >"$r/colorize.log"
  "$scancam" colorize --scan "$road/scan.pcd" --camera "$road/camera-intrinsic.json" \
    --image "$road/image.png" --calib "$road/reference-extrinsic.json" --no-occlusion \
    --out "$r/coloured_no_occlusion.ply" >"$r/colorize_no_occlusion.log"
fi
cd "$out"
find . -type f ! -name '*.log' ! -name SHA256SUMS | LC_ALL=C sort | xargs sha256sum >SHA256SUMS
echo "$(wc -l <SHA256SUMS) files hashed into $out/SHA256SUMS"
