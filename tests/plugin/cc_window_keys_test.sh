#!/usr/bin/env bash
# The real CloudCompare GUI (Xvfb + openbox, driven with xdotool like a user): the calibration
# window must never act on CloudCompare's data through the keyboard (issue 13, section 1).
#
# With the scan's cloud selected in CloudCompare's DB tree (the plugin needs it), the window
# is opened on it, an image is opened, a pair is picked (a click on the BA view, a click on
# the photo), and Delete is pressed after a click in the BA view, after a click on the photo,
# and in the pairs table with the pair selected. CloudCompare's own Delete (an
# application-wide shortcut) deletes the selected cloud; here:
#   - the cloud stays: the window is not told that its cloud was closed (its title would get
#     "[cloud closed]"), and the DB tree looks the same, pixel for pixel, as before;
#   - Delete in the table removes the selected pair (the autosaved pairs file loses it) and
#     Ctrl+Z brings it back.
# Then a second scan (another PTX loaded beside the first): the window opened on it gets
# nothing of the first scan's (no image in its title; the first scan's pairs file unchanged),
# and opened again on the first scan it gets that scan's image and pairs back.
# Then the control, which shows both checks can fail: Delete in CloudCompare's main window
# with the cloud selected deletes it, the window's title says "[cloud closed]" and the DB
# tree changes.
#
# Usage: cc_window_keys_test.sh SCANCAM_CLI PLUGIN.so WORKDIR
# Screenshots of each step are left in WORKDIR/shots.
set -euo pipefail
cli="$1"; plugin="$2"; work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/../../scripts/cc_gui_session.sh"
rm -rf "$work"
mkdir -p "$work/shots"
trap cc_gui_stop EXIT
"$cli" simulate --out "$work/sim" --supersample 1 --dropout 0 --quiet
# A second scan (another seed: other points), loaded after the first one.
"$cli" simulate --out "$work/sim2" --supersample 1 --dropout 0 --seed 2 --quiet
cp "$work/sim2/scan.ptx" "$work/other.ptx"
image="$work/sim/image.png"
sidecar="$image.scancam-pairs.csv"
cc_gui_start "$work" "$plugin" 2600x1000 "$work/sim/scan.ptx" "$work/other.ptx"

fail() {
  echo "FAIL: $*"
  shot_root "$work/shots/failure.png" || true
  exit 1
}
# A digest of CloudCompare's DB tree (top left of the main window), and a picture of it.
tree_digest() {
  shot_window "$main" -crop 340x330+0+95 +repage "$work/shots/tree_$1.png"
  "$cc_gui_convert" "$work/shots/tree_$1.png" rgb:- | md5sum | cut -d' ' -f1
}
# Complete pairs in the autosaved pairs file (comment and header lines excluded).
pair_count() {
  [ -f "$sidecar" ] || { echo 0; return; }
  grep -v '^#' "$sidecar" | tail -n +2 | grep -c . || true
}
wait_pairs() {
  for _ in $(seq 150); do [ "$(pair_count)" = "$1" ] && return 0; sleep 0.1; done
  fail "expected $1 pair(s) in $sidecar, found $(pair_count)$2"
}
window_title() { xdotool getwindowname "$win"; }
# The cloud is still there: the window was not told otherwise and the DB tree is unchanged.
expect_cloud() {
  case "$(window_title)" in *"cloud closed"*) fail "$1 deleted the cloud (window title)";; esac
  [ "$(tree_digest "$2")" = "$tree_before" ] ||
    fail "$1 changed CloudCompare's DB tree (shots/tree_before.png, shots/tree_$2.png)"
}

main="$(wait_window "CloudCompare v")" || fail "CloudCompare's main window did not appear"
xdotool windowmove "$main" 0 0
xdotool windowsize "$main" 1600 1000
# The PTX loads; the DB tree then shows the file's group and the cloud (second row). Select
# the cloud and press the plugin's toolbar button (scripts/screenshots.sh) until the window
# opens (the button is enabled once a cloud is selected).
echo "== select the cloud, open the calibration window on it"
open_scancam_window || true
[ -n "$win" ] || fail "the calibration window did not open"
xdotool windowmove "$win" 1150 0
xdotool windowsize "$win" 1400 850
# Both files loaded: the DB tree no longer changes.
tree_before="" same=0
for _ in $(seq 120); do
  d="$(tree_digest before)"
  if [ "$d" = "$tree_before" ]; then same=$((same + 1)); else same=0; fi
  tree_before="$d"
  [ $same -ge 4 ] && break
  sleep 0.5
done
shot_root "$work/shots/1_opened.png"

echo "== open the image (Ctrl+O in the window)"
dlg=""
for _ in $(seq 60); do  # the window may still be computing its BA images
  xdotool windowactivate --sync "$win"
  xdotool key ctrl+o
  sleep 0.5
  dlg="$(xdotool search --onlyvisible --name "^Camera image$" 2>/dev/null | tail -1)" || true
  [ -z "$dlg" ] || break
  sleep 1
done
[ -n "$dlg" ] || fail "no file dialog for the image"
xdotool windowactivate --sync "$dlg"
xdotool type --delay 5 "$image"
xdotool key Return
sleep 1.5

# Window-relative spots: the BA view (centre), the photo (right dock), the first table row.
ba_x=300; ba_y=330; photo_x=1050; photo_y=300; row_x=60; row_y=603
echo "== a pair: click on the BA view, then on the photo"
# Until the image is in (a click on the photo before is refused; a second click on the BA view
# only corrects the half-picked pair).
for _ in $(seq 30); do
  xdotool mousemove --window "$win" $ba_x $ba_y click 1
  sleep 0.5
  xdotool mousemove --window "$win" $photo_x $photo_y click 1
  sleep 0.5
  [ "$(pair_count)" = 1 ] && break
done
wait_pairs 1 " after a click on the BA view and one on the photo"

echo "== Delete after a click in the BA view"
xdotool mousemove --window "$win" $((ba_x + 40)) $((ba_y + 20)) click 1  # starts pair 2
sleep 0.5
xdotool key Delete
sleep 1
shot_root "$work/shots/2_delete_in_ba_view.png"
expect_cloud "Delete in the BA view" ba_view
echo "== Delete after a click on the photo"
xdotool mousemove --window "$win" $((photo_x - 60)) $((photo_y + 40)) click 1  # completes pair 2
wait_pairs 2 " after completing pair 2"
xdotool key Delete
sleep 1
expect_cloud "Delete on the photo" photo
[ "$(pair_count)" = 2 ] || fail "Delete without a selected pair changed the pairs"

echo "== Delete in the pairs table removes the selected pair; Ctrl+Z brings it back"
xdotool mousemove --window "$win" $row_x $row_y click 1
sleep 0.5
shot_root "$work/shots/3_pair_selected.png"
xdotool key Delete
wait_pairs 1 " after Delete with pair 1 selected in the table"
expect_cloud "Delete in the pairs table" table
shot_window "$win" "$work/shots/4_pair_deleted.png"
xdotool key ctrl+z
wait_pairs 2 " after Ctrl+Z"
xdotool key ctrl+shift+z
wait_pairs 1 " after Ctrl+Shift+Z"
xdotool key ctrl+z
wait_pairs 2 " after the second Ctrl+Z"
sleep 1
shot_root "$work/shots/5_after_window_keys.png"
expect_cloud "Ctrl+Z / Ctrl+Shift+Z in the window" after_undo
echo "cloud still in the DB tree, title: $(window_title)"

echo "== another scan: nothing of the first one's comes back"
sidecar_sum="$(md5sum < "$sidecar")"
# Opens the window on the cloud at DB-tree row y=$1 and waits for the title to match $2.
open_on() {
  local id=""
  for _ in $(seq 60); do
    xdotool windowactivate --sync "$main"
    xdotool mousemove 175 "$1" click 1
    sleep 0.3
    xdotool mousemove 1219 61 click 1
    sleep 0.7
    id="$(xdotool search --onlyvisible --name "$2" 2>/dev/null | tail -1)" || true
    [ -z "$id" ] || { echo "$id"; return 0; }
  done
  return 1
}
win="$(open_on 178 "ScanCam calibration: other")" || fail "no window on the second cloud"
sleep 3
shot_root "$work/shots/7_other_scan.png"
case "$(window_title)" in *image.png*) fail "the second scan reopened the first one's image";; esac
[ "$(md5sum < "$sidecar")" = "$sidecar_sum" ] || fail "the first scan's pairs file changed"
echo "title on the other scan: $(window_title)"
echo "== the first scan again: its image (and pairs) come back, and the title says which image"
win="$(open_on 138 "ScanCam calibration: scan - Cloud - image.png")" ||
  fail "the first scan did not get its image back"
sleep 1
shot_window "$win" "$work/shots/8_first_scan_again.png"
[ "$(md5sum < "$sidecar")" = "$sidecar_sum" ] || fail "reopening changed the pairs file"
echo "title on the first scan: $(window_title)"

echo "== control: Delete in CloudCompare's main window deletes the cloud, and the window says so"
xdotool windowactivate --sync "$main"
xdotool mousemove 175 138 click 1
sleep 0.5
xdotool key Delete
closed=0
for _ in $(seq 150); do
  case "$(window_title)" in *"cloud closed"*) closed=1; break;; esac
  sleep 0.1
done
sleep 1
tree_control="$(tree_digest control)"
shot_root "$work/shots/6_control_deleted.png"
[ $closed = 1 ] || fail "the window was not told that its cloud was deleted (title: $(window_title))"
[ "$tree_control" != "$tree_before" ] || fail "the DB tree did not change when the cloud was deleted"
echo "title after the control: $(window_title)"
echo "OK"
