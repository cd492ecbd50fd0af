#!/usr/bin/env bash
# The whole test suite under AddressSanitizer and UndefinedBehaviorSanitizer (any report fails).
# Opt-in (not in CI): a full instrumented build takes about half an hour on 2 cores.
#   scripts/sanitize.sh [ctest arguments...]      build dir: $EOM_SANITIZE_DIR or build-sanitize
# The flags go through CXXFLAGS/LDFLAGS, which CMake reads when a project is first configured, so
# the nested projects that ctest configures (consumers, bad models, examples) are instrumented and
# link the instrumented libraries too. Leak checking is off: the tracers and the test programs
# exit through paths that keep caches alive on purpose; every other report stops the test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
build=${EOM_SANITIZE_DIR:-build-sanitize}
flags="-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer -Wno-psabi"
export CXXFLAGS="$flags" LDFLAGS="-fsanitize=address,undefined"
export ASAN_OPTIONS="detect_leaks=0:abort_on_error=1" UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DEOM_BUILD_BENCH=OFF
cmake --build "$build" -j2
ctest --test-dir "$build" -j2 --output-on-failure --timeout 1200 "$@"
