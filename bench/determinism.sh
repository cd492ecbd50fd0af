#!/usr/bin/env bash
# Kernel timing determinism: min / median / p99 / max ns per call of every generated
# kernel of the bundled models (the per_call benchmarks of eom_bench_kernels; the method and its
# limits are in bench/bench_kernels.cpp, "Per-call timing"). Writes docs/benchmarks/determinism.md.
#
#   bench/determinism.sh [extra Google Benchmark flags, e.g. --benchmark_filter=chain10]
#
# Builds eom_bench_kernels in $EOM_BENCH_BUILD_DIR (default build-bench/; a few minutes from
# scratch on 2 cores) and runs it pinned to one CPU ($EOM_BENCH_CPU, default the last one) when
# taskset is available. The run itself takes about 10 s.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${EOM_BENCH_BUILD_DIR:-build-bench}
out=docs/benchmarks

log() { echo "determinism.sh: [$(date +%T)] $*" >&2; }
log "configuring $build"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
log "building eom_bench_kernels"
cmake --build "$build" -j2 --target eom_bench_kernels

cpu=${EOM_BENCH_CPU:-$(($(nproc) - 1))}
pin=() pinned="not pinned (no taskset)"
if command -v taskset >/dev/null; then pin=(taskset -c "$cpu") pinned="CPU $cpu (taskset)"; fi
json="$build/bench/determinism.json"
log "running the per_call benchmarks, $pinned"
"${pin[@]}" "$build/bench/eom_bench_kernels" --benchmark_filter=per_call \
  --benchmark_out="$json" --benchmark_out_format=json "$@" >"$build/bench/determinism.txt"

compiler=$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$build/CMakeCache.txt")
model=$(lscpu | sed -n 's/^Model name: *//p' | head -1)
flags=$(grep -o -w 'constant_tsc\|nonstop_tsc' /proc/cpuinfo 2>/dev/null | sort -u |
        tr '\n' ' ' || true)
python3 bench/determinism_report.py "$json" --md "$out/determinism.md" --machine \
  "CPU=$model, $(nproc) logical CPUs; TSC flags: ${flags:-none found}" \
  "compiler=$("${compiler:-g++}" --version | head -1), -O3 -march=native" \
  "kernel=$(uname -sr)" \
  "pinned to=$pinned; not an isolated core (no isolcpus, normal scheduling)" \
  "command=bench/determinism.sh $*"
log "wrote $out/determinism.md"
