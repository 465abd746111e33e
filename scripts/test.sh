#!/usr/bin/env bash
# Runs the whole test suite: installs/builds what is missing first (scripts/install-and-build.sh),
# builds the libFuzzer targets (build-fuzz), then CTest. Tests that need ../shared (model, data
# clips) skip with a message when it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-and-build.sh
# The libFuzzer build of the loaders (clang; about a minute), fuzzed briefly by fuzz_bounded_runs.
if command -v clang++ >/dev/null 2>&1; then
  scripts/fuzz.sh --build
else
  echo "note: clang++ not found, so fuzz_bounded_runs will be skipped (apt-get install clang libclang-rt-14-dev)"
fi
cd build
ctest --output-on-failure -j "${JOBS:-$(nproc)}" "$@"
