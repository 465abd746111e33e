#!/usr/bin/env bash
# Fuzzing the loaders (fuzz/: TUM lists, YAML config, trajectories, vocabulary, depth PNG) with
# clang's libFuzzer, AddressSanitizer and UBSan.
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]  builds build-fuzz (clang, -DDESSLAM_FUZZ=ON) and fuzzes
#                                          each target (default: all) for SECONDS (default 60),
#                                          growing build-fuzz/corpus/<target> from fuzz/corpus;
#                                          crashes land in build-fuzz/artifacts/ (exit 1 if any)
#   scripts/fuzz.sh --build                builds (or updates) build-fuzz only; scripts/test.sh runs
#                                          it before the suite, so fuzz_bounded_runs fuzzes this code
#   scripts/fuzz.sh --bounded [BUILD_DIR]  2000 inputs per target of an existing fuzz build (the
#                                          default suite's fuzz_bounded_runs); exit 77 = skipped
#   scripts/fuzz.sh --run-one BIN TARGET [libFuzzer options]  one target on a scratch copy of its seeds
#
# Builds run under nice -n 19 with at most ${JOBS:-2} jobs (the machine is shared).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
targets_all=(tum_list config trajectory vocabulary depth_png)

# One libFuzzer run of $1 (binary) for target $2 on a scratch corpus seeded from fuzz/corpus/$2;
# prints "<target>: <executions> executions, <result>"; returns the fuzzer's status.
run_one() {
  local bin="$1" name="$2"
  shift 2
  local work
  work="$(mktemp -d)"
  mkdir -p "$work/corpus" "$work/artifacts"
  cp -r "$root/fuzz/corpus/$name/." "$work/corpus/"
  local status=0
  "$bin" "$work/corpus" -artifact_prefix="$work/artifacts/" -print_final_stats=1 -rss_limit_mb=2048 \
    -max_len=16384 "$@" >"$work/log" 2>&1 || status=$?
  local execs
  execs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/log" | tail -1)"
  if [ "$status" -eq 0 ]; then
    echo "$name: ${execs:-?} executions, no crash"
  else
    echo "$name: FAILED (status $status) after ${execs:-?} executions; log and artifacts in $work"
    tail -40 "$work/log"
    return "$status"
  fi
  rm -rf "$work"
}

# Configures build-fuzz (clang, -DDESSLAM_FUZZ=ON) if needed and builds fuzz_<target> for each argument.
build_fuzz() {
  command -v clang++ >/dev/null 2>&1 || { echo "error: clang++ not found: apt-get install clang libclang-rt-14-dev" >&2; exit 1; }
  if [ ! -f "$root/build-fuzz/CMakeCache.txt" ]; then
    nice -n 19 cmake -S "$root" -B "$root/build-fuzz" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DCMAKE_CXX_COMPILER=clang++ -DDESSLAM_FUZZ=ON -DDESSLAM_BUILD_TESTS=OFF -DDESSLAM_BUILD_BENCH=OFF \
      -DDESSLAM_BUILD_PYTHON=OFF
  fi
  nice -n 19 cmake --build "$root/build-fuzz" -j "${JOBS:-2}" --target $(printf 'fuzz_%s ' "$@")
}

case "${1:-}" in
  --build)
    build_fuzz "${targets_all[@]}"
    exit 0
    ;;
  --run-one)
    shift
    run_one "$@"
    exit $?
    ;;
  --bounded)
    dir="${2:-$root/build-fuzz}"
    missing=()
    for t in "${targets_all[@]}"; do [ -x "$dir/fuzz/fuzz_$t" ] || missing+=("$t"); done
    if [ "${#missing[@]}" -gt 0 ]; then
      if command -v clang++ >/dev/null 2>&1; then
        echo "skipped: no fuzz build in $dir (missing: ${missing[*]}): run scripts/fuzz.sh to build one"
      else
        echo "skipped: clang is not installed (apt-get install clang), so there is no libFuzzer build"
      fi
      exit 77
    fi
    echo "bounded fuzzing with the binaries in $dir (built from the sources as they were then)"
    for t in "${targets_all[@]}"; do run_one "$dir/fuzz/fuzz_$t" "$t" -runs=2000; done
    exit 0
    ;;
esac

seconds="${1:-60}"
[ "$#" -gt 0 ] && shift
targets=("$@")
[ "${#targets[@]}" -eq 0 ] && targets=("${targets_all[@]}")
build="$root/build-fuzz"
build_fuzz "${targets[@]}"
mkdir -p "$build/artifacts"
failed=0
for t in "${targets[@]}"; do
  mkdir -p "$build/corpus/$t"
  cp -rn "$root/fuzz/corpus/$t/." "$build/corpus/$t/"
  log="$build/fuzz_$t.log"
  status=0
  nice -n 19 "$build/fuzz/fuzz_$t" "$build/corpus/$t" -max_total_time="$seconds" -print_final_stats=1 \
    -rss_limit_mb=2048 -max_len=16384 -artifact_prefix="$build/artifacts/$t-" >"$log" 2>&1 || status=$?
  execs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)"
  corpus="$(find "$build/corpus/$t" -type f | wc -l)"
  if [ "$status" -eq 0 ]; then
    echo "$t: ${execs:-?} executions in ${seconds} s, corpus $corpus inputs, no crash"
  else
    echo "$t: CRASH (status $status) after ${execs:-?} executions: see $log and $build/artifacts/"
    failed=1
  fi
done
exit "$failed"
