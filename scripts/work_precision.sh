#!/usr/bin/env bash
# Regenerates the work-precision report docs/work-precision/ (README.md, PNG plots, CSV): every
# integrator on every problem at a sweep of tolerances, against wide-type references, with the
# Boost.Odeint peers. Progress goes to the terminal. ~5 min on 2 cores (--quick: every other
# tolerance, ~2 min).
# Usage: scripts/work_precision.sh [--quick]
set -euo pipefail
cd "$(dirname "$0")/.."
# Prerequisites, named with the command that installs them (scripts/setup.sh installs them all).
missing=()
for p in libboost-dev libqd-dev python3-matplotlib; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "work_precision.sh: missing Debian packages: ${missing[*]}" >&2
  echo "  install them with: apt-get install ${missing[*]}   (or run scripts/setup.sh as root)" >&2
  exit 1
fi
scripts/setup.sh
build=${EOM_BUILD_DIR:-build}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DEOM_BUILD_BENCH=ON >/dev/null
cmake --build "$build" -j2 --target eom_work_precision
out=docs/work-precision
mkdir -p "$out"
"$build/bench/eom_work_precision" "$out" "$@"
machine=$(mktemp)
{
  echo "date:     $(date -u +%Y-%m-%d)"
  echo "cpu:      $(lscpu | sed -n 's/^Model name: *//p') ($(nproc) cores)"
  echo "compiler: $(${CXX:-c++} --version | head -1), -O3 -march=native"
  echo "os:       $(. /etc/os-release && echo "$PRETTY_NAME")"
} >"$machine"
/usr/bin/python3 bench/plot_work_precision.py "$out/work_precision.csv" "$out" "$machine"
rm -f "$machine"
