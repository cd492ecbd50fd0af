#!/usr/bin/env python3
"""The codegen peer benchmark: writes docs/benchmarks/pinocchio.md (and pinocchio.json).

    bench/pinocchio.py --prefix /opt/eom-peer [--build-dir build-pinocchio] [--runs 3]
                       [--chain 30] [--jobs 2] [--out docs/benchmarks] [--report-only]

--prefix: an install of Pinocchio 3 (built with BUILD_WITH_CODEGEN_SUPPORT), CppAD and
CppADCodeGen (bench/pinocchio_install.sh builds one from their sources). Nothing of them is
vendored or needed by anything else in eomgen.

1. Configures <build-dir> (Release, EOM_BENCH_PINOCCHIO_PREFIX=<prefix>, no tests or demo) and
   builds eom_bench_pinocchio with --jobs parallel jobs (eomgen's kernels for the Panda, the UR5,
   the chain, Romeo on its free base (bundled) and, where MuJoCo and its samples are installed,
   MuJoCo's humanoid on its free base, each with every parameter folded and with every one free).
2. Runs it --runs times (the first run also generates and compiles Pinocchio's CppADCodeGen code,
   kept in <build-dir>/pinocchio_codegen for the later runs).
Then writes the report. The "Discussion" section is written by hand: it is kept, between its
markers, from the existing report. --report-only rewrites the report from pinocchio.json.
Standard library only; needs cmake and g++.
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import time

from scaling import discussion_section, fmt_ns, kept_discussion, machine_info, run_or_exit

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
START = time.monotonic()
KERNELS = ["mass_matrix", "inverse_dynamics", "forward_dynamics", "forward_dynamics_derivatives",
           "inverse_dynamics_derivatives"]
PINOCCHIO = {"mass_matrix": "crba", "inverse_dynamics": "rnea", "forward_dynamics": "aba",
             "forward_dynamics_derivatives": "computeABADerivatives",
             "inverse_dynamics_derivatives": "computeRNEADerivatives"}
PAIRS = ["folded / Pinocchio codegen", "free / Pinocchio codegen", "folded / Pinocchio"]
ROUTES = ["folded", "free", "codegen", "pinocchio"]
ROBOTS = ["panda", "ur5", "chain", "humanoid", "romeo"]
FREE_BASE = ("humanoid", "romeo")  # their reference is Pinocchio in double
LINE = re.compile(r"^(\w+)/(\w+): (.+?)\s+([\d.]+) ns\s+([\d.]+) ns\s+ratio ([\d.]+)$")
ACCURACY = re.compile(r"^accuracy\s+(\w+)\s+(\w+)\s+(.*)$")


def progress(message):
    print(f"pinocchio: [{time.monotonic() - START:6.0f} s] {message}", file=sys.stderr, flush=True)


def run(command, **kw):
    return run_or_exit("pinocchio.py", command, **kw)


def versions(prefix):
    """The peers' versions, from the install's headers and pkg-config files."""
    def grep(path, pattern):
        try:
            with open(os.path.join(prefix, path), encoding="utf-8") as f:
                m = re.search(pattern, f.read(), re.M)
            return m.group(1) if m else "?"
        except OSError:
            return "?"
    return {
        "Pinocchio": grep("include/pinocchio/config.hpp", r'PINOCCHIO_VERSION\s+"([^"]+)"'),
        "CppAD": grep("include/cppad/configure.hpp", r'CPPAD_PACKAGE_STRING\s+"cppad-([^"]+)"'),
        "CppADCodeGen": grep("lib/pkgconfig/cppadcg.pc", r"^Version:\s*(\S+)")
                        if os.path.exists(os.path.join(prefix, "lib/pkgconfig/cppadcg.pc"))
                        else grep("share/pkgconfig/cppadcg.pc", r"^Version:\s*(\S+)"),
    }


def build(build_dir, prefix, chain, jobs):
    progress(f"configuring {build_dir}")
    run(["cmake", "-S", ROOT, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
         "-DEOM_BUILD_TESTS=OFF", "-DEOM_BUILD_DEMO=OFF", "-DEOM_CUDA=OFF",
         f"-DEOM_BENCH_PINOCCHIO_PREFIX={prefix}", f"-DEOM_BENCH_PINOCCHIO_CHAIN={chain}"],
        stdout=subprocess.DEVNULL)
    progress(f"building eom_bench_pinocchio (ten generated kernel sets; Pinocchio's headers; "
             f"{jobs} jobs)")
    run(["cmake", "--build", build_dir, f"-j{jobs}", "--target", "eom_bench_pinocchio"],
        stdout=subprocess.DEVNULL)


def bench(build_dir, runs):
    exe = os.path.join(build_dir, "bench", "eom_bench_pinocchio")
    cache = os.path.join(build_dir, "pinocchio_codegen")
    ratios, times, accuracy, generate_s, load = {}, {}, {}, None, []
    for r in range(runs):
        progress(f"run {r + 1} of {runs}")
        t0 = time.monotonic()
        out = run([exe, cache], capture_output=True, text=True).stdout
        if r == 0:
            generate_s = time.monotonic() - t0
        load.append([round(x, 2) for x in os.getloadavg()])
        for line in out.splitlines():
            m = LINE.match(line.strip())
            if m:
                key = f"{m.group(1)}/{m.group(2)}/{m.group(3)}"
                ratios.setdefault(key, []).append(float(m.group(6)))
                times.setdefault(key, []).append([float(m.group(4)), float(m.group(5))])
            m = ACCURACY.match(line.strip())
            if m:
                accuracy[f"{m.group(1)}/{m.group(2)}"] = dict(
                    (k, float(v)) for k, v in re.findall(r"(\w+)=(\S+)", m.group(3)))
    return {"ratios": ratios, "ns": times, "accuracy": accuracy,
            "first_run_s": generate_s, "load_after_runs": load}


def report(result, path):
    ratios, ns, acc = result["ratios"], result["ns"], result["accuracy"]
    robots = [r for r in ROBOTS if f"{r}/mass_matrix" in acc]
    n = {"panda": 7, "ur5": 6, "chain": result["chain"], "humanoid": 27, "romeo": 37}
    v = result["versions"]
    lines = [
        "# The codegen peer: Pinocchio and its CppADCodeGen output",
        "",
        "Regenerate with `bench/pinocchio.py --prefix <install>` (builds `eom_bench_pinocchio` in "
        "`build-pinocchio/`, runs it three times and writes this file and `pinocchio.json`); "
        "`bench/pinocchio_install.sh` builds such an install from the peers' sources. Opt-in: "
        "nothing else in eomgen needs Pinocchio, CppAD or CppADCodeGen, and none of them is "
        "vendored.",
        "",
        "## Machine and peers",
        "",
    ]
    for k, val in result["machine"].items():
        lines.append(f"- {k}: {val}")
    if result.get("load_after_runs"):
        lines.append("- load average at the end of each run: " +
                     "; ".join(" ".join(f"{x:.2f}" for x in l) for l in result["load_after_runs"]))
    lines += [
        f"- Pinocchio {v['Pinocchio']}, CppAD {v['CppAD']}, CppADCodeGen {v['CppADCodeGen']} "
        "(built from their published sources by `bench/pinocchio_install.sh`)",
        "",
        "## What is timed",
        "",
        "`bench/bench_pinocchio.cpp`, one binary compiled with `-O3 -march=native`, eomgen's "
        "kernel libraries with the same flags. Robots: the Panda, the UR5 (models/robots) and "
        f"the planar chain of {result['chain']} links (bench/robots/chain{result['chain']}.urdf), each "
        "read by eomgen's URDF reader; the Pinocchio model is built from what it read "
        "(`urdf_pinocchio_model`, bench/pinocchio_model.hpp: moving joints in file order, "
        "RX/RY/RZ for principal axes, fixed joints merged into their parent body), so both sides "
        "integrate the same numbers. And MuJoCo's humanoid (humanoid.xml, 27 velocities: a free "
        "base and 21 hinges) read by eomgen-mjcf, the Pinocchio model built from eomgen's "
        "tree-form header (`tree_pinocchio_model`: a `JointModelFreeFlyer`, the hinges, their "
        "armature). And Romeo (tests/urdf/robots/published/romeo_small.urdf, from "
        "example-robot-data: 37 velocities, a free root and 31 revolute joints) read by eomgen's URDF "
        "reader with its root freed (`FLOATING_BASE`) and its two inconsistent arm inertias taken "
        "as published (`INERTIA_POLICY warn`), the Pinocchio model built from what it read "
        "(`urdf_pinocchio_model` with a `JointModelFreeFlyer` on the root link; this Pinocchio "
        "has no URDF parser). Routes:",
        "",
        "- **folded**: eomgen's kernels with `FIXED_PARAMETERS ALL` (every inertial parameter, "
        "damping and g folded at the URDF's values);",
        "- **free**: the same kernels with every parameter a run-time `p` (the URDF import's "
        "default);",
        "- **Pinocchio codegen**: Pinocchio's `CodeGenCRBA`, `CodeGenRNEA`, `CodeGenABA`, "
        "`CodeGenABADerivatives`, `CodeGenRNEADerivatives` (pinocchio/codegen/"
        "code-generator-algo.hpp): the algorithm taped once with CppADCodeGen (forward sweep "
        "only), its C code compiled by gcc with `-O3 -march=native` (the flags of eomgen's side; "
        "Pinocchio's own default is `-Ofast`, which lets the compiler reassociate) into a shared "
        "library, and the library's `forward_zero` entry point called as a raw C function (no "
        "CppAD::cg::GenericModel vectors in between; bench/pinocchio_codegen.cpp), its packed "
        "input [q; v; a] or [q; v; τ] precomputed per state;",
        "- **Pinocchio**: the same algorithms in double (`crba`, `rnea`, `aba`, "
        "`computeABADerivatives`, `computeRNEADerivatives`), header-only.",
        "",
        "Where the work differs, the peer is spared: eomgen's kernels include the URDF's joint "
        "damping (Q = u − d⊙q̇), Pinocchio gets τ = u − d⊙q̇ precomputed; `crba` fills the upper "
        "triangle of M only, eomgen all of it; `computeRNEADerivatives` also returns ∂τ/∂q̈ = M, "
        "which eomgen's `inverse_dynamics_derivatives` does not (call `mass_matrix` for it); "
        "`computeABADerivatives` and eomgen's `forward_dynamics_derivatives` both return M⁻¹. "
        "The humanoid: its generalized forces are MuJoCo's (gear · ctrl, joint springs and "
        "dampers; Q(q, v, u)), which eomgen's kernels compute and Pinocchio gets precomputed as "
        "τ = Q; eomgen's `forward_dynamics_derivatives` returns ∂q̈/∂u = M⁻¹B (27×21) where "
        "Pinocchio returns M⁻¹ (27×27). Conventions differ on a free base (Pinocchio's quaternion "
        "x y z w, base linear velocity in base axes, its own tangent directions; eomgen's w x y z, "
        "world axes, (δx world, δθ base axes)): each side is timed on its own inputs, "
        "precomputed per state, with its raw outputs; the conversion (bench_pinocchio.cpp, "
        "`run_floating`) is used for the accuracy check only. Romeo's generalized forces are "
        "Q = (0, u) (no damping in its file; one input per joint), Pinocchio's τ = Q, and "
        "eomgen's ∂q̈/∂u is 37×31. Each "
        "pair is timed by `eombench::compare` (bench/paired_timing.hpp): 201 alternating rounds of "
        "1000 calls on a pool of 64 random states, the figure the median of the per-round "
        "ratios, so that load changes both sides alike.",
        "",
        "## Accuracy",
        "",
        "On 16 states, every route against Featherstone's algorithms in double-double "
        "(tests/support/recursive_dynamics.hpp; derivatives by central differences in "
        "double-double, h = 1e-10); max-abs error over max(1, max-abs reference). The run aborts "
        "above 1e-8 (a model mismatch). The free-base robots' (the humanoid's, Romeo's) reference "
        "is Pinocchio's algorithms in "
        "double (its column reads \"reference\"), each route's outputs converted to eomgen's "
        "conventions: tests/support's recursive implementation reads a URDF robot (a free base, "
        "but not MuJoCo's armature, joint springs and off-origin joint anchors; and "
        "`PinocchioTruth` differentiates along q, not the free joint's tangent), so these "
        "figures are agreement with Pinocchio in double, not errors against a double-double truth.",
        "",
        "| robot | kernel | eomgen folded | eomgen free | Pinocchio codegen | Pinocchio |",
        "|---|---|---|---|---|---|",
    ]
    for robot in robots:
        for kernel in KERNELS:
            a = acc.get(f"{robot}/{kernel}", {})
            cells = [f"{a[r]:.1e}" if r in a else
                     "reference" if robot in FREE_BASE and r == "pinocchio" else "–" for r in ROUTES]
            lines.append(f"| {robot} | {kernel} | " + " | ".join(cells) + " |")
    runs = result["runs"]
    lines += [
        "",
        f"## Ratios (median of per-round ratios; {runs} runs, each shown)",
        "",
        "| robot | kernel | folded / Pinocchio codegen | free / Pinocchio codegen | "
        "folded / Pinocchio | ns: folded, free, codegen, Pinocchio (last run) |",
        "|---|---|---|---|---|---|",
    ]
    for robot in robots:
        for kernel in KERNELS:
            cells = []
            for pair in PAIRS:
                rs = ratios.get(f"{robot}/{kernel}/{pair}", [])
                cells.append(" / ".join(f"{x:.2f}" for x in rs) or "–")
            t = {pair: ns.get(f"{robot}/{kernel}/{pair}", [[None, None]])[-1] for pair in PAIRS}
            times = [t[PAIRS[0]][0], t[PAIRS[1]][0], t[PAIRS[0]][1], t[PAIRS[2]][1]]
            lines.append(f"| {robot} ({n[robot]}) | {kernel} | " + " | ".join(cells) + " | " +
                         ", ".join(fmt_ns(x) for x in times) + " |")
    lines += [
        "",
        "## Targets (issue 34: the arms; issue 50: the chain, the humanoid and Romeo; every kernel)",
        "",
        "| target | the worst run's figure (every kernel above the limit, else the largest) | |",
        "|---|---|---|",
    ]
    for pair, limit in (("folded / Pinocchio codegen", 0.8), ("free / Pinocchio codegen", 1.0)):
        for robot in ROBOTS:
            if robot not in robots:
                continue
            worst = {k: max(ratios.get(f"{robot}/{k}/{pair}", [float("inf")])) for k in KERNELS}
            over = [f"{k} {x:.2f}" for k, x in worst.items() if x > limit]
            top = max(worst, key=worst.get)
            figure = "; ".join(over) if over else f"{worst[top]:.2f} ({top})"
            met = "**met**" if not over else "**not met**"
            lines.append(f"| {robot}: every kernel, {pair} ≤ {limit} | {figure} | {met} |")
    lines += [
        "",
        f"The first run took {result['first_run_s']:.0f} s in all (it also generates and compiles "
        "Pinocchio's code, unless the build directory holds the libraries already).",
        "",
    ] + discussion_section("pinocchio.py", result.get("discussion"))
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--prefix", help="the Pinocchio + CppAD + CppADCodeGen install")
    parser.add_argument("--build-dir", default=os.path.join(ROOT, "build-pinocchio"))
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--chain", type=int, default=30)
    parser.add_argument("--jobs", type=int, default=2, help="parallel build jobs (default 2)")
    parser.add_argument("--out", default=os.path.join(ROOT, "docs", "benchmarks"))
    parser.add_argument("--report-only", action="store_true")
    args = parser.parse_args()
    md, js = os.path.join(args.out, "pinocchio.md"), os.path.join(args.out, "pinocchio.json")
    if args.report_only:
        with open(js, encoding="utf-8") as f:
            result = json.load(f)
    else:
        if not args.prefix:
            sys.exit("pinocchio.py: --prefix <install of Pinocchio, CppAD, CppADCodeGen> is "
                     "required (bench/pinocchio_install.sh builds one)")
        prefix = os.path.abspath(args.prefix)
        machine = machine_info()
        build(args.build_dir, prefix, args.chain, args.jobs)
        result = bench(args.build_dir, args.runs)
        result.update(machine=machine, versions=versions(prefix), runs=args.runs,
                      chain=args.chain)
    discussion = kept_discussion(md, "pinocchio.py")
    if discussion:
        result["discussion"] = discussion
    with open(js, "w", encoding="utf-8") as f:
        json.dump(result, f, indent=1)
    report(result, md)
    progress(f"wrote {md}")


if __name__ == "__main__":
    main()
