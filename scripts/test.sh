#!/usr/bin/env bash
# The test command: installs what is missing, configures, builds and runs every test.
# Warnings are errors here (this is what CI runs).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
build=${EOM_BUILD_DIR:-build}
# The benchmarks are not tests: their scripts (bench/*.py, bench/run_peers.sh,
# scripts/work_precision.sh) build them. Left out here they save about 3 minutes of CI, most of it
# recompiling the robots' and the spacecraft's generated code at -O3 -march=native.
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DEOM_WERROR=ON -DEOM_BUILD_BENCH=OFF
cmake --build "$build" -j2
ctest --test-dir "$build" -j2 --output-on-failure "$@"
