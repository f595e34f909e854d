#!/usr/bin/env bash
# The benchmarks' Python alone, without the test suite: BUILD/venv (default build/venv) with the
# packages of tests/python/requirements.txt (NumPy, SciPy, colour-science, OpenImageIO, Mitsuba 3)
# and this tree's Mitsuba plugin: the venv `.ci/bootstrap test` makes, by the same function, so
# either reuses the other's. Seconds to minutes, as fast as PyPI (580 MB installed). The benchmarks
# also need the binary, build/src/spectex: `.ci/bootstrap example` builds it (and python3-venv).
#   tests/bench/setup.sh [BUILD]
set -euo pipefail
cd "$(dirname "$0")/../.."
. .ci/lib.sh
build=${1:-build}
if ! /usr/bin/python3 -c 'import ensurepip, venv' 2>/dev/null; then
  echo "spectex: no python3-venv: apt-get install python3-venv (or run .ci/bootstrap example first)" >&2
  exit 1
fi
spectex_venv "$build"
"$build/venv/bin/python" -W ignore -c 'import numpy, scipy, colour, OpenImageIO, mitsuba, drjit, spectex_mitsuba'
echo "spectex: $build/venv is ready: $build/venv/bin/python tests/bench/<script>.py ..."
[ -x "$build/src/spectex" ] || echo "spectex: no $build/src/spectex yet: .ci/bootstrap example builds it"
