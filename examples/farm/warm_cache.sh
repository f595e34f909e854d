#!/bin/bash
# Fills spectex's cache once, before a farm array starts, so that no task pays for the answers
# that depend only on the settings: the grid search of --wavelengths auto (some 25 s), the bits of
# --precision auto for settings other than the default bake's (some 30 s; the default's ship with
# spectex) and the method's table. It bakes the bundled chart with the array's own options into a
# temporary file and throws the file away; the answers stay in the cache.
#
#   SPECTEX_CACHE_DIR=/shared/spectex-cache examples/farm/warm_cache.sh [BAKE OPTIONS...]
#
# Give it exactly the options the array's tasks get (the answers are keyed by them), and let the
# tasks see the same cache: SPECTEX_CACHE_DIR exported to them (sbatch exports the environment by
# default) and naming a folder every node reads at the same path (a shared filesystem). Entries
# are written atomically, so tasks may read it while another writes. SPECTEX names the binary.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
chart=$here/../textures/colour_chart.png
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"${SPECTEX:-spectex}" bake "$chart" -o "$tmp/warm.exr" -q "$@"
echo "spectex: the cache holds the answers for: $*" >&2
