#!/usr/bin/env bash
# Builds everything with AddressSanitizer + UndefinedBehaviorSanitizer
# (VLN_SANITIZE=ON, gcc) into build-asan/ and runs the ctest suite there with
# every sanitizer report fatal.
#
#   scripts/sanitize.sh                  # whole suite
#   scripts/sanitize.sh -L 'common|sim'  # extra arguments go to ctest
#   scripts/sanitize.sh -LE slow         # everything but the slow tests
#   VLN_SANITIZE_MODULES="common sim data world" scripts/sanitize.sh
#                                        # only those modules' tests
#
# Suppressions (tests/reliability/sanitizers/*.supp) are narrow and each one
# says why; LibTorch, OpenBLAS and Mesa are not instrumented, which is fine.
# Prints the build and test wall-clock times at the end.
#
# Environment: VLN_JOBS (build and ctest parallelism, default 2),
# VLN_ASAN_BUILD_DIR (default build-asan), VLN_SANITIZE_MODULES (modules,
# space-separated: build only the tests/<module>/*Test targets and the
# libraries they link, and run only the tests labelled with those modules;
# "common sim data world" needs no LibTorch code and builds in a fraction
# of the full tree's time).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build=${VLN_ASAN_BUILD_DIR:-build-asan}
jobs=${VLN_JOBS:-2}
supp=$root/tests/reliability/sanitizers

# VLN_SANITIZE_MODULES: the test targets of those modules and a ctest label
# filter for them (tests/CMakeLists.txt labels each test with its module)
read -ra modules <<<"${VLN_SANITIZE_MODULES:-}"
targets=()
filter=()
if ((${#modules[@]})); then
  for module in "${modules[@]}"; do
    if ! compgen -G "tests/$module/*Test.cpp" >/dev/null; then
      echo "sanitize: no tests/$module/*Test.cpp (VLN_SANITIZE_MODULES)" >&2
      exit 2
    fi
    for source in tests/"$module"/*Test.cpp; do targets+=("$(basename "$source" .cpp)"); done
  done
  labels=$(IFS='|'; echo "${modules[*]}")
  filter=(-L "^($labels)\$")
  echo "sanitize: modules ${modules[*]}: ${#targets[@]} test targets, ctest ${filter[*]}"
fi

start=$(date +%s)
# packages, configure (first time) and build, through the project's setup
# script; -g1 gives the reports line numbers at a fraction of -g's cost
VLN_BUILD_DIR=$build VLN_JOBS=$jobs VLN_BUILD_TARGETS="${targets[*]}" \
  VLN_CMAKE_ARGS="-DVLN_SANITIZE=ON -DVLN_WERROR=ON -DVLN_BUILD_BENCH=OFF -DCMAKE_CXX_FLAGS=-g1 -DCMAKE_C_FLAGS=-g1" \
  scripts/setup.sh
built=$(date +%s)

# halt on the first report; LibTorch's and OpenBLAS's threads keep a few
# allocations alive at exit, listed (narrowly) in lsan.supp
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=1:detect_leaks=1:detect_odr_violation=1:strict_string_checks=1:check_initialization_order=1:detect_stack_use_after_return=0"
export LSAN_OPTIONS="suppressions=$supp/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:suppressions=$supp/ubsan.supp"
# sanitized code is 2-5x slower: give ctest's per-test timeout room
set +e
(cd "$build" && ctest --output-on-failure -j "$jobs" --timeout 2400 "${filter[@]}" "$@")
rc=$?
set -e
done_at=$(date +%s)
echo "sanitize: build $((built - start)) s, tests $((done_at - built)) s, ctest exit $rc"
exit $rc
