#!/usr/bin/env bash
# Fetches Debian's source package of the installed CloudCompare (headers for the
# plugin build) into third_party/cloudcompare-src. Debian ships no -dev package.
# Idempotent: does nothing when the tree is already there and matches the
# installed version.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
dest="$here/third_party/cloudcompare-src"
want="2.11.3-7.1"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

have=$(dpkg-query -W -f='${Version}' cloudcompare 2>/dev/null || true)
if [ "$have" != "$want" ]; then
  echo "[fetch-cc] error: installed cloudcompare is '$have', the plugin is built for $want" >&2
  exit 1
fi
if [ -f "$dest/debian/changelog" ] && head -1 "$dest/debian/changelog" | grep -q "($want)"; then
  echo "[fetch-cc] CloudCompare $want sources present in $dest"
  exit 0
fi

srcfile=/etc/apt/sources.list.d/scancam-deb-src.sources
cleanup() { $SUDO rm -f "$srcfile"; $SUDO apt-get update -qq || true; }
trap cleanup EXIT
if [ -f /etc/apt/sources.list.d/debian.sources ]; then
  sed 's/^Types:.*/Types: deb-src/' /etc/apt/sources.list.d/debian.sources | $SUDO tee "$srcfile" >/dev/null
else
  grep -h '^deb ' /etc/apt/sources.list | sed 's/^deb /deb-src /' | $SUDO tee "${srcfile%.sources}.list" >/dev/null
  srcfile="${srcfile%.sources}.list"
fi
$SUDO apt-get update -qq
tmp=$(mktemp -d)
(cd "$tmp" && apt-get source -qq --download-only "cloudcompare=$want" && dpkg-source -x --no-check cloudcompare_*.dsc src >/dev/null)
rm -rf "$dest"
mkdir -p "$(dirname "$dest")"
mv "$tmp/src" "$dest"
rm -rf "$tmp"
if ! head -1 "$dest/debian/changelog" | grep -q "($want)"; then
  echo "[fetch-cc] error: $dest/debian/changelog is not version $want" >&2
  exit 1
fi
echo "[fetch-cc] CloudCompare $want sources unpacked into $dest"
