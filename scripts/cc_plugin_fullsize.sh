#!/usr/bin/env bash
# The plugin on a full-size scan in the real CloudCompare (issue 17 item 4), driven like a user
# (Xvfb + openbox + xdotool, scripts/cc_gui_session.sh): open the calibration window on the
# cloud, switch BA tabs, zoom and pan a BA view, load the simulator's camera, image and pairs,
# calibrate, Apply colours. Screenshots of the whole screen are taken every 0.5 s while the
# window opens, while a tab is drawn and while the colours are applied (CloudCompare's
# progress dialog must be on them), and after each step. Times printed: from the click (key)
# to the last of the plugin's progress dialogs closing, seen from outside (polled every
# 0.1-0.5 s, screenshots included); the plugin's own figures ("[ScanCam] Window opened in
# ...", "[ScanCam] Apply colours: ...") are in CloudCompare's console (the last screenshots).
#
# Usage: scripts/cc_plugin_fullsize.sh SIM_DIR CLOUD_FILE PLUGIN.so WORK
#   SIM_DIR     a `scancam simulate --camera pinhole` folder (camera.yaml, image.png, pairs.csv)
#   CLOUD_FILE  its scan as CloudCompare opens it with the grid (the PTX, or a BIN saved from it)
# Screenshots go to WORK/shots. The display is the first free one from $CC_GUI_FIRST_DISPLAY.
# CC_FULLSIZE_OPEN_ONLY=1 stops once the window has opened (the window's figures are in the
# status bar of 2_opened.png); CC_LOAD_WAIT_S the seconds given to CloudCompare to load.
set -euo pipefail
sim="$1"; cloud="$2"; plugin="$3"; work="$4"
source "$(dirname "${BASH_SOURCE[0]}")/cc_gui_session.sh"
rm -rf "$work"
mkdir -p "$work/shots"
trap cc_gui_stop EXIT
cc_gui_start "$work" "$plugin" 1600x1000 "$cloud"

fail() {
  echo "FAIL: $*"
  import -window root "$work/shots/failure.png" || true
  exit 1
}
now() { date +%s.%N; }
since() { echo "$(now) - $1" | bc; }
# A visible progress dialog of the plugin (CloudCompare's ccProgressDialog, titled by the step).
busy() {
  xdotool search --onlyvisible --name \
    "^ScanCam: |^Scan view|^Laser edges|^Bearing-Angle|^Visibility|^Calibrat|^Alignment check" >/dev/null 2>&1
}
# Screenshots every 0.5 s under the name PREFIX_N.png until no progress dialog has been seen
# for 2 s (after one was seen, or 10 s without any); at most 300 s.
shots_while_busy() {
  local prefix="$1" n=0 idle=0 seen=0 polls_per_half_s=1
  [ "${CC_FULLSIZE_SHOTS:-1}" = 1 ] || polls_per_half_s=5
  for _ in $(seq $((600 * polls_per_half_s))); do
    if busy; then seen=1; idle=0; else idle=$((idle + 1)); fi
    # 2 s without a dialog after one, 10 s when none came (polls of 0.5 s, or 0.1 s)
    [ $seen = 1 ] && [ $idle -ge $((4 * polls_per_half_s)) ] && return 0
    [ $seen = 0 ] && [ $idle -ge $((20 * polls_per_half_s)) ] && return 0
    if [ "${CC_FULLSIZE_SHOTS:-1}" = 1 ]; then
      import -window root "$work/shots/${prefix}_$(printf %03d $n).png" 2>/dev/null || true
      n=$((n + 1))
      sleep 0.5
    else
      sleep 0.1
    fi
  done
  fail "a progress dialog stayed for 300 s"
}
main="$(wait_window "CloudCompare v")" || fail "CloudCompare's main window did not appear"
xdotool windowmove "$main" 0 0
xdotool windowsize "$main" 1600 1000
echo "== waiting for the cloud to load (${CC_LOAD_WAIT_S:-20} s)"
sleep "${CC_LOAD_WAIT_S:-20}"
import -window root "$work/shots/0_loaded.png"

echo "== select the cloud, open the calibration window"
open_scancam_window || true
t0="$cc_click_time"
[ -n "$win" ] || fail "the calibration window did not open"
echo "   window shown after $(since "$t0") s"
shots_while_busy 1_opening
echo "   window ready (no progress dialog for 2 s) after $(since "$t0") s, minus those 2 s"
xdotool windowmove "$win" 150 0
xdotool windowsize "$win" 1400 850
sleep 2
import -window root "$work/shots/2_opened.png"
if [ "${CC_FULLSIZE_OPEN_ONLY:-0}" = 1 ]; then
  echo "== CC_FULLSIZE_OPEN_ONLY=1: stopping after the window opened (2_opened.png)"
  exit 0
fi

echo "== the +45 deg BA tab (its picture is made when shown)"
xdotool windowactivate --sync "$win"
t0="$(now)"
# Tabs: horizontal, vertical, +45, -45, range, intensity along the top of the central area.
xdotool mousemove --window "$win" 247 99 click 1
shots_while_busy 3_tab
echo "   tab ready after $(since "$t0") s, minus 2 s (or 10 s when no dialog came)"
import -window root "$work/shots/3_tab.png"

echo "== zoom in 8 wheel steps on the BA view, pan, zoom out"
xdotool mousemove --window "$win" 450 400
t0="$(now)"
for _ in $(seq 8); do xdotool click 4; done
import -window root "$work/shots/4_zoomed.png"
echo "   8 wheel steps and a screenshot: $(since "$t0") s"
t0="$(now)"
xdotool mousedown 1 mousemove_relative 200 120 mouseup 1
import -window root "$work/shots/4_panned.png"
echo "   a pan and a screenshot: $(since "$t0") s"
t0="$(now)"
for _ in $(seq 8); do xdotool click 5; done
import -window root "$work/shots/4_unzoomed.png"
echo "   8 wheel steps back and a screenshot: $(since "$t0") s"

echo "== camera, image, pairs; calibrate"
open_file "$win" ctrl+shift+o "Camera file" "$sim/camera.yaml"
open_file "$win" ctrl+o "Camera image" "$sim/image.png"
open_file "$win" ctrl+l "Load pairs" "$sim/pairs.csv"
xdotool windowactivate --sync "$win"
xdotool key Escape ctrl+Return
sleep 8
import -window root "$work/shots/5_calibrated.png"

shots_while_busy 5_calibrating
echo "== Apply colours"
xdotool windowactivate --sync "$win"
t0="$(now)"
xdotool key ctrl+shift+a
shots_while_busy 6_applying
echo "   colours applied (no progress dialog for 2 s) after $(since "$t0") s, minus those 2 s"
sleep 3
import -window root "$work/shots/7_applied.png"
xdotool windowminimize "$win"
sleep 5
import -window root "$work/shots/8_cloud.png"
xdotool windowactivate --sync "$win"
sleep 1
import -window root "$work/shots/9_window.png"
