#!/usr/bin/env bash
# Where the test suite's build time goes: configures a fresh build directory as scripts/test.sh
# does (Release, -DEOM_WERROR=ON, no benchmarks), builds it with every compile, link and
# build-time command (the tracers' runs, eomgen-urdf, eomgen-mjcf) under GNU time, and prints
# CPU seconds by kind and the most expensive commands. CPU seconds, not wall: they barely move on
# a loaded machine. About the suite's build time (~17 min on 2 cores).
# Usage: scripts/build_census.sh [build dir, default build-census] [how many to list, default 30]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
build=$(realpath -m "${1:-build-census}")
top=${2:-30}
rm -rf "$build"
mkdir -p "$build"
log="$build/census.txt"
# Every command of the build through the launchers: one 'user|sys|peak KB|command' line each.
cat > "$build/launchers.cmake" <<EOF
set(time "/usr/bin/time -a -o $log -f '%U|%S|%M|%C'")
set_property(GLOBAL PROPERTY RULE_LAUNCH_COMPILE "\${time}")
set_property(GLOBAL PROPERTY RULE_LAUNCH_LINK "\${time}")
set_property(GLOBAL PROPERTY RULE_LAUNCH_CUSTOM "\${time}")
EOF
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DEOM_WERROR=ON -DEOM_BUILD_BENCH=OFF \
      "-DCMAKE_PROJECT_INCLUDE=$build/launchers.cmake" >/dev/null
start=$(date +%s)
cmake --build "$build" -j2 >/dev/null
echo "built in $(( $(date +%s) - start )) s (wall); CPU seconds by kind:"
/usr/bin/python3 - "$log" "$top" <<'EOF'
import re, sys
log, top = sys.argv[1], int(sys.argv[2])
rows = []
for line in open(log, encoding="utf-8", errors="replace"):
    parts = line.rstrip("\n").split("|", 3)
    if len(parts) != 4 or not re.match(r"^[\d.]+$", parts[0]):
        continue  # GNU time's notes
    cpu, command = float(parts[0]) + float(parts[1]), parts[3]
    out = re.search(r" -o (\S+)", command)
    what = out.group(1) if out else command[:160]
    if "--out-dir" in command:
        kind = "tracer runs (generation)"
    elif "eomgen-urdf" in command or "eomgen-mjcf" in command:
        kind = "URDF/MJCF readers"
    elif " -c " not in command:
        kind = "links and other commands"
    elif "eomgen_tracer_" in what:
        kind = "tracer compiles (-O0)"
    elif "/eomgen/" in what:
        kind = "generated kernels and Python modules"
    elif re.search(r"CMakeFiles/(eom_generator|eom_urdf|eom_mjcf|eomgen_urdf|eomgen_mjcf)\.dir", what):
        kind = "the generator"
    else:
        kind = "test programs, demo, support"
    rows.append((cpu, kind, what, int(parts[2]) / 1024))
kinds = {}
for cpu, kind, _, _ in rows:
    kinds[kind] = kinds.get(kind, 0.0) + cpu
for kind, cpu in sorted(kinds.items(), key=lambda k: -k[1]):
    print(f"  {cpu:8.1f} s  {kind}")
print(f"  {sum(kinds.values()):8.1f} s  in all, {len(rows)} commands\nthe {top} most expensive:")
for cpu, kind, what, mb in sorted(rows, reverse=True)[:top]:
    print(f"  {cpu:7.1f} s {mb:6.0f} MB  {what}")
EOF
