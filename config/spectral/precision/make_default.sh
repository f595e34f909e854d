#!/usr/bin/env bash
# Writes the default bake's --precision auto answers (its grid, and 380:780:5) into this folder, under the name of the request
# it answers (config/spectral/precision/README.md). Run after any change that changes the answer
# (the lattice, the rounding, the chooser): tests/cli/precision_test.cpp fails until it is.
#
#   config/spectral/precision/make_default.sh [SPECTEX_BINARY]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
spectex=${1:-$root/build/src/spectex}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# A copy of the data without the shipped answers, and an empty cache: the bits are chosen afresh.
cp -r "$root/config" "$tmp/config"
rm -rf "$tmp/config/spectral/precision"
# The default's grid, and 380:780:5, the grid it stored before (the documented way back to it).
for grid in default 380:780:5; do
  opts=(); [ "$grid" = default ] || opts=(--wavelengths "$grid")
  SPECTEX_DATA_DIR="$tmp/config" SPECTEX_CACHE_DIR="$tmp/cache" \
    "$spectex" bake "$root/examples/textures/colour_chart.png" -o "$tmp/chart.exr" -q "${opts[@]}"
done
entries=("$tmp"/cache/precision-*)
[ ${#entries[@]} -eq 2 ] && [ -f "${entries[0]}" ] || { echo "make_default.sh: expected two precision entries in the cache" >&2; exit 1; }
rm -f "$here"/precision-*
for e in "${entries[@]}"; do
  key=$(sed -n 's/^key //p' "$e")
  case "$key" in precision-[0-9a-f]*) ;; *) echo "make_default.sh: no key in $e" >&2; exit 1 ;; esac
  cp "$e" "$here/$key"
  echo "$here/$key"
done
