#!/usr/bin/env bash
# MuJoCo's humanoid: the generated forward dynamics and derivatives against MuJoCo itself, side
# by side in one binary (bench/bench_mujoco.cpp). Writes docs/benchmarks/mujoco.md.
#
#   bench/mujoco.sh
#
# Builds eom_bench_mujoco in $EOM_BENCH_BUILD_DIR (default build-bench/) with EOM_BENCH_MUJOCO=ON;
# the humanoid's derivative kernel takes a few minutes to compile the first time.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${EOM_BENCH_BUILD_DIR:-build-bench}
out=docs/benchmarks/mujoco.md
for need in /usr/include/mujoco/mujoco.h /usr/share/mujoco/model/humanoid/humanoid.xml; do
  [ -e "$need" ] || { echo "mujoco.sh: $need missing (apt-get install libmujoco-dev libmujoco-samples)" >&2; exit 1; }
done
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DEOM_BENCH_MUJOCO=ON >/dev/null
cmake --build "$build" -j2 --target eom_bench_mujoco
result=$("$build/bench/eom_bench_mujoco")
echo "$result"
cpu=$(lscpu | sed -n 's/^Model name: *//p' | head -1)
{
  echo "# MuJoCo's humanoid: eomgen against MuJoCo"
  echo
  echo "bench/mujoco.sh on $cpu ($(nproc) logical CPUs), $(g++ --version | head -1), -O3 -march=native;"
  echo "median of 201 alternating rounds of 1000 calls (bench/paired_timing.hpp). mjd_transitionFD"
  echo "computes a whole step's transition matrices by centred differences of mj_step: the figure"
  echo "issue 47 names, not the same quantity as forward_dynamics_derivatives' exact ∂v̇/∂(q, v, u)."
  echo
  echo '```'
  echo "$result"
  echo '```'
} >"$out"
echo "mujoco.sh: wrote $out" >&2
