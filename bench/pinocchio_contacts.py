#!/usr/bin/env python3
"""The contact benchmark against Pinocchio: writes docs/benchmarks/pinocchio_contacts.md.

    bench/pinocchio_contacts.py --prefix /opt/eom-peer [--build-dir build-pinocchio-contacts]
                                [--runs 3] [--jobs 1] [--out docs/benchmarks] [--no-build]
                                [--report-only]

--prefix: an install of Pinocchio 3 (built with BUILD_WITH_CODEGEN_SUPPORT), CppAD and
CppADCodeGen (bench/pinocchio_install.sh builds one from their sources).

1. Configures <build-dir> (Release, EOM_BENCH_PINOCCHIO_PREFIX=<prefix>, no tests or demo) and
   builds eom_bench_pinocchio_contacts (eomgen's contact kernels for Solo12 and MuJoCo's humanoid,
   bench/pinocchio.cmake).
   (--no-build: runs the binary already there.)
2. Runs it --runs times (the first run also generates and compiles Pinocchio's CppADCodeGen code,
   kept in <build-dir>/pinocchio_codegen for the later runs).
Then writes the report, and the figures as <build-dir>/pinocchio_contacts.json. The "Discussion"
section is written by hand: it is kept, between its markers, from the existing report.
--report-only rewrites the report from that .json.
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

from pinocchio import versions
from scaling import discussion_section, fmt_ns, kept_discussion, machine_info, run_or_exit

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = "pinocchio_contacts.py"
START = time.monotonic()
# set: (robot, its frames)
SETS = {"stance": ("Solo12", "FL_FOOT, FR_FOOT, HL_FOOT, HR_FOOT, points (12 rows)"),
        "trot": ("Solo12", "FL_FOOT, HR_FOOT, points (6 rows)"),
        "double": ("humanoid", "left_foot, right_foot, 6d (12 rows)"),
        "single": ("humanoid", "right_foot, 6d (6 rows)")}
KERNELS = ["contact_dynamics", "contact_dynamics_derivatives", "impulse_dynamics",
           "impulse_dynamics_derivatives"]
PINOCCHIO = {
    "contact_dynamics": "constraintDynamics",
    "contact_dynamics_derivatives": "constraintDynamics + computeConstraintDynamicsDerivatives",
    "impulse_dynamics": "impulseDynamics",
    "impulse_dynamics_derivatives": "impulseDynamics + computeImpulseDynamicsDerivatives",
}
CODEGEN = {"contact_dynamics": "CodeGenConstraintDynamics",
           "contact_dynamics_derivatives": "CodeGenConstraintDynamicsDerivatives"}
PAIRS = ["eomgen / Pinocchio codegen", "eomgen / Pinocchio"]
TARGETS = [("eomgen / Pinocchio codegen", 0.8), ("eomgen / Pinocchio", 0.25)]
LINE = re.compile(r"^(\w+)/(\w+): (.+?)\s+([\d.]+) ns\s+([\d.]+) ns\s+ratio ([\d.]+)$")
AGREEMENT = re.compile(r"^agreement\s+(\w+)\s+(\w+)\s+(.*)$")
OUTPUT = re.compile(r"^output\s+(\w+)\s+(\w+)\s+(\w+)\s+(.*)$")


def progress(message):
    print(f"pinocchio_contacts: [{time.monotonic() - START:6.0f} s] {message}", file=sys.stderr,
          flush=True)


def run(command, **kw):
    return run_or_exit(SCRIPT, command, **kw)


def build(build_dir, prefix, jobs):
    progress(f"configuring {build_dir}")
    run(["cmake", "-S", ROOT, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
         "-DEOM_BUILD_TESTS=OFF", "-DEOM_BUILD_DEMO=OFF", "-DEOM_BUILD_BENCH=ON",
         f"-DEOM_BENCH_PINOCCHIO_PREFIX={prefix}"], stdout=subprocess.DEVNULL)
    progress("building eom_bench_pinocchio_contacts (Solo12's and the humanoid's contact kernels, "
             "Pinocchio)")
    run(["cmake", "--build", build_dir, f"-j{jobs}", "--target", "eom_bench_pinocchio_contacts"],
        stdout=subprocess.DEVNULL)


def bench(build_dir, runs):
    exe = os.path.join(build_dir, "bench", "eom_bench_pinocchio_contacts")
    cache = os.path.join(build_dir, "pinocchio_codegen")
    ratios, times, agreement, outputs, first_run_s = {}, {}, {}, {}, None
    for r in range(runs):
        progress(f"run {r + 1} of {runs}")
        t0 = time.monotonic()
        out = run([exe, cache], capture_output=True, text=True).stdout
        if r == 0:
            first_run_s = time.monotonic() - t0
        for line in out.splitlines():
            m = LINE.match(line.strip())
            if m:
                key = f"{m.group(1)}/{m.group(2)}/{m.group(3)}"
                ratios.setdefault(key, []).append(float(m.group(6)))
                times.setdefault(key, []).append([float(m.group(4)), float(m.group(5))])
            m = AGREEMENT.match(line.strip())
            if m:
                agreement[f"{m.group(1)}/{m.group(2)}"] = dict(
                    (k, float(v)) for k, v in re.findall(r"(\w+)=(\S+)", m.group(3)))
            m = OUTPUT.match(line.strip())
            if m:
                outputs[f"{m.group(1)}/{m.group(2)}/{m.group(3)}"] = dict(
                    (k, float(v)) for k, v in re.findall(r"(\w+)=(\S+)", m.group(4)))
    return {"ratios": ratios, "ns": times, "agreement": agreement, "outputs": outputs,
            "first_run_s": first_run_s}


def median(xs):
    return statistics.median(xs) if xs else None


def report(result, path):
    ratios, ns, agreement = result["ratios"], result["ns"], result["agreement"]
    sets = [s for s in SETS if any(k.startswith(s + "/") for k in agreement)]  # those measured
    v = result["versions"]
    runs = result["runs"]
    lines = [
        "# Contact dynamics against Pinocchio and its CppADCodeGen output",
        "",
        "*Generated* by `bench/pinocchio_contacts.py --prefix <install>` (builds "
        "`eom_bench_pinocchio_contacts`, runs it " + str(runs) + " times and writes this file; the "
        "figures also as `pinocchio_contacts.json` in the build directory); "
        "`bench/pinocchio_install.sh` builds the install from the peers' sources. Opt-in: "
        "nothing else in eomgen needs Pinocchio, CppAD or CppADCodeGen.",
        "",
        "## Machine and peers",
        "",
    ]
    for k, val in result["machine"].items():
        lines.append(f"- {k}: {val}")
    lines += [
        f"- Pinocchio {v['Pinocchio']}, CppAD {v['CppAD']}, CppADCodeGen {v['CppADCodeGen']} "
        "(built from their published sources by `bench/pinocchio_install.sh`)",
        "",
        "## Reproduce",
        "",
        "The peers from their public repositories (coin-or/CppAD, joaoleal/CppADCodeGen, "
        "stack-of-tasks/pinocchio and its cmake/ submodule jrl-umi3218/jrl-cmakemodules at the "
        "commit v3.7.0 pins), each extracted outside the repository (`<x>.git`: a clone):",
        "",
        "```sh",
        "mkdir -p peer-src/cppad peer-src/cppadcg peer-src/pinocchio",
        "git --git-dir=CppAD.git archive 20240000.7 | tar -x -C peer-src/cppad",
        "git --git-dir=CppADCodeGen.git archive v2.5.0 | tar -x -C peer-src/cppadcg",
        "git --git-dir=pinocchio.git archive v3.7.0 | tar -x -C peer-src/pinocchio",
        "git --git-dir=jrl-cmakemodules.git archive "
        "$(git --git-dir=pinocchio.git ls-tree v3.7.0 cmake | awk '{print $3}') "
        "| tar -x -C peer-src/pinocchio/cmake",
        "apt-get install cmake g++ make libeigen3-dev libboost-dev libboost-filesystem-dev "
        "libboost-serialization-dev libboost-system-dev googletest",
        "CPPAD_SRC=$PWD/peer-src/cppad CPPADCG_SRC=$PWD/peer-src/cppadcg "
        "PINOCCHIO_SRC=$PWD/peer-src/pinocchio JOBS=1 bench/pinocchio_install.sh /opt/eom-peer",
        "bench/pinocchio_contacts.py --prefix /opt/eom-peer "
        f"--build-dir build-pinocchio-contacts --runs {runs} --jobs 1",
        "```",
        "",
        "The script's steps by hand:",
        "",
        "```sh",
        "cmake -S . -B <build> -DCMAKE_BUILD_TYPE=Release -DEOM_BUILD_TESTS=OFF "
        "-DEOM_BUILD_DEMO=OFF -DEOM_BUILD_BENCH=ON -DEOM_BENCH_PINOCCHIO_PREFIX=/opt/eom-peer",
        "cmake --build <build> -j1 --target eom_bench_pinocchio_contacts",
        "<build>/bench/eom_bench_pinocchio_contacts <build>/pinocchio_codegen   # 3 times",
        "```",
        "",
        "## What is timed",
        "",
        "`bench/bench_pinocchio_contacts.cpp`, one binary compiled with `-O3 -march=native`, "
        "eomgen's kernel libraries with the same flags. Robots, each on a free base, the Pinocchio "
        "model built from what eomgen read (`bench/pinocchio_model.hpp`), so both sides integrate "
        "the same numbers:",
        "",
        "- **Solo12** (models/robots/solo12.urdf, 18 dof), read by eomgen's URDF reader: a "
        "JointModelFreeFlyer root, the legs' joints in file order, the feet as operational frames; "
        "τ = (0, u), u drawn in ±3;",
        "- **humanoid**: MuJoCo's humanoid.xml (Debian's libmujoco-samples; 27 dof, 21 motors), "
        "read by eomgen-mjcf: the tree of its header (each hinge a joint at its anchor, about its "
        "axis, RevoluteUnaligned where the axis is not a principal one; each body's inertia; each "
        "joint's armature in Model::armature), the feet left_foot and right_foot as operational "
        "frames. Its generalized forces are MuJoCo's (gear · ctrl, joint springs and dampers): "
        "Pinocchio's τ is the model's Q(q, v, u), precomputed per state, and Q's constant Jacobians "
        "(∂Q/∂q, ∂Q/∂v, ∂Q/∂u = the gears) carry Pinocchio's ∂/∂τ over to eomgen's ∂/∂q, ∂/∂v, "
        "∂/∂u in the check (not in the timed calls); ctrl drawn in ±0.9, inside its ctrlrange.",
        "",
        "Contact sets (3 rows per point, 6 per flat foot held in placement):",
        "",
    ]
    for s, (robot, frames) in SETS.items():
        lines.append(f"- **{s}** ({robot}): {frames}")
    lines += [
        "",
        "Routes:",
        "",
        "- **eomgen**: the generated `contact_dynamics`, `contact_dynamics_derivatives`, "
        "`impulse_dynamics`, `impulse_dynamics_derivatives` (docs/CONTRACT.md §3, CONTACTS) with "
        "every parameter folded (`FIXED_PARAMETERS ALL`), kd = 0, ρ = 0, restitution 0;",
        "- **Pinocchio**: `RigidConstraintModel` CONTACT_3D at each point foot, CONTACT_6D at each "
        "flat one, LOCAL_WORLD_ALIGNED, "
        "`initConstraintDynamics` once per set (not timed), `ProximalSettings` at its defaults "
        "(mu = 0, one iteration: the exact KKT solve, as eomgen's ρ = 0); the derivative routes "
        "time the forward call their derivatives need (constraintDynamics or impulseDynamics) "
        "plus the derivative call; header-only, in double;",
        "- **Pinocchio codegen**: `CodeGenConstraintDynamics` and "
        "`CodeGenConstraintDynamicsDerivatives` (pinocchio/codegen/code-generator-algo.hpp): the "
        "algorithm taped once with CppADCodeGen (forward sweep only), its C code compiled by gcc "
        "with `-O3 -march=native` into a shared library, its `forward_zero` entry point called as a "
        "raw C function (bench/pinocchio_codegen.cpp) on the packed input [q; v; τ] precomputed "
        "per state. Pinocchio 3.7 has no code generator for the impulse dynamics or its "
        "derivatives: those rows have no codegen column.",
        "",
        "The peers' inputs are precomputed per state in their conventions (quaternion x y z w, "
        "base velocity in base axes, τ) and their raw outputs timed, without the "
        "conversion to eomgen's; eomgen's kernels are called as a user calls them. "
        "`computeConstraintDynamicsDerivatives` returns ∂/∂τ for all nv velocities, eomgen ∂/∂u "
        "for the inputs. Each pair is timed by `eombench::compare` (bench/paired_timing.hpp): "
        "201 alternating rounds of 1000 calls on a pool of 64 random states, the figure the median "
        "of the per-round ratios, so that load changes both sides alike.",
        "",
        "A flat foot's drift differs between the two: eomgen's bias is the classical acceleration "
        "of the frame's origin (docs/CONTRACT.md §3, frames), Pinocchio's CONTACT_6D its spatial "
        "one, apart by ω × ẋ of the foot. The contact kernels of the humanoid's sets are "
        "therefore checked and timed at states where the set's feet are at rest (v with its part "
        "in the range of the feet's Jacobian removed, as a held foot is), where the two coincide, "
        "their derivatives included (ω × ẋ is bilinear in two vanishing velocities); the impulse "
        "kernels on the unprojected states (at rest the impulse would vanish).",
        "",
        "## Agreement (checked before timing)",
        "",
        "On 16 random states, eomgen's outputs and those of Pinocchio's generated code against "
        "Pinocchio's algorithms in double, Pinocchio's outputs carried over to eomgen's "
        "conventions (v̇ = diag(R, I) a + (R (ω × v_b); 0), v⁺ = diag(R, I) v⁺_pin, λ and the "
        "impulse in world axes on both sides; the derivatives by the chain rule between the two "
        "tangent spaces); per output (v̇, λ, each derivative block), max-abs difference over "
        "max(1, max-abs of Pinocchio's), the worst over states and outputs. The binary refuses to "
        "time above 1e-10. \"largest\": the largest magnitude among the kernel's outputs.",
        "",
        "| robot | set | kernel | eomgen vs Pinocchio | Pinocchio codegen vs Pinocchio | largest |",
        "|---|---|---|---|---|---|",
    ]
    for s in sets:
        for kernel in KERNELS:
            a = agreement.get(f"{s}/{kernel}", {})
            cell = lambda k: f"{a[k]:.1e}" if k in a else "–"
            lines.append(f"| {SETS[s][0]} | {s} | {kernel} | {cell('eomgen')} | {cell('codegen')} | "
                         f"{cell('largest')} |")
    outputs = result.get("outputs", {})
    if outputs:
        lines += [
            "",
            "Per output (the same measure):",
            "",
            "| robot | set | kernel | output | eomgen vs Pinocchio | Pinocchio codegen vs Pinocchio |",
            "|---|---|---|---|---|---|",
        ]
        for key, a in outputs.items():
            s, kernel, output = key.split("/")
            lines.append(f"| {SETS[s][0]} | {s} | {kernel} | {output} | {a['eomgen']:.1e} | " +
                         (f"{a['codegen']:.1e}" if "codegen" in a else "–") + " |")
    lines += [
        "",
        f"## Times and ratios ({runs} runs)",
        "",
        "ns: medians of the last run's rounds (the pairs are timed apart, so eomgen's time is "
        "given from each pair). Ratios: the median of the per-round ratios, each run's, "
        "then their median in bold.",
        "",
        "| robot | set | kernel | eomgen ns | Pinocchio codegen ns | Pinocchio ns "
        "| eomgen / codegen | eomgen / Pinocchio |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for s in sets:
        for kernel in KERNELS:
            cg = ns.get(f"{s}/{kernel}/{PAIRS[0]}", [[None, None]])[-1]
            pin = ns.get(f"{s}/{kernel}/{PAIRS[1]}", [[None, None]])[-1]
            ours = " / ".join(fmt_ns(x) for x in (cg[0], pin[0]) if x is not None)
            cells = []
            for pair in PAIRS:
                rs = ratios.get(f"{s}/{kernel}/{pair}", [])
                cells.append((" / ".join(f"{x:.2f}" for x in rs) + f" → **{median(rs):.2f}**")
                             if rs else "–")
            lines.append(f"| {SETS[s][0]} | {s} | {kernel} | {ours or '–'} | {fmt_ns(cg[1])} | {fmt_ns(pin[1])} "
                         f"| {cells[0]} | {cells[1]} |")
    lines += [
        "",
        "## Targets",
        "",
        "The issue's targets, on every kernel and set: eomgen ≤ 0.8× Pinocchio's generated code "
        "and ≤ 0.25× Pinocchio itself. The figure is each kernel's median ratio over the runs "
        "(the worst run in brackets), to three decimals (as the binary prints it), which decide.",
        "",
        "| target | kernel, set | median (worst run) | |",
        "|---|---|---|---|",
    ]
    summary = {}
    for pair, limit in TARGETS:
        for s in sets:
            for kernel in KERNELS:
                rs = ratios.get(f"{s}/{kernel}/{pair}", [])
                if not rs:
                    continue
                met = median(rs) <= limit
                summary.setdefault(pair, []).append(met)
                lines.append(f"| {pair} ≤ {limit} | {kernel}, {SETS[s][0]} {s} | {median(rs):.3f} "
                             f"({max(rs):.3f}) | {'met' if met else '**not met**'} |")
    lines.append("")
    for pair, limit in TARGETS:
        got = summary.get(pair, [])
        lines.append(f"- {pair} ≤ {limit}: met on {sum(got)} of {len(got)} kernel-set pairs.")
    lines += [
        "",
        f"The first run took {result['first_run_s']:.0f} s in all (it also generates and compiles "
        "Pinocchio's code, unless the build directory holds the libraries already).",
        "",
    ] + discussion_section(SCRIPT, result.get("discussion"))
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--prefix", help="the Pinocchio + CppAD + CppADCodeGen install")
    parser.add_argument("--build-dir", default=os.path.join(ROOT, "build-pinocchio-contacts"))
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--out", default=os.path.join(ROOT, "docs", "benchmarks"))
    parser.add_argument("--no-build", action="store_true",
                        help="run the eom_bench_pinocchio_contacts already in --build-dir")
    parser.add_argument("--report-only", action="store_true")
    args = parser.parse_args()
    md = os.path.join(args.out, "pinocchio_contacts.md")
    js = os.path.join(os.path.abspath(args.build_dir), "pinocchio_contacts.json")
    if args.report_only:
        with open(js, encoding="utf-8") as f:
            result = json.load(f)
    else:
        if not args.prefix:
            sys.exit(f"{SCRIPT}: --prefix <install of Pinocchio, CppAD, CppADCodeGen> is required "
                     "(bench/pinocchio_install.sh builds one)")
        prefix = os.path.abspath(args.prefix)
        machine = machine_info()
        if not args.no_build:
            build(os.path.abspath(args.build_dir), prefix, args.jobs)
        result = bench(os.path.abspath(args.build_dir), args.runs)
        result.update(machine=machine, versions=versions(prefix), runs=args.runs,
                      build_dir=os.path.abspath(args.build_dir))
    discussion = kept_discussion(md, SCRIPT)
    if discussion:
        result["discussion"] = discussion
    with open(js, "w", encoding="utf-8") as f:
        json.dump(result, f, indent=1)
    report(result, md)
    progress(f"wrote {md}")


if __name__ == "__main__":
    main()
