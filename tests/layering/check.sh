#!/usr/bin/env bash
# The layers point one way: cli -> pipeline -> io -> spectral. A file may include its own layer and
# those below it only, and spectral/ no image, colour or EXR library at all.
#   tests/layering/check.sh SOURCE_DIR
set -euo pipefail
cd "${1:?usage: check.sh SOURCE_DIR}/src"
fail=0
check() {  # check LAYER PATTERN WHY
  local hits
  hits=$(grep -nE "^[[:space:]]*#[[:space:]]*include[[:space:]]*[<\"]($2)" -r "$1" --include='*.cpp' --include='*.h' || true)
  if [ -n "$hits" ]; then
    echo "layering: $1/ $3:" >&2
    echo "$hits" | sed 's/^/  /' >&2
    fail=1
  fi
}
check spectral 'io/|pipeline/|cli/|OpenImageIO/|OpenColorIO/|OpenEXR/|Imf|ImfC|openexr|nlohmann/' "must hold maths only"
check io 'pipeline/|cli/' "must not reach up to pipeline/ or cli/"
check pipeline 'cli/' "must not reach up to cli/"
[ -d spectral ] && [ -d io ] && [ -d pipeline ] && [ -d cli ] || { echo "layering: src/ layers missing" >&2; exit 1; }
if [ $fail -ne 0 ]; then exit 1; fi
echo "layering: cli -> pipeline -> io -> spectral holds ($(find spectral io pipeline cli -name '*.cpp' -o -name '*.h' | wc -l) files)"
