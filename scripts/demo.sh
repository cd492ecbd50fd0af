#!/usr/bin/env bash
# The main job: installs what is missing, builds, simulates the paper's examples and writes
# the report with plots to report/ (report/README.md is the entry point).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
build=${EOM_BUILD_DIR:-build}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j2 --target eom_demo
mkdir -p report
"$build/demo/eom_demo" report
# The same Monte Carlo over two MPI ranks (loopback; OpenMPI refuses root without these variables).
if cmake --build "$build" -j2 --target eom_demo_mpi 2>/dev/null && command -v mpiexec >/dev/null; then
  OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none \
    mpiexec -n 2 --oversubscribe --mca btl self,vader "$build/demo/eom_demo_mpi" report ||
    echo "eom_demo_mpi failed: the report leaves out the MPI row" >&2
else
  echo "MPI not available: the report leaves out the MPI row" >&2
  rm -f report/monte_carlo_mpi.csv
fi
# Debian's python3-matplotlib belongs to /usr/bin/python3, which may not be the first python3 on PATH.
python=python3
for candidate in /usr/bin/python3 python3; do
  if "$candidate" -c "import matplotlib" 2>/dev/null; then python=$candidate; break; fi
done
# The example controllers (examples/): user projects built against this source tree; each writes
# its closed-loop response CSV into report/ and prints whether it met its bounds.
build_dir=$(cd "$build" && pwd)
for example in computed_torque lqr_cartpole panda_osc; do
  cmake -S "examples/$example" -B "$build/examples/$example" -DCMAKE_BUILD_TYPE=Release \
        -DEOMGEN_SOURCE_DIR="$(pwd)" >/dev/null
  cmake --build "$build/examples/$example" -j2 --target "$example" >/dev/null
  (cd report && "$build_dir/examples/$example/$example")
done
"$python" examples/plot_examples.py --csv-dir report --out-dir report
"$python" demo/plot.py report
echo "report written: $(pwd)/report/README.md"
