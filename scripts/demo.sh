#!/usr/bin/env bash
# The main job on the bundled sample: simulate the sample scene (deterministic),
# render its Bearing-Angle images, calibrate from its pairs file, colour the scan
# and export a textured model and overlays. Usage: demo.sh [SCANCAM_BINARY] [OUT_DIR]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
scancam="${1:-$root/build/core/scancam}"
out="${2:-$root/out/sample}"
mkdir -p "$out"

echo "== 1/4 sample scene (share/sample): office room, rotating 2D scanner, omni camera =="
"$scancam" simulate --out "$out/scene" --seed 7
echo
echo "== 2/4 Bearing-Angle images of the scan =="
"$scancam" ba "$out/scene/scan.txt" --out "$out/ba" --edges --quiet
ls "$out/ba"/*.png | sed 's/^/  /'
echo
echo "== 3/4 calibration from the sample's picked pairs =="
"$scancam" calibrate --scan "$out/scene/scan.txt" --camera "$out/scene/camera.txt" \
  --image "$out/scene/image.png" --mask "$out/scene/mask.png" --pairs "$out/scene/pairs.csv" \
  --out "$out/calib.json" --truth "$out/scene/ground_truth.json" --plot "$out/pairs_plot.png"
echo
echo "== 4/4 colouring, textured model, overlays =="
"$scancam" colorize --scan "$out/scene/scan.txt" --camera "$out/scene/camera.txt" \
  --image "$out/scene/image.png" --mask "$out/scene/mask.png" --calib "$out/calib.json" \
  --out "$out/coloured.ply" --mesh "$out/model.glb" --mesh "$out/model.obj" \
  --overlay "$out/overlay_depth.png" --edge-overlay "$out/overlay_edges.png" \
  --grid-image "$out/coloured_grid.png"
echo
cat <<TXT
Done. Files in $out:
  ba/*.png               Bearing-Angle images (pick pairs on these)
  calib.json             T_cam_scan, errors, parameter std, per-pair residuals
  pairs_plot.png         the pairs on the photo (residuals) and where to pick next
  coloured.ply           the scan coloured from the photo (open in CloudCompare)
  model.obj / model.glb  textured mesh (CloudCompare / Blender or a glTF viewer)
  overlay_edges.png      laser edge points drawn on the photo (judge the calibration)
  overlay_depth.png      all points drawn on the photo, coloured by distance
In CloudCompare: open $out/scene/scan.ptx, select it, Plugins > ScanCam > Camera / scanner
calibration..., choose $out/scene/camera.txt and image.png, pick pairs, Calibrate, Apply colours.
TXT
