#!/usr/bin/env bash
# Screenshots of the qScanCam plugin in the real CloudCompare, driven like a user would: a
# virtual X server (Xvfb) with a window manager (openbox), the plugin in a throw-away
# XDG_DATA_HOME/HOME, the simulator's sample scan opened, and the plugin's menu action, file
# dialogs and buttons operated with xdotool (mouse and keyboard). Writes PNGs to docs/images/.
#
# Usage: scripts/screenshots.sh [BUILD_DIR [OUT_DIR]]   (defaults: build, docs/images)
# Needs: Xvfb, openbox, xdotool, xwd, ImageMagick's convert, CloudCompare 2.11.3, and the built
# `scancam` CLI and plugin in BUILD_DIR. Takes about a minute, plus Refine's (2-3 min on a
# shared 2-core machine).
#
# Screen positions below are those of a fresh CloudCompare profile on a 1600x1000 screen
# (CloudCompare's default layout); every step checks that the window it expects appeared.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
out="${2:-$root/docs/images}"
plugin="$build/plugin/libQSCANCAM_PLUGIN.so"
cli="$build/core/scancam"
source "$root/scripts/cc_gui_session.sh"
[ -n "$cc_gui_convert" ] || { echo "screenshots: no convert"; exit 1; }
[ -f "$plugin" ] || { echo "screenshots: $plugin not built"; exit 1; }
[ -x "$cli" ] || { echo "screenshots: $cli not built"; exit 1; }
mkdir -p "$out"
# Where the blend slider's handle is at its start (value 50), window coordinates.
blend_slider_x=1100
blend_slider_y=583

work="$(mktemp -d /tmp/scancam-shots.XXXXXX)"
trap 'cc_gui_stop; rm -rf "$work"' EXIT

echo "[shots] simulating the sample scene"
# One planted wrong pair: the calibration flags it (red row).
"$cli" simulate --out "$work/sim" --supersample 2 --dropout 0 --wrong-pairs 1 --quiet
cc_gui_start "$work" "$plugin" 1600x1000 "$work/sim/scan.ptx"

main="$(wait_window "CloudCompare v")"
xdotool windowmove "$main" 0 0
xdotool windowsize "$main" 1600 1000
sleep 4  # the PTX file loads
echo "[shots] selecting the cloud and running Plugins > ScanCam > Camera / scanner calibration"
# DB tree: the file's group is the first row, the cloud the second.
xdotool mousemove 175 138 click 1
sleep 1
# The plugin's toolbar button (its icon: icons/scancam.svg).
xdotool mousemove 1219 61 click 1
win="$(wait_window "ScanCam calibration")"
xdotool windowmove "$win" 0 0
xdotool windowsize "$win" 1400 850
sleep 2
shot_window "$win" "$out/scancam_window_empty.png"

echo "[shots] camera file, image, mask and pairs through the file dialogs"
open_file "$win" ctrl+shift+o "Camera file" "$work/sim/camera.txt"
open_file "$win" ctrl+o "Camera image" "$work/sim/image.png"
open_file "$win" ctrl+m "Image mask" "$work/sim/mask.png"
open_file "$win" ctrl+l "Load pairs" "$work/sim/pairs.csv"
# Select a pair in the table: its markers are highlighted on both sides.
xdotool mousemove --window "$win" 60 716 click 1
xdotool mousemove --window "$win" 700 845  # off the buttons (their tips replace the status)
sleep 1
shot_window "$win" "$out/scancam_pairs.png"

echo "[shots] calibrating"
xdotool windowactivate --sync "$win"
xdotool key Escape ctrl+Return
sleep 3
shot_window "$win" "$out/scancam_calibrated.png"
# Zoom the camera image around the whiteboard to judge the laser edges (paper Fig. 8c).
xdotool mousemove --window "$win" 915 215
for _ in 1 2 3 4 5; do xdotool click 4; sleep 0.2; done
sleep 1
shot_window "$win" -crop 680x520+720+70 "$out/scancam_edges_zoom.png"

echo "[shots] applying the colours to the cloud"
xdotool windowactivate --sync "$win"
xdotool key ctrl+shift+a
sleep 4
shot_window "$win" -crop 1400x24+0+826 "$out/scancam_applied_status.png"
xdotool windowminimize "$win"
sleep 1
# Left toolbar: an isometric view of the room; deselect (an empty spot of the DB tree) to hide
# the bounding box; zoom in a little.
xdotool mousemove 20 601 click 1
sleep 1
xdotool mousemove 150 380 click 1
sleep 1
xdotool mousemove 930 480
for _ in 1 2 3; do xdotool click 4; sleep 0.3; done
sleep 2
shot_root "$out/cloudcompare_coloured.png"

echo "[shots] picking the laser side of a pair in the 3D view"
xdotool windowactivate --sync "$win"
sleep 1
xdotool mousemove --window "$win" 505 38
sleep 0.5
xdotool click 1  # "Pick in 3D view"
sleep 1
xdotool windowminimize "$win"
sleep 1
xdotool mousemove 900 560 click 1
sleep 2
# CloudCompare may ask whether to compute an octree for picking: yes, then pick again.
if q="$(xdotool search --onlyvisible --name "Picking acceleration" 2>/dev/null | tail -1)" &&
   [ -n "$q" ]; then
  xdotool windowactivate --sync "$q"
  xdotool key Return
  sleep 3
fi
shot_root "$out/cloudcompare_pick3d.png"
xdotool windowactivate --sync "$win"
sleep 1
shot_window "$win" "$out/scancam_pick3d.png"

echo "[shots] restoring the original colours"
sleep 1
xdotool mousemove --window "$win" 1290 38
sleep 0.5
xdotool click 1  # "Restore colours"
sleep 2
xdotool windowminimize "$win"
sleep 1
shot_root "$out/cloudcompare_restored.png"
echo "[shots] Refine (dense refinement of the pose; a few minutes on a busy machine)"
xdotool windowactivate --sync "$win"
xdotool key ctrl+r
wait_window "^Refine$" >/dev/null
while xdotool search --onlyvisible --name "^Refine$" >/dev/null 2>&1; do sleep 0.5; done
sleep 3
shot_window "$win" "$out/scancam_refined.png"

echo "[shots] blend slider and Before Refine on the zoomed camera image"
# The Photo - Edges slider in the Calibration panel's bar (after Before Refine): a click on its
# handle gives it the focus; Home then 8 x Page Up set it to 80 (photo dimmed, edges at full).
xdotool windowactivate --sync "$win"
xdotool mousemove --window "$win" "$blend_slider_x" "$blend_slider_y" click 1
sleep 0.5
xdotool key Home
for _ in 1 2 3 4 5 6 7 8; do xdotool key Page_Up; sleep 0.1; done
xdotool mousemove --window "$win" 700 845
sleep 1
shot_window "$win" -crop 694x510+706+85 "$out/scancam_refine_after.png"
xdotool key ctrl+b  # Before Refine: the start pose's edges (orange)
sleep 1
shot_window "$win" -crop 694x510+706+85 "$out/scancam_refine_before.png"
xdotool key ctrl+b
grep -F "[ScanCam]" "$work/cc.log" | tail -n 20 || true
echo "[shots] wrote: $(cd "$out" && ls *.png | tr '\n' ' ')"
