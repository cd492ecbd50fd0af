#!/usr/bin/env bash
# Regenerates the hard-cases report docs/hard-cases/README.md: the spherical pendulum near its
# coordinate singularity, 50- and 100-link chains with light links and a heavy tip, the chaotic
# double pendulum's divergence time against tolerance, the closed chain at and near its dead
# point, energy over 10⁶ steps. Every figure is measured by this run; progress goes to the
# terminal. ~45 s of measurement on 2 cores, plus ~2 min to compile bench/hard_cases.cpp.
# The tests in tests/hard_cases/ assert the same bounds at reduced sizes.
# Usage: scripts/hard_cases.sh     (EOM_BUILD_DIR selects the build directory, default build)
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
build=${EOM_BUILD_DIR:-build}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DEOM_BUILD_BENCH=ON >/dev/null
cmake --build "$build" -j2 --target eom_hard_cases
out=docs/hard-cases
mkdir -p "$out"
"$build/bench/eom_hard_cases" "$out"
