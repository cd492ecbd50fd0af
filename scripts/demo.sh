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
# Debian's python3-matplotlib belongs to /usr/bin/python3, which may not be the first python3 on PATH.
python=python3
for candidate in /usr/bin/python3 python3; do
  if "$candidate" -c "import matplotlib" 2>/dev/null; then python=$candidate; break; fi
done
"$python" demo/plot.py report
echo "report written: $(pwd)/report/README.md"
