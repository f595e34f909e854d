#!/usr/bin/env bash
# The C++ tree stays formatted by .clang-format: every file of src/ and tests/ (not the fuzz
# corpus) must come out of clang-format unchanged.
#   tests/format/check.sh SOURCE_DIR          check (exit 1 and the first differences on failure)
#   tests/format/check.sh SOURCE_DIR --fix    reformat in place
# One version of clang-format formats one way: the check uses Debian 12's clang-format (14), and
# fails (never skips) when it is missing.
set -euo pipefail
src=$(cd "${1:?usage: check.sh SOURCE_DIR [--fix]}" && pwd)
fix=${2:-}
cf=$(command -v clang-format-14 || command -v clang-format || true)
if [ -z "$cf" ]; then
  echo "format: FAILED: clang-format (Debian package clang-format) is not installed" >&2
  exit 1
fi
cd "$src"
mapfile -t files < <(git ls-files -- 'src/*.cpp' 'src/*.h' 'tests/*.cpp' 'tests/*.h' 2>/dev/null ||
                     find src tests \( -name '*.cpp' -o -name '*.h' \) -not -path 'tests/fuzz/corpus/*')
if [ ${#files[@]} -eq 0 ]; then
  echo "format: FAILED: no C++ files found under $src" >&2
  exit 1
fi
if [ "$fix" = --fix ]; then
  "$cf" -i --style=file "${files[@]}"
  echo "format: reformatted ${#files[@]} files with $("$cf" --version)"
  exit 0
fi
bad=()
for f in "${files[@]}"; do
  if ! "$cf" --style=file --dry-run -Werror "$f" >/dev/null 2>&1; then bad+=("$f"); fi
done
if [ ${#bad[@]} -gt 0 ]; then
  echo "format: ${#bad[@]} of ${#files[@]} files are not formatted by .clang-format ($("$cf" --version)):" >&2
  printf '  %s\n' "${bad[@]}" >&2
  echo "first differences:" >&2
  "$cf" --style=file --dry-run "${bad[0]}" 2>&1 | head -20 >&2
  echo "fix: tests/format/check.sh . --fix" >&2
  exit 1
fi
echo "format: ${#files[@]} files formatted ($("$cf" --version))"
