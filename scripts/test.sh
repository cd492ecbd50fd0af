#!/usr/bin/env bash
# The test command: installs what is missing, configures, builds and runs every test.
# Warnings are errors here (this is what CI runs).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
build=${EOM_BUILD_DIR:-build}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DEOM_WERROR=ON
cmake --build "$build" -j2
ctest --test-dir "$build" -j2 --output-on-failure "$@"
