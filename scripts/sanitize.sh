#!/usr/bin/env bash
# The whole test suite under AddressSanitizer and UndefinedBehaviorSanitizer (any report fails).
# Opt-in (not in CI).
#   scripts/sanitize.sh [ctest arguments...]      build dir: $EOM_SANITIZE_DIR or build-sanitize
# Last full run (2026-11-28, at f856b7e with this script's settings; 2 cores, shared part of the
# time with another build): build and 714 tests in 8738 s (2 h 26 min). No sanitizer report from
# eomgen's code. 706 passed, 2 skipped; 6 failed, all from the harness, fixed since: two tracer
# tests expected empty stderr and got ASan's one-time notice on swapcontext (test_emit filters
# it now); python.kernels/integrate/bad_input aborted at the first C++ exception (ASan's
# __cxa_throw interceptor needs libstdc++ preloaded too; with it the five Python suites pass);
# example.panda_osc timed out (557 s) while the run was paused for 6 of them (not rerun).
# The flags go through CXXFLAGS/LDFLAGS, which CMake reads when a project is first configured, so
# the nested projects that ctest configures (consumers, bad models, examples) are instrumented and
# link the instrumented libraries too. -Wno-psabi there reaches every compiler invocation (GCC's
# note on the batch kernels' vector returns is not an error). The generated kernels alone compile
# at -O1 -g1 (EOM_KERNEL_CXXFLAGS, read by add_eom_model): at -O2 -g an instrumented big kernel
# (spatial_upend.cpp) took more than 24 GB; at -O1 -g1 it takes 0.7 GB and 75 s. The Python tests
# load instrumented modules into an uninstrumented python3, so ASan's runtime is preloaded there,
# and libstdc++ with it (ASan's __cxa_throw interceptor must find it: EOM_PYTHON_PRELOAD). No
# CUDA: nvcc's host code is not instrumented. Leak checking is off: the tracers and the test
# programs exit through paths that keep caches alive on purpose; every other report stops the test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
build=${EOM_SANITIZE_DIR:-build-sanitize}
flags="-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer -Wno-psabi"
export CXXFLAGS="$flags" LDFLAGS="-fsanitize=address,undefined" EOM_KERNEL_CXXFLAGS="-O1 -g1"
export EOM_PYTHON_PRELOAD="$(c++ -print-file-name=libasan.so) $(c++ -print-file-name=libstdc++.so)"
export ASAN_OPTIONS="detect_leaks=0:abort_on_error=1" UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DEOM_BUILD_BENCH=OFF -DEOM_CUDA=OFF
cmake --build "$build" -j2
ctest --test-dir "$build" -j2 --output-on-failure --timeout 1200 "$@"
