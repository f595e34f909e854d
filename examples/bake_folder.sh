#!/usr/bin/env bash
# Bake every texture of a folder into spectral reflectance OpenEXR files.
#
#   examples/bake_folder.sh INDIR OUTDIR [spectex bake options...]
#
# Every *.png, *.jpg, *.tif and *.exr in INDIR (not recursive; extensions in any
# case, plus .jpeg and .tiff) is baked to OUTDIR/<stem>.exr. Extra arguments are
# passed to every 'spectex bake', e.g. --type float --preview. A failed file does
# not stop the others. Exit status: 0 all baked; 1 a file failed or INDIR has no
# textures; 2 usage error (bad arguments, spectex not found).
# The spectex binary is $SPECTEX, else 'spectex' from PATH.
set -euo pipefail

usage() {
    echo "usage: ${0##*/} INDIR OUTDIR [spectex bake options...]" >&2
    echo "  bakes INDIR/*.{png,jpg,tif,exr} to OUTDIR/<stem>.exr with \$SPECTEX or spectex from PATH" >&2
    exit 2
}

case "${1-}" in -h|--help) usage ;; esac
[[ $# -ge 2 ]] || usage
indir=$1
outdir=$2
shift 2
[[ -d $indir ]] || { echo "${0##*/}: $indir: not a folder" >&2; exit 2; }

spectex=${SPECTEX:-spectex}
if ! command -v -- "$spectex" >/dev/null 2>&1; then
    echo "${0##*/}: $spectex not found; set SPECTEX or add spectex to PATH" >&2
    exit 2
fi

mkdir -p -- "$outdir"

shopt -s nullglob nocaseglob
inputs=("$indir"/*.png "$indir"/*.jpg "$indir"/*.jpeg "$indir"/*.tif "$indir"/*.tiff "$indir"/*.exr)
shopt -u nullglob nocaseglob

if [[ ${#inputs[@]} -eq 0 ]]; then
    echo "${0##*/}: no .png, .jpg, .tif or .exr files in $indir" >&2
    exit 1
fi

done_count=0
failed=0
declare -A seen=()
for src in "${inputs[@]}"; do
    [[ -f $src ]] || continue
    name=${src##*/}
    stem=${name%.*}
    out=$outdir/$stem.exr
    # Two inputs with the same stem (a.png, a.tif) would overwrite each other.
    if [[ -n ${seen[$stem]+x} ]]; then
        echo "${0##*/}: $src: skipped, $out is already made from ${seen[$stem]}" >&2
        failed=$((failed + 1))
        continue
    fi
    seen[$stem]=$src
    # The output must never be the input (an .exr baked into its own folder).
    if [[ $out -ef $src ]]; then
        echo "${0##*/}: $src: skipped, the output would overwrite the input" >&2
        failed=$((failed + 1))
        continue
    fi
    status=0
    "$spectex" bake "$@" -o "$out" -- "$src" || status=$?
    if [[ $status -eq 0 ]]; then
        done_count=$((done_count + 1))
        echo "$src -> $out"
    else
        failed=$((failed + 1))
        echo "${0##*/}: $src: failed (exit status $status)" >&2
    fi
done

echo "${0##*/}: $done_count baked, $failed failed, into $outdir"
if [[ $failed -gt 0 ]]; then
    exit 1
fi
