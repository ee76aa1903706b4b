# Sourced (bash): the real CloudCompare GUI on a virtual X server, for scripts that drive it
# like a user (scripts/screenshots.sh, tests/plugin/cc_window_keys_test.sh).
#
#   cc_gui_start WORK PLUGIN_SO SCREEN FILE...
#       throw-away HOME, XDG_DATA_HOME (the plugin installed there) and XDG_RUNTIME_DIR under
#       WORK; Xvfb on a free display of size SCREEN (e.g. 1600x1000) with openbox; then
#       CloudCompare opening the FILEs (its output in WORK/cc.log). Exports DISPLAY, HOME, XDG_*.
#       The display is the first free one from $CC_GUI_FIRST_DISPLAY (default 91) on.
#   cc_gui_stop          kills what cc_gui_start started (call it from the caller's EXIT trap)
#   wait_window REGEX    prints the id of a visible window whose title matches (waits <= 2 min)
#   shot_root ARGS...    the whole screen through convert (ARGS: options, then the output file)
#   shot_window ID ARGS  one window (popups and Qt windows come out black in root captures)
#   open_scancam_window  selects the cloud (second row of the DB tree) and presses the plugin's
#                        toolbar button until the calibration window opens; sets `win` (its
#                        id) and `cc_click_time` (date +%s.%N of the click that opened it)
#   open_file WIN KEYS TITLE PATH  a file through the Qt dialog the shortcut KEYS raises
# (positions: a fresh CloudCompare profile, main window at 0,0 sized 1600x1000).
# Needs: Xvfb, openbox, xdotool, xwd, ImageMagick's convert, CloudCompare.
cc_gui_pids=()
cc_gui_convert=/usr/bin/convert
[ -x "$cc_gui_convert" ] || cc_gui_convert="$(command -v convert || true)"

cc_gui_start() {
  local work="$1" plugin="$2" screen="$3" tool disp
  shift 3
  for tool in Xvfb openbox xdotool xwd CloudCompare "$cc_gui_convert"; do
    command -v "$tool" >/dev/null || { echo "cc_gui_start: $tool is not installed" >&2; return 1; }
  done
  mkdir -p "$work/home" "$work/xdg/CCCorp/CloudCompare/plugins" "$work/run"
  chmod 700 "$work/run"
  cp "$plugin" "$work/xdg/CCCorp/CloudCompare/plugins/"
  disp="${CC_GUI_FIRST_DISPLAY:-91}"
  while [ -e "/tmp/.X${disp}-lock" ] || [ -e "/tmp/.X11-unix/X${disp}" ]; do
    disp=$((disp + 1))
  done
  export DISPLAY=":$disp"
  unset QT_QPA_PLATFORM WAYLAND_DISPLAY  # the virtual X server, not offscreen
  Xvfb "$DISPLAY" -screen 0 "${screen}x24" -nolisten tcp >"$work/xvfb.log" 2>&1 &
  cc_gui_pids+=($!)
  for _ in $(seq 100); do xdotool getmouselocation >/dev/null 2>&1 && break; sleep 0.1; done
  HOME="$work/home" openbox >"$work/openbox.log" 2>&1 &
  cc_gui_pids+=($!)
  sleep 1
  export HOME="$work/home" XDG_DATA_HOME="$work/xdg" XDG_RUNTIME_DIR="$work/run"
  (cd "$work" && exec CloudCompare "$@") >"$work/cc.log" 2>&1 &
  cc_gui_pids+=($!)
}

cc_gui_stop() {
  local i
  for ((i = ${#cc_gui_pids[@]} - 1; i >= 0; i--)); do kill "${cc_gui_pids[$i]}" 2>/dev/null || true; done
  wait 2>/dev/null || true
}

wait_window() {
  local id=""
  for _ in $(seq 600); do  # up to 2 min: a loaded machine starts CloudCompare slowly
    id="$(xdotool search --onlyvisible --name "$1" 2>/dev/null | tail -1)" || true
    [ -n "$id" ] && { echo "$id"; return 0; }
    sleep 0.2
  done
  echo "no window '$1' appeared" >&2
  return 1
}

shot_root() { xwd -root -silent | "$cc_gui_convert" xwd:- "$@"; }
shot_window() { local id="$1"; shift; xwd -id "$id" -silent | "$cc_gui_convert" xwd:- "$@"; }

open_scancam_window() {
  win=""
  for _ in $(seq 120); do
    xdotool mousemove 175 138 click 1
    # CloudCompare redraws its 3D view when the selection changes: with a large cloud in
    # software OpenGL that takes seconds, and a click meanwhile waits (CC_SELECT_WAIT_S).
    sleep "${CC_SELECT_WAIT_S:-0.3}"
    cc_click_time="$(date +%s.%N)"
    xdotool mousemove 1219 61 click 1
    # Wait for the window before clicking again: openbox may place it under that spot, and a
    # second click there would press its "Camera file..." button (a modal dialog then blocks).
    # 12 s: a 50 M-point cloud's grid takes seconds before the window is created (a second
    # click then would also restart the caller's clock, cc_click_time).
    for _ in $(seq 60); do
      win="$(xdotool search --onlyvisible --name "ScanCam calibration" 2>/dev/null | tail -1)" || true
      [ -z "$win" ] || return 0
      sleep 0.2
    done
  done
  return 1
}

open_file() {
  local win="$1" keys="$2" title="$3" path="$4" dlg
  xdotool windowactivate --sync "$win"
  xdotool key "$keys"
  dlg="$(wait_window "$title")"
  xdotool windowactivate --sync "$dlg"
  xdotool type --delay 5 "$path"
  xdotool key Return
  sleep 1
}
