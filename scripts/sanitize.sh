#!/usr/bin/env bash
# The whole test suite under a sanitizer (issue 11). Not part of scripts/test.sh: a sanitizer
# suite takes many times longer than the normal one.
#
#   scripts/sanitize.sh asan [ctest arguments...]   AddressSanitizer + UBSan (-DDESSLAM_ASAN=ON)
#   scripts/sanitize.sh tsan [ctest arguments...]   ThreadSanitizer (-DDESSLAM_TSAN=ON)
#
# Configures (first time) and builds build-asan or build-tsan beside this script's project
# (RelWithDebInfo, Ninja, ccache when installed, no benchmarks; BUILD_DIR=... chooses another
# folder), then runs CTest in it with the sanitizer's options below, ${JOBS:-2} jobs, and prints
# the summary. Extra arguments go to ctest (e.g. -R LoopClosing, -E consumer). Every test's own
# timeout is multiplied by DESSLAM_TEST_TIMEOUT_SCALE (6 in sanitizer builds, CMakeLists.txt).
# Builds and tests run under nice -n 19 (the machine is shared). Exit: CTest's status.
#
# Any sanitizer report fails the test that printed it: ASan and UBSan stop the process at the
# first error (halt_on_error), LeakSanitizer fails it at exit, TSan makes it exit 66.
# tests/tsan.supp holds the ThreadSanitizer suppressions (third-party libraries only); our own
# code is never suppressed. The Python tests are not part of a sanitizer build (python/CMakeLists.txt:
# the interpreter is not instrumented); the API they call is tested in C++ (tests/api).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
kind="${1:-}"
case "$kind" in
  asan) option=DESSLAM_ASAN ;;
  tsan) option=DESSLAM_TSAN ;;
  *) echo "usage: scripts/sanitize.sh asan|tsan [ctest arguments...]" >&2; exit 2 ;;
esac
shift
build="${BUILD_DIR:-$root/build-$kind}"
jobs="${JOBS:-2}"
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$(dirname "$root")}"

if [ ! -f "$build/CMakeCache.txt" ]; then
  launcher=()
  command -v ccache >/dev/null 2>&1 && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  nice -n 19 cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -D"$option"=ON -DDESSLAM_BUILD_BENCH=OFF "${launcher[@]}"
fi
grep -q "^$option:BOOL=ON" "$build/CMakeCache.txt" \
  || { echo "error: $build is not a $kind build ($option is not ON there); set BUILD_DIR" >&2; exit 2; }
start=$(date +%s)
nice -n 19 cmake --build "$build" -j "$jobs"
echo "build: $(( $(date +%s) - start )) s"

if [ "$kind" = asan ]; then
  # detect_leaks: LeakSanitizer at exit; strict_init_order: static initialisers using others.
  export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:check_initialization_order=1:strict_init_order=1:detect_stack_use_after_return=1"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
  if [ -f "$root/tests/lsan.supp" ]; then
    export LSAN_OPTIONS="suppressions=$root/tests/lsan.supp:print_suppressions=0"
  fi
else
  # second_deadlock_stack: both stacks of a lock-order report.
  export TSAN_OPTIONS="suppressions=$root/tests/tsan.supp:second_deadlock_stack=1:print_suppressions=0"
fi
start=$(date +%s)
status=0
nice -n 19 ctest --test-dir "$build" -j "$jobs" --output-on-failure "$@" || status=$?
echo "$kind suite: $(( $(date +%s) - start )) s, ctest status $status"
exit "$status"
