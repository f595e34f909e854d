#!/usr/bin/env bash
# AddressSanitizer + UndefinedBehaviorSanitizer build of spectex, then its unit and CLI tests but
# the Slow ones, with leak detection on and any UB report fatal.
#
#   tests/sanitize/run.sh SOURCE_DIR BUILD_DIR CLI_TESTS
#
# CLI_TESTS is the CLI test harness of an ordinary build (build/tests/spectex_cli_tests): it only
# starts spectex and reads its outputs with OpenEXR, so it runs against this build's instrumented
# spectex ($SPECTEX_TEST_BINARY, SPECTEX_TEST_BINARY_SANITIZED=1) instead of being compiled a
# second time (its 35 files were a quarter of this build). BUILD_DIR is kept between runs, so a
# rerun only rebuilds what changed. Environment:
#   CXX          compiler (default clang++ when installed, else g++)
#   JOBS         parallel build jobs, ctest jobs and CLI test shards (default 2)
#   CTEST_ARGS   extra ctest arguments for the unit tests (e.g. -R Lattice)
#   GTEST_FILTER the CLI tests to run (default: all but the Slow ones)
# OpenImageIO, OpenColorIO and OpenEXR are Debian's (not instrumented): ASan still sees their
# heap through its malloc, so leaks inside them would be reported; tests/sanitize/lsan.supp lists
# frames of those libraries only, never spectex's own code.
set -euo pipefail
usage="usage: run.sh SOURCE_DIR BUILD_DIR CLI_TESTS"
src=$(cd "${1:?$usage}" && pwd)
build=${2:?$usage}
cli_tests=${3:?$usage}
[ -x "$cli_tests" ] || { echo "run.sh: $cli_tests: no CLI test harness there (build the tests first)" >&2; exit 2; }
mkdir -p "$build"
build=$(cd "$build" && pwd)
jobs=${JOBS:-2}

if [ -z "${CXX:-}" ]; then
  if command -v clang++ >/dev/null; then CXX=clang++; else CXX=g++; fi
fi
flags="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"

# Configure once (and again when the flags or compiler change). -g1 (clang: line tables only)
# gives every report its file and line at a fraction of -g's compile time. Built: spectex, its
# image module and the unit tests, which run the library in-process.
stamp="$build/.spectex-sanitize-config"
want="$CXX|$flags|module|g1|no-harness"  # "module": the image module links with the sanitizers too
if [ ! -f "$build/CMakeCache.txt" ] || [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  cmake -S "$src" -B "$build" -G Ninja \
    -DCMAKE_CXX_COMPILER="$CXX" \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" \
    -DCMAKE_CXX_FLAGS="$flags" \
    -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
    -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" \
    -DCMAKE_MODULE_LINKER_FLAGS="-fsanitize=address,undefined" \
    -DSPECTEX_INTEROP_TESTS=OFF \
    -DSPECTEX_BUILD_BENCHMARKS=OFF \
    -DSPECTEX_TOOLING_TESTS=OFF
  echo "$want" > "$stamp"
fi
cmake --build "$build" -j "$jobs" --target spectex spectex_unit_tests

supp="$src/tests/sanitize/lsan.supp"
# fast_unwind_on_malloc=1 (the default): every spectex the CLI tests start allocates thousands of
# blocks while OpenImageIO and OpenColorIO load, and the slow unwinder (=0) took 1.5 s of a 1.9 s
# bake of a 48x32 PNG (0.36 s with it on); the CLI tests start over two thousand of them. The
# frame-pointer unwinder stops at the first frame of a library built without frame pointers, but
# the allocation's caller is always the first frame, so a suppression names that frame's function.
# A leak in a spectex child that exits 0 turns its status into 23 and fails the test; leaks of
# runs that fail anyway are printed in the test's log.
# intercept_tls_get_addr=0: the runtime of clang 14 (and GCC up to 13) takes a dynamic TLS block
# whose address is 16 bytes past a page boundary for a glibc-2.19 block with a header, reads the
# two words before it as the block's start and size, and its leak-check tracer then scans a range
# near address 0 and dies ("Tracer caught signal 11", exit 1, no leak named). The image libraries
# are loaded with the image module (dlopen), so their TLS is dynamic and the bake of one 64x48 TIFF
# hit it every time. Without the interceptor, the blocks (allocated by the dynamic linker) are
# still scanned as the linker's allocations (use_ld_allocations, on by default).
export ASAN_OPTIONS="detect_leaks=1:fast_unwind_on_malloc=1:strict_string_checks=1:detect_stack_use_after_return=1:check_initialization_order=1:intercept_tls_get_addr=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
if [ -f "$supp" ]; then export LSAN_OPTIONS="suppressions=$supp:print_suppressions=0"; fi

cd "$build"
# -E '^slow\.' as well as -LE slow: the slow unit tests are discovered with the prefix "slow.", and
# their "unit;slow" label list is flattened by gtest_discover_tests, so the label alone misses them.
# shellcheck disable=SC2086
ctest -L unit -LE slow -E '^slow\.' -j "$jobs" --output-on-failure --timeout 1800 ${CTEST_ARGS:-}

# The CLI tests, in JOBS shards of the harness run side by side (GoogleTest deals the tests out in
# turn). Each shard's log is kept in BUILD_DIR; a failing shard's failures are printed.
export SPECTEX_TEST_BINARY="$build/src/spectex" SPECTEX_TEST_BINARY_SANITIZED=1
filter=${GTEST_FILTER:--*Slow*}
pids=()
for ((i = 0; i < jobs; ++i)); do
  GTEST_TOTAL_SHARDS=$jobs GTEST_SHARD_INDEX=$i "$cli_tests" --gtest_filter="$filter" \
    >"$build/cli-shard-$i.log" 2>&1 &
  pids+=($!)
done
status=0
for ((i = 0; i < jobs; ++i)); do
  if wait "${pids[$i]}"; then
    echo "CLI tests, shard $((i + 1))/$jobs: $(grep -E '^\[  PASSED  \]' "$build/cli-shard-$i.log")"
  else
    status=1
    echo "CLI tests, shard $((i + 1))/$jobs FAILED (log: $build/cli-shard-$i.log):"
    grep -E -B40 '^\[  FAILED  \] [A-Za-z]' "$build/cli-shard-$i.log" | head -400
    grep -E '^\[  FAILED  \]|^\[  PASSED  \]' "$build/cli-shard-$i.log"
  fi
done
exit $status
