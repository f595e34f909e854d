#!/usr/bin/env bash
# tests/layering/check.sh can fail: a tiny scratch tree that keeps every rule passes, and the same
# tree with one violating include added fails, naming the file, once per rule.
#   tests/layering/negative_test.sh SOURCE_DIR
set -euo pipefail
check="$(cd "${1:?usage: negative_test.sh SOURCE_DIR}" && pwd)/tests/layering/check.sh"
scratch=$(mktemp -d "${TMPDIR:-/tmp}/spectex-layering.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
failures=0

# A clean tree: each floor includes what it may (its own floor, the ones below, the standard
# library; base/ POSIX and threads; spectral/ Eigen).
clean() {
  rm -rf "$scratch/src"
  mkdir -p "$scratch/src"/{base,spectral,io,pipeline,cli}
  printf '#pragma once\n#include <unistd.h>\n#include <thread>\n#include <mutex>\n#include <string>\n' \
    >"$scratch/src/base/pool.h"
  printf '#include "base/pool.h"\n#include <atomic>\n#include <sys/stat.h>\n' >"$scratch/src/base/pool.cpp"
  printf '#pragma once\n#include <Eigen/Dense>\n#include <vector>\n#include "base/pool.h"\n' \
    >"$scratch/src/spectral/maths.h"
  printf '#include "spectral/maths.h"\n#include <cmath>\n#include <immintrin.h>\n' \
    >"$scratch/src/spectral/maths.cpp"
  printf '#include <OpenEXR/ImfHeader.h>\n#include "spectral/maths.h"\n#include "base/pool.h"\n' \
    >"$scratch/src/io/exr.cpp"
  printf '#include "io/exr.h"\n#include <nlohmann/json.hpp>\n' >"$scratch/src/pipeline/bake.cpp"
  printf '#include "pipeline/bake.h"\n' >"$scratch/src/cli/bake_command.cpp"
}

expect() {  # expect pass|fail WHAT [FILE LINE]: the clean tree plus LINE in FILE
  local want=$1 what=$2 file=${3:-} line=${4:-} out rc
  clean
  if [ -n "$file" ]; then printf '%s\n' "$line" >>"$scratch/src/$file"; fi
  set +e
  out=$("$check" "$scratch" 2>&1)
  rc=$?
  set -e
  if [ "$want" = pass ] && [ $rc -ne 0 ]; then
    echo "FAILED: $what: the check refused a clean tree (exit $rc):" >&2
    echo "$out" | sed 's/^/  /' >&2
    failures=$((failures + 1))
  elif [ "$want" = fail ] && { [ $rc -ne 1 ] || ! grep -qF "$file" <<<"$out"; }; then
    echo "FAILED: $what: the check let '$line' in src/$file through (exit $rc):" >&2
    echo "$out" | sed 's/^/  /' >&2
    failures=$((failures + 1))
  fi
}

expect pass "a clean tree"
expect fail "base/ including spectral/" base/pool.cpp '#include "spectral/maths.h"'
expect fail "base/ including io/" base/pool.h '#include "io/exr.h"'
expect fail "base/ including the generated version header" base/pool.cpp '#include "spectex/version.h"'
expect fail "base/ including OpenImageIO" base/pool.cpp '#include <OpenImageIO/imageio.h>'
expect fail "spectral/ including io/" spectral/maths.cpp '#include "io/exr.h"'
expect fail "spectral/ including pipeline/" spectral/maths.h '#  include "pipeline/bake.h"'
expect fail "spectral/ including OpenEXR" spectral/maths.cpp '#include <OpenEXR/ImfHeader.h>'
expect fail "spectral/ including OpenColorIO" spectral/maths.cpp '#include <OpenColorIO/OpenColorIO.h>'
for h in unistd.h fcntl.h sys/stat.h sys/mman.h pthread.h dirent.h thread mutex condition_variable \
         atomic future shared_mutex filesystem; do
  expect fail "spectral/ including <$h>" spectral/maths.cpp "#include <$h>"
done
expect fail "spectral/ naming a header attribute" spectral/maths.cpp 'const char* k = "spectex:method";'
expect fail "base/ naming a header attribute" base/pool.h 'constexpr const char* kVersion = "spectex:version";'
expect pass "spectral/ with an error message" spectral/maths.cpp 'const char* m = "spectex: a message";'
expect fail "io/ including pipeline/" io/exr.cpp '#include "pipeline/bake.h"'
expect fail "io/ including cli/" io/exr.cpp '#include "cli/commands.h"'
expect fail "pipeline/ including cli/" pipeline/bake.cpp '#include "cli/commands.h"'

# A floor that is missing is an error, not a pass.
clean
rm -rf "$scratch/src/base"
if "$check" "$scratch" >/dev/null 2>&1; then
  echo "FAILED: a tree without src/base/ passed" >&2
  failures=$((failures + 1))
fi

if [ $failures -ne 0 ]; then
  echo "layering negative test: $failures case(s) failed" >&2
  exit 1
fi
echo "layering negative test: every rule refuses its violation, and a clean tree passes"
