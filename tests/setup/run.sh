#!/usr/bin/env bash
# The README's set-up commands must never test nothing. Configure-only checks of .ci/lib.sh (the
# steps .ci/bootstrap runs) on scratch build folders, in the orders a newcomer or a packager uses:
#   1. a folder configured with the tests off (as `example` once did; the farm test off too) gets the
#      whole suite from the test command's configure step;
#   2. a plain `cmake -S . -B DIR` (no venv, Unix Makefiles) succeeds, says in one line how to turn
#      the interop tests on, and the test command's configure step then works on that folder;
#   3. the test command's ctest step fails on a folder with no tests.
#
#   tests/setup/run.sh SOURCE_DIR PYTHON
set -uo pipefail
src=$(cd "${1:?usage: run.sh SOURCE_DIR PYTHON}" && pwd)
python=${2:?usage: run.sh SOURCE_DIR PYTHON}
cd "$src"
. .ci/lib.sh
tmp=$(mktemp -d /tmp/spectex-setup-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail=0
check() {  # check "what" command...
  local what=$1; shift
  if "$@"; then echo "ok: $what"; else echo "FAILED: $what"; fail=1; fi
}
count_tests() { ctest --test-dir "$1" -N 2>/dev/null | sed -n 's/^Total Tests: //p'; }

# 1. Tests off, then the test command's configure.
cmake -S . -B "$tmp/off" -G Ninja -DSPECTEX_BUILD_TESTS=OFF -DSPECTEX_FARM_TESTS=OFF --no-warn-unused-cli >/dev/null
check "a folder configured with tests off lists no test" test "$(count_tests "$tmp/off")" = 0
# 3. ... and the test command's ctest step refuses to call that green.
check "the ctest step fails when there is no test" bash -c '. .ci/lib.sh; ! spectex_ctest "$0" >/dev/null 2>&1' "$tmp/off"
check "the test configure step succeeds on it" spectex_configure test "$tmp/off" "$python"
n=$(count_tests "$tmp/off")
check "it then lists the suite ($n entries before building)" test "${n:-0}" -gt 0
check "including the interop tests" bash -c 'ctest --test-dir "$0" -N -L interop | grep -q "interop\\."' "$tmp/off"
check "and the farm test" bash -c 'ctest --test-dir "$0" -N -L farm | grep -q "farm\\.slurm"' "$tmp/off"

# 2. A plain configure: default generator, no venv.
out=$(cmake -S . -B "$tmp/plain" 2>&1)
check "a plain configure succeeds" test $? = 0
check "and says in one line how to turn the interop tests on" \
  bash -c 'test "$(grep -c "interop tests off.*bootstrap test" <<<"$0")" = 1' "$out"
check "the test configure step keeps its generator and works" spectex_configure test "$tmp/plain" "$python"
check "example's configure step works after it" spectex_configure example "$tmp/plain"
exit $fail
