#!/usr/bin/env python3
"""The robot benchmark: writes docs/benchmarks/robots.md (and robots.json).

    bench/robots.py [--build-dir build-robots] [--repetitions 10] [--min-time 0.2]
                    [--out docs/benchmarks] [--report-only]

1. Configures <build-dir> (Release, EOM_BENCH_ROBOT_CHAINS=ON) and builds eom_bench_robots.
2. The Panda's full kernel set: eomgen-urdf (URDF -> model header), the tracer's run (trace,
   derive, emit: wall and CPU seconds, peak memory by /usr/bin/time -v) and the compile of the
   emitted .cpp alone with `g++ -std=c++17 -O2 -c` (seconds, peak memory).
3. Runs eom_bench_robots with --benchmark_repetitions and takes each benchmark's median CPU time.
Then writes the report. The "Discussion" section is written by hand: it is kept, between its
markers, from the existing report. --report-only rewrites the report from robots.json. Standard
library only; needs cmake, g++ and GNU time (/usr/bin/time).
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

# shared with the other studies (bench/scaling.py): /usr/bin/time -v around a command, the machine,
# ns in tables, the steps that must succeed, the kept discussion
from scaling import (discussion_section, fmt_ns, kept_discussion, machine_info, run_or_exit,
                     timed)
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
START = time.monotonic()
KERNELS = ["mass_matrix", "forward_dynamics", "inverse_dynamics", "forward_dynamics_derivatives"]
RECURSIVE = {"mass_matrix": "CRBA", "forward_dynamics": "ABA", "inverse_dynamics": "RNEA",
             "forward_dynamics_derivatives": "FD of ABA"}
ROBOTS = ["panda", "ur5", "chain2", "chain5", "chain10", "chain20", "chain30"]
DOF = {"panda": 7, "ur5": 6, "chain2": 2, "chain5": 5, "chain10": 10, "chain20": 20, "chain30": 30}


def progress(message):
    print(f"robots: [{time.monotonic() - START:6.0f} s] {message}", file=sys.stderr, flush=True)


def check_prerequisites():
    missing = []
    if not os.access("/usr/bin/time", os.X_OK):
        missing.append("time")
    for tool, package in (("cmake", "cmake"), ("g++", "g++")):
        if shutil.which(tool) is None:
            missing.append(package)
    if missing:
        sys.exit("robots.py: missing prerequisites; install them with: apt-get install " +
                 " ".join(missing))


def run(command, **kw):
    return run_or_exit("robots.py", command, **kw)


def build(build_dir):
    progress(f"configuring {build_dir}")
    run(["cmake", "-S", ROOT, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
         "-DEOM_BENCH_ROBOT_CHAINS=ON", "-DEOM_BUILD_DEMO=OFF"], stdout=subprocess.DEVNULL)
    progress("building eom_bench_robots (the Panda's, the UR5's and five chains' generated code)")
    run(["cmake", "--build", build_dir, "-j2", "--target", "eom_bench_robots",
         "eomgen_tracer_panda", "eomgen_urdf"], stdout=subprocess.DEVNULL)


def panda_generation(build_dir):
    """eomgen-urdf, the tracer's run and the -O2 compile of the Panda's full kernel set."""
    tool = os.path.join(build_dir, "generator", "eomgen-urdf")
    tracer = os.path.join(build_dir, "models", "eomgen", "panda.tracer", "eomgen_tracer_panda")
    urdf = os.path.join(ROOT, "models", "robots", "panda.urdf")
    out = {}
    with tempfile.TemporaryDirectory(prefix="eom-robots-") as work:
        progress("eomgen-urdf panda.urdf")
        rc, wall, cpu, mb, err = timed([tool, urdf, "--class", "panda", "--namespace",
                                        "eom::urdf_models", "-o", os.path.join(work, "model.hpp")])
        if rc != 0:
            sys.exit(f"robots.py: eomgen-urdf failed:\n{err[-2000:]}")
        out["urdf_s"], out["urdf_mb"] = wall, mb
        progress("compiling the Panda's tracer (flags of the build: flags.make)")
        flags = {}
        with open(os.path.join(build_dir, "models", "CMakeFiles", "eomgen_tracer_panda.dir",
                               "flags.make"), encoding="utf-8") as f:
            for line in f:
                m = re.match(r"^(CXX_\w+) = (.*)$", line)
                if m:
                    flags[m.group(1)] = m.group(2).split()
        source_file = os.path.join(os.path.dirname(tracer), "panda_tracer.cpp")
        rc, wall, cpu, mb, err = timed(["g++", *flags.get("CXX_DEFINES", []),
                                        *flags.get("CXX_INCLUDES", []), *flags.get("CXX_FLAGS", []),
                                        "-c", source_file, "-o", os.path.join(work, "tracer.o")])
        if rc != 0:
            sys.exit(f"robots.py: compiling the tracer failed:\n{err[-2000:]}")
        out["tracer_compile_s"], out["tracer_compile_mb"] = wall, mb
        out["tracer_flags"] = " ".join(flags.get("CXX_FLAGS", []))
        progress("the Panda's tracer (every kernel)")
        rc, wall, cpu, mb, err = timed([tracer, "--name", "panda", "--class",
                                        "eom::urdf_models::panda", "--namespace", "panda",
                                        "--out-dir", work])
        if rc != 0:
            sys.exit(f"robots.py: the tracer failed:\n{err[-2000:]}")
        out["generate_s"], out["generate_cpu_s"], out["generate_mb"] = wall, cpu, mb
        cpp = os.path.join(work, "panda.cpp")
        out["cpp_bytes"] = os.path.getsize(cpp)
        out["hpp_bytes"] = os.path.getsize(os.path.join(work, "panda.hpp"))
        with open(cpp, encoding="utf-8") as f:
            source = f.read()
        # (not the <kernel>_prepare functions of the parameter caches)
        out["kernels"] = sorted(set(k for k in re.findall(r"^// panda: (\w+) \(", source, re.M)
                                    if not k.endswith("_prepare")))
        progress("g++ -std=c++17 -O2 -c panda.cpp")
        rc, wall, cpu, mb, err = timed(["g++", "-std=c++17", "-O2", "-c", cpp, "-I", work,
                                        "-o", os.path.join(work, "panda.o")])
        if rc != 0:
            sys.exit(f"robots.py: compiling panda.cpp failed:\n{err[-2000:]}")
        out["compile_s"], out["compile_cpu_s"], out["compile_mb"] = wall, cpu, mb
    return out


def run_benchmark(build_dir, repetitions, min_time):
    exe = os.path.join(build_dir, "bench", "eom_bench_robots")
    with tempfile.TemporaryDirectory(prefix="eom-robots-") as work:
        json_out = os.path.join(work, "bench.json")
        progress(f"eom_bench_robots, {repetitions} repetitions (a few minutes)")
        result = run([exe, f"--benchmark_repetitions={repetitions}",
                      f"--benchmark_min_time={min_time}", "--benchmark_report_aggregates_only=true",
                      f"--benchmark_out={json_out}", "--benchmark_out_format=json"],
                     capture_output=True, text=True)
        with open(json_out, encoding="utf-8") as f:
            data = json.load(f)
        data["context"]["executable"] = "bench/eom_bench_robots"  # no machine path
    agreement = [line[len("agreement "):] for line in result.stdout.splitlines()
                 if line.startswith("agreement ")]
    medians = {}
    for b in data["benchmarks"]:
        if b.get("run_type") == "aggregate" and b.get("aggregate_name") == "median":
            assert b["time_unit"] == "ns"
            medians[b["run_name"]] = b["cpu_time"]
    return {"median_ns": medians, "agreement": agreement, "context": data["context"]}


def operation_counts(build_dir):
    """{robot: {kernel: operations}} from the generated sources' comments."""
    sources = {"panda": ("models", "panda"), "ur5": ("models", "ur5")}
    for robot in ROBOTS[2:]:
        sources[robot] = ("bench", "robot_" + robot)
    out = {}
    for robot, (where, name) in sources.items():
        path = os.path.join(build_dir, where, "eomgen", name, name + ".cpp")
        if not os.path.exists(path):
            continue
        with open(path, encoding="utf-8") as f:
            text = f.read()
        out[robot] = {k: int(n) for k, n in
                      re.findall(rf"^// {name}: (\w+) \((\d+) operations", text, re.M)}
    return out


def verdict(ok):
    return "**met**" if ok else "**not met**"


def report(result, path):
    med = result["bench"]["median_ns"]
    gen = result["generation"]
    reps = result["repetitions"]

    ops = result.get("operations", {})

    def ns(robot, kernel, route):
        return med.get(f"{robot}/{kernel}/{route}")

    lines = [
        "# Robots from URDF: generated kernels against the recursive algorithms",
        "",
        "Regenerate with `bench/robots.py` (builds `eom_bench_robots` with "
        "`-DEOM_BENCH_ROBOT_CHAINS=ON` in `build-robots/`, measures the Panda's generation and "
        "compile, runs the benchmark and writes this file and `robots.json`; about 10 minutes on "
        "this machine). The benchmark alone:",
        "",
        "```",
        f"{result.get('build_dir', 'build-robots')}/bench/eom_bench_robots --benchmark_repetitions={reps} "
        f"--benchmark_min_time={result['min_time']} --benchmark_report_aggregates_only=true",
        "```",
        "",
        "## Machine",
        "",
    ]
    for k, v in result["machine"].items():
        lines.append(f"- {k}: {v}")
    lines += [
        "",
        "## What is timed",
        "",
        "`bench/bench_robots.cpp`, one binary, compiled with `-O3 -march=native`; the generated "
        "`.cpp` of the Panda and the UR5 are compiled into it, the chains' libraries with the same "
        "flags. Three routes on the same pool of 64 random states (q ∈ [−3, 3], q̇ ∈ [−2, 2], "
        "u ∈ [−10, 10], q̈ ∈ [−2, 2]; one call per iteration, cycling through the pool), all with "
        "the URDF's own numbers:",
        "",
        "- **generated**: the kernels `add_eom_model(<name> URDF <file>)` writes (every inertial "
        "parameter and damping is a run-time parameter `p`, as the URDF import makes them);",
        "- **recursive**: `eomtest::RecursiveDynamics<double>` (tests/support/recursive_dynamics.hpp),"
        " built from the same URDF file: CRBA for `mass_matrix`, ABA for `forward_dynamics`, RNEA "
        "for `inverse_dynamics`, and for `forward_dynamics_derivatives` forward differences of the "
        "ABA over q and q̇, 2n + 1 ABA calls (the issue's baseline; the generated kernel also "
        "returns ∂q̈/∂u = M⁻¹, the baseline does not). These are the algorithms Pinocchio and RBDL "
        "run, but this is our own straightforward implementation (6×6 matrices as arrays, no "
        "SIMD-friendly layout, no sparsity tricks): a tuned library would be faster;",
        "- **Reference**: `eom::Reference<Model>` (run-time AD) on the model header eomgen-urdf "
        "wrote.",
        "",
        "Before anything is timed, the three routes are compared on all 64 states (max-abs "
        "difference / max(1, max-abs reference value)); the run aborts above 1e-8 (above 1e-4 for "
        "the finite differences, whose truncation and rounding errors are 1e-7 to 1e-5 here). Measured worst differences:",
        "",
        "| robot | comparison | worst |",
        "|---|---|---|",
    ]
    for a in result["bench"]["agreement"]:
        m = re.match(r"(\S+)\s+(.*?)\s+(\S+)$", a)
        if m:
            lines.append(f"| {m.group(1)} | {m.group(2)} | {m.group(3)} |")
    lines += [
        "",
        f"## ns per call (median CPU time of {reps} repetitions)",
        "",
        "| robot | n | kernel | generated | recursive | Reference | generated / recursive | "
        "generated / Reference | generated: operations |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for robot in ROBOTS:
        for kernel in KERNELS:
            g, r, f = ns(robot, kernel, "generated"), ns(robot, kernel, "recursive"), \
                ns(robot, kernel, "reference")
            if g is None:
                continue
            lines.append(f"| {robot} | {DOF[robot]} | {kernel} | {fmt_ns(g)} | {fmt_ns(r)} "
                         f"({RECURSIVE[kernel]}) | {fmt_ns(f) if f else '—'} | {g / r:.2f} | "
                         f"{f'{g / f:.3f}' if f else '—'} | {ops.get(robot, {}).get(kernel, '?')} |")
    lines += [
        "",
        "Recursive: CRBA, ABA, RNEA; for `forward_dynamics_derivatives`, forward differences of "
        "the ABA, 2n + 1 ABA calls. Operations: the generated kernel's count, as the generator "
        "writes it in the emitted source. From 30 coordinates the derivatives take the looped "
        "solve (generator/README.md); the Reference's derivatives of the chain N = 30 are not "
        "run (—): their stack grows about as n³, from more than 1 GB at N = 20 to near the "
        "benchmark's 4 GB (not tried); the generated kernel is checked against the ABA's "
        "differences there.",
        "",
        "## The Panda's full kernel set: generation and compile",
        "",
        f"Kernels: {', '.join(gen['kernels'])}. Generated `panda.cpp` {gen['cpp_bytes'] / 1e6:.1f} MB"
        f" (`panda.hpp` {gen['hpp_bytes'] / 1e3:.0f} kB). Wall seconds of one process on a shared "
        "machine, CPU seconds beside them; memory is the peak resident set size by "
        "`/usr/bin/time -v`.",
        "",
        "| step | wall s | CPU s | peak MB |",
        "|---|---|---|---|",
        f"| eomgen-urdf (URDF → model header) | {gen['urdf_s']:.2f} | | {gen['urdf_mb']:.0f} |",
        f"| tracer run (trace, derive, emit) | {gen['generate_s']:.2f} | "
        f"{gen['generate_cpu_s']:.2f} | {gen['generate_mb']:.0f} |",
        f"| `g++ -std=c++17 -O2 -c panda.cpp` | {gen['compile_s']:.1f} | {gen['compile_cpu_s']:.1f} |"
        f" {gen['compile_mb']:.0f} |",
        "",
        "The generation target is the tracer run. In a build the tracer program is compiled "
        "first (the model header with the generator's templates; linking it with the generator "
        "library is not timed): "
        f"{gen['tracer_compile_s']:.1f} s, {gen['tracer_compile_mb']:.0f} MB at "
        f"`{gen['tracer_flags']}`.",
        "",
        "## Targets",
        "",
        "| target | figure | |",
        "|---|---|---|",
    ]
    for robot in ("panda", "ur5"):
        for kernel, name in (("forward_dynamics", "ABA"), ("inverse_dynamics", "RNEA"),
                             ("forward_dynamics_derivatives", "FD of ABA")):
            g, r = ns(robot, kernel, "generated"), ns(robot, kernel, "recursive")
            ratio = g / r
            lines.append(f"| {robot}: {kernel} ≤ 0.5 × {name} | {fmt_ns(g)} / {fmt_ns(r)} ns = "
                         f"{ratio:.2f} | {verdict(ratio <= 0.5)} |")
    lines += [
        f"| Panda, full kernel set generated in < 2 s | {gen['generate_s']:.2f} s (tracer run) | "
        f"{verdict(gen['generate_s'] < 2)} |",
        f"| Panda, full kernel set compiled (-O2) in < 60 s and < 1 GiB | {gen['compile_s']:.1f} s, "
        f"{gen['compile_mb']:.0f} MB | {verdict(gen['compile_s'] < 60 and gen['compile_mb'] < 1024)} |",
        "",
    ] + discussion_section("robots.py", result.get("discussion"))
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build-dir", default=os.path.join(ROOT, "build-robots"))
    parser.add_argument("--repetitions", type=int, default=10)
    parser.add_argument("--min-time", type=float, default=0.2)
    parser.add_argument("--out", default=os.path.join(ROOT, "docs", "benchmarks"))
    parser.add_argument("--report-only", action="store_true")
    args = parser.parse_args()
    md, js = os.path.join(args.out, "robots.md"), os.path.join(args.out, "robots.json")
    if args.report_only:
        with open(js, encoding="utf-8") as f:
            result = json.load(f)
    else:
        check_prerequisites()
        machine = machine_info()
        build(args.build_dir)
        generation = panda_generation(args.build_dir)
        bench = run_benchmark(args.build_dir, args.repetitions, args.min_time)
        result = {"machine": machine, "generation": generation, "bench": bench,
                  "operations": operation_counts(args.build_dir),
                  "repetitions": args.repetitions, "min_time": args.min_time,
                  "build_dir": os.path.relpath(args.build_dir, ROOT)}
        with open(js, "w", encoding="utf-8") as f:
            json.dump(result, f, indent=1)
    discussion = kept_discussion(md, "robots.py")
    if discussion:
        result["discussion"] = discussion
    report(result, md)
    progress(f"wrote {md}")


if __name__ == "__main__":
    main()
