#!/usr/bin/env bash
# The kernel benchmark against the peers: generated kernels vs eom::Reference vs ADOL-C
# vs SymPy for mass_matrix, coriolis and forward_dynamics of the bundled models and Chain<N>,
# N = 2, 5, 10, 20, 50. Writes docs/benchmarks/kernels.md, kernels.json and kernels.csv.
#
#   bench/run_peers.sh [extra Google Benchmark flags, e.g. --benchmark_filter=chain10]
#
# Builds eom_bench_peers in $EOM_BENCH_BUILD_DIR (default build-bench/). The first build derives
# the SymPy code (several minutes for the 20-link chain); later runs reuse it. Takes about
# 10-15 minutes from scratch on a 2-core machine, 3-5 minutes once built.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${EOM_BENCH_BUILD_DIR:-build-bench}
python=${EOM_SYMPY_PYTHON:-/usr/bin/python3}
out=docs/benchmarks

# Prerequisites first: a missing peer is named here, not deep in a build.
missing=() why=()
need() { missing+=("$1"); why+=("$2"); }
command -v cmake >/dev/null || need cmake "cmake"
command -v g++ >/dev/null || need g++ "a C++ compiler (g++)"
[ -e /usr/include/benchmark/benchmark.h ] || [ -e /usr/local/include/benchmark/benchmark.h ] ||
  need libbenchmark-dev "Google Benchmark (benchmark/benchmark.h)"
[ -e /usr/include/adolc/adolc.h ] || [ -e /usr/local/include/adolc/adolc.h ] ||
  need libadolc-dev "ADOL-C, the taped AD peer (adolc/adolc.h)"
if ! [ -x "$python" ]; then
  need python3-sympy "a Python 3 interpreter at $python (set EOM_SYMPY_PYTHON) with SymPy"
elif ! "$python" -c 'import sympy' 2>/dev/null; then
  need python3-sympy "SymPy, the symbolic peer ($python -c 'import sympy' fails)"
fi
if [ ${#missing[@]} -gt 0 ]; then
  echo "run_peers.sh: missing prerequisites:" >&2
  for i in "${!missing[@]}"; do echo "  - ${why[$i]}" >&2; done
  echo "install them with: apt-get install ${missing[*]}" >&2
  exit 1
fi

log() { echo "run_peers.sh: [$(date +%T)] $*" >&2; }
start=$SECONDS
log "configuring $build"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DEOM_BENCH_PEERS=ON -DEOM_SYMPY_PYTHON="$python" \
      -DEOM_SYMPY_MAX_LINKS=20 >/dev/null
log "building eom_bench_peers (SymPy derivations and the 50-link kernels take a while)"
cmake --build "$build" -j2 --target eom_bench_peers
log "built in $((SECONDS - start)) s; running the benchmark (progress below)"
mkdir -p "$out"
"$build/bench/eom_bench_peers" --benchmark_repetitions=3 --benchmark_report_aggregates_only=false \
  --benchmark_min_time=0.2 --benchmark_out="$out/kernels.json" --benchmark_out_format=json \
  "$@" >"$build/bench_peers.txt"

adolc_version=$(pkg-config --modversion adolc 2>/dev/null ||
                dpkg-query -W -f='${Version}' libadolc-dev 2>/dev/null || echo '?')
compiler=$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$build/CMakeCache.txt")
cpu=$(lscpu | sed -n 's/^Model name: *//p' | head -1)
cores_per_socket=$(lscpu | sed -n 's/^Core(s) per socket: *//p' | head -1)
"$python" bench/peers_report.py "$out/kernels.json" --md "$out/kernels.md" \
  --csv "$out/kernels.csv" --sympy-stats "$build/bench/sympy" --machine \
  "CPU=$cpu" "cores=$(nproc) logical CPUs ($cores_per_socket per socket)" \
  "compiler=$("${compiler:-g++}" --version | head -1), -O3 -march=native" \
  "peers=SymPy $("$python" -c 'import sympy; print(sympy.__version__)'), ADOL-C $adolc_version"
log "done in $((SECONDS - start)) s: $out/kernels.md, kernels.json, kernels.csv"
