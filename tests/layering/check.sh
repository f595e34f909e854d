#!/usr/bin/env bash
# The floors point one way: cli -> pipeline -> io -> spectral -> base. A file may include its own
# floor and those below it only (docs/ARCHITECTURE.md, "Floors"):
#   base/      nothing of ours: the standard library, POSIX and third-party headers only (no image,
#              colour, EXR or JSON library either: every floor stands on it, spectral/ included)
#   spectral/  base/ and spectral/ only; maths: no image, colour, EXR or JSON library, and no POSIX
#              I/O or thread header (files and threads are base/'s: bounded_read, task_pool)
#   base/ and spectral/ name no header attribute ("spectex:<name>": io/provenance_keys.h)
#   io/        not pipeline/ or cli/
#   pipeline/  not cli/
#   tests/layering/check.sh SOURCE_DIR
# tests/layering/negative_test.sh proves that each rule can fail.
set -euo pipefail
cd "${1:?usage: check.sh SOURCE_DIR}/src"
for floor in base spectral io pipeline cli; do
  [ -d "$floor" ] || { echo "layering: src/$floor/ missing" >&2; exit 1; }
done
fail=0
report() {  # report FLOOR WHY HITS
  if [ -n "$3" ]; then
    echo "layering: $1/ $2:" >&2
    echo "$3" | sed 's/^/  /' >&2
    fail=1
  fi
}
includes() {  # includes FLOOR: every #include line of its files, as file:line:text
  grep -nE '^[[:space:]]*#[[:space:]]*include' -r "$1" --include='*.cpp' --include='*.h' || true
}
check() {  # check FLOOR PATTERN WHY: no include of <PATTERN... or "PATTERN...
  report "$1" "$3" "$(includes "$1" | grep -E "#[[:space:]]*include[[:space:]]*[<\"]($2)" || true)"
}
check_ours() {  # check_ours FLOOR ALLOWED WHY: quoted includes ("ours") only from ALLOWED floors
  report "$1" "$3" "$(includes "$1" | grep -E '#[[:space:]]*include[[:space:]]*"' |
                      grep -vE "#[[:space:]]*include[[:space:]]*\"($2)/" || true)"
}
libraries='OpenImageIO/|OpenColorIO/|OpenEXR/|Imath/|Imf|ImfC|openexr|nlohmann/'
# POSIX I/O, processes and threads: a file, a descriptor or a lock belongs to base/, not to maths.
system='unistd\.h|fcntl\.h|sys/|dirent\.h|dlfcn\.h|poll\.h|signal\.h|csignal>|termios\.h|pthread\.h|semaphore\.h|sched\.h|thread>|mutex>|shared_mutex>|condition_variable>|atomic>|future>|semaphore>|latch>|barrier>|stop_token>|filesystem>'
check_ours base 'base' "includes nothing of ours (include by path from src/: \"base/...\")"
check base "$libraries" "must not include an image, colour, EXR or JSON library"
check_ours spectral 'base|spectral' "may include only base/ and spectral/"
check spectral "$libraries" "must hold maths only (no image, colour, EXR or JSON library)"
check spectral "$system" "must hold maths only (no POSIX I/O or thread header: use base/)"
# The names a file records (spectex:* header attributes) are a file format's, io/'s
# (io/provenance_keys.h): the maths describes itself (spectral/spectral_method.h, MethodFact).
for floor in base spectral; do
  report "$floor" "must not name a header attribute (\"spectex:<name>\" belongs in io/provenance_keys.h)" \
    "$(grep -nE '"spectex:[A-Za-z]' -r "$floor" --include='*.cpp' --include='*.h' || true)"
done
check io 'pipeline/|cli/' "must not reach up to pipeline/ or cli/"
check pipeline 'cli/' "must not reach up to cli/"
if [ $fail -ne 0 ]; then exit 1; fi
echo "layering: cli -> pipeline -> io -> spectral -> base holds ($(find base spectral io pipeline cli -name '*.cpp' -o -name '*.h' | wc -l) files)"
