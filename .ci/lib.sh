# Shared steps of .ci/bootstrap, kept as functions so that tests/setup/run.sh can check them on
# scratch build folders (configure only) without a second copy.

# spectex_configure MODE BUILD [PYTHON]
#   MODE example: whatever the folder was configured with before stays (only the binary is built).
#   MODE test: every part of the suite is switched on explicitly, so a folder configured earlier
#   with tests, benchmarks, the interop or the farm tests off (by `example`, by hand) runs everything.
# A folder made by a plain `cmake -S . -B build` (Unix Makefiles) keeps its generator: passing
# -G Ninja to it would make cmake refuse.
spectex_configure() {
  local mode=$1 build=$2 python=${3:-}
  local gen=()
  [ -f "$build/CMakeCache.txt" ] || gen=(-G Ninja)
  local opts=(-DCMAKE_BUILD_TYPE=Release -DSPECTEX_REQUIRE_INTEROP=OFF)
  if [ "$mode" = test ]; then
    opts+=(-DSPECTEX_BUILD_TESTS=ON -DSPECTEX_BUILD_BENCHMARKS=ON -DSPECTEX_TOOLING_TESTS=ON
           -DSPECTEX_INTEROP_TESTS=ON -DSPECTEX_REQUIRE_INTEROP=ON -DSPECTEX_PYTHON="$python")
    opts+=(-DSPECTEX_FARM_TESTS=ON)
  fi
  cmake -S . -B "$build" "${gen[@]}" "${opts[@]}" >/dev/null
}

# spectex_venv BUILD: BUILD/venv with the packages of tests/python/requirements.txt (made again
# only when they change: a copy of the list is kept in the venv) and this tree's Mitsuba plugin
# (installed again every run, without the network: the venv's setuptools builds it and its
# dependencies are in the requirements). The test command's venv, and the benchmarks'.
spectex_venv() {
  local venv=$1/venv
  if [ ! -x "$venv/bin/python" ] || ! cmp -s tests/python/requirements.txt "$venv/requirements.txt"; then
    rm -rf "$venv"
    /usr/bin/python3 -m venv "$venv"
    "$venv/bin/pip" install -q --disable-pip-version-check -r tests/python/requirements.txt
    cp tests/python/requirements.txt "$venv/requirements.txt"
  fi
  "$venv/bin/pip" install -q --disable-pip-version-check --no-deps --no-build-isolation --force-reinstall ./python
  rm -rf python/build python/*.egg-info
}

# spectex_ctest BUILD: the whole suite; a folder with no tests is a failure, never a green run.
spectex_ctest() {
  ctest --test-dir "$1" --output-on-failure --no-tests=error -j 2 --timeout 1800
}
