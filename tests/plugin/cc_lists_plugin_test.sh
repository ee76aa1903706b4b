#!/usr/bin/env bash
# The real CloudCompare (headless, -SILENT) finds and loads the plugin from a
# throw-away per-user plugin folder. Usage: cc_lists_plugin_test.sh PLUGIN.so WORKDIR
set -euo pipefail
plugin="$1"; work="$2"
rm -rf "$work"; mkdir -p "$work/home" "$work/xdg/CCCorp/CloudCompare/plugins"
cp "$plugin" "$work/xdg/CCCorp/CloudCompare/plugins/"
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n' > "$work/t.ply"
out=$(HOME="$work/home" XDG_DATA_HOME="$work/xdg" XDG_RUNTIME_DIR="$work" QT_QPA_PLATFORM=offscreen \
      timeout 120 CloudCompare -SILENT -AUTO_SAVE OFF -O "$work/t.ply" 2>&1) || {
  echo "$out"; echo "CloudCompare failed"; exit 1; }
echo "$out" | grep -F "Plugin found: ScanCam" || { echo "$out"; echo "plugin not listed"; exit 1; }
