#!/usr/bin/env bash
# Runs the whole test suite: installs/builds what is missing first (scripts/install-and-build.sh),
# then CTest. Tests that need ../shared (model, data clips) skip with a message when it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-and-build.sh
cd build
ctest --output-on-failure -j "${JOBS:-$(nproc)}" "$@"
