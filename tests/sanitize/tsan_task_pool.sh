#!/usr/bin/env bash
# ThreadSanitizer build of the task facility (src/base/task_pool.cpp) and its unit tests, run
# 20 times over: every parallel stage of spectex (strips, chunks, loops, batch jobs) stands on it,
# and a data race there would show as rare wrong output anywhere. Any TSan report is fatal.
#
#   tests/sanitize/tsan_task_pool.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$(cd "${1:?usage: tsan_task_pool.sh SOURCE_DIR BUILD_DIR}" && pwd)
build=${2:?usage: tsan_task_pool.sh SOURCE_DIR BUILD_DIR}
mkdir -p "$build"
CXX=${CXX:-clang++}
command -v "$CXX" >/dev/null || { echo "tsan_task_pool: $CXX not found (install clang)" >&2; exit 1; }
"$CXX" -std=c++17 -O1 -g -fsanitize=thread -fno-omit-frame-pointer -I"$src/src" \
  "$src/src/base/task_pool.cpp" "$src/tests/unit/task_pool_test.cpp" \
  -lgtest -lgtest_main -pthread -o "$build/task_pool_tsan"
TSAN_OPTIONS="halt_on_error=1 exitcode=66 ${TSAN_OPTIONS:-}" \
  "$build/task_pool_tsan" --gtest_repeat=20 --gtest_brief=1
echo "tsan_task_pool: 20 runs of the TaskPool tests, no race reported"
