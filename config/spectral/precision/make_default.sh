#!/usr/bin/env bash
# Writes the default bake's --precision auto answer into this folder, under the name of the request
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
SPECTEX_DATA_DIR="$tmp/config" SPECTEX_CACHE_DIR="$tmp/cache" \
  "$spectex" bake "$root/examples/textures/colour_chart.png" -o "$tmp/chart.exr" -q
entries=("$tmp"/cache/precision-*)
[ ${#entries[@]} -eq 1 ] && [ -f "${entries[0]}" ] || { echo "make_default.sh: expected one precision entry in the cache" >&2; exit 1; }
key=$(sed -n 's/^key //p' "${entries[0]}")
case "$key" in precision-[0-9a-f]*) ;; *) echo "make_default.sh: no key in ${entries[0]}" >&2; exit 1 ;; esac
rm -f "$here"/precision-*
cp "${entries[0]}" "$here/$key"
echo "$here/$key"
