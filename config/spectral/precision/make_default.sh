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
# A config with no sRGB space (tests/ocio/not_srgb.ocio): its question measures IEC 61966-2-1's
# values of the 8-bit codes, as it does for every config whose sRGB mixes channels (an ACES config's,
# through AP0), so that those get a shipped answer too (spectral/precision.h, PrecisionRequest::codes).
# The default's grid, and 380:780:5, the grid it stored before (the documented way back to it); the
# shipped config's codes and the formula's.
for grid in default 380:780:5; do
  for config in shipped "$root/tests/ocio/not_srgb.ocio"; do
    opts=(); [ "$grid" = default ] || opts=(--wavelengths "$grid")
    [ "$config" = shipped ] || opts+=(--config "$config")
    SPECTEX_DATA_DIR="$tmp/config" SPECTEX_CACHE_DIR="$tmp/cache" OCIO= \
      "$spectex" bake "$root/examples/textures/colour_chart.png" -o "$tmp/chart.exr" -q "${opts[@]}"
  done
done
entries=("$tmp"/cache/precision-*)
[ ${#entries[@]} -eq 4 ] && [ -f "${entries[0]}" ] || { echo "make_default.sh: expected four precision entries in the cache" >&2; exit 1; }
rm -f "$here"/precision-*
for e in "${entries[@]}"; do
  key=$(sed -n 's/^key //p' "$e")
  case "$key" in precision-[0-9a-f]*) ;; *) echo "make_default.sh: no key in $e" >&2; exit 1 ;; esac
  cp "$e" "$here/$key"
  echo "$here/$key"
done
