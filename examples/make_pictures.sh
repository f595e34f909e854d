#!/bin/sh
# Regenerates the pictures of the README and docs/inspecting.md (docs/images/) from
# examples/textures/colour_chart.png with the built binary. Run from the repository root:
#   examples/make_pictures.sh [path/to/spectex]
# Same bytes each run for the same build (no timestamps are written).
set -eu
SPECTEX=$(realpath "${1:-build/src/spectex}")
root=$(pwd)
out=$root/docs/images
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT INT TERM
cd "$tmp"  # relative names, so that no temporary path ends up in the pictures

# The bake every picture is made from (defaults: 31 bins 400-700 nm, half, ZIP).
"$SPECTEX" bake "$root/examples/textures/colour_chart.png" -o colour_chart.exr --quiet

# The chart under daylight, tungsten and a narrow-band fluorescent, each white-balanced to D65.
"$SPECTEX" render colour_chart.exr --illuminant D65,A,FL11 -o "$out/colour_chart_D65_A_FL11.png" --quiet

# Three patches of its bottom half: the white grey patch, ColorChecker orange and blue flower,
# with illuminant A's spectrum behind.
"$SPECTEX" plot colour_chart.exr --pixel 40,175 --pixel 40,240 --pixel 383,208 --light A \
    --title "colour_chart.png, baked: three patches" -o "$out/colour_chart_spectra.svg" --quiet

ls -l "$out"
