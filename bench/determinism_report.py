#!/usr/bin/env python3
"""Writes docs/benchmarks/determinism.md from the JSON of eom_bench_kernels' per_call benchmarks.

    determinism_report.py RESULT.json --md OUT.md [--machine KEY=VALUE ...]

One row per <model>/<kernel>: calls per timed sample (batch), min / median / p99 / max ns per
call and the ratios p99/median and max/median (bench/bench_kernels.cpp explains the method).
Standard library only.
"""
import argparse
import json

KERNELS = ["kinetic_energy", "potential_energy", "mass_matrix", "mass_matrix_dot", "coriolis",
           "potential_gradient", "constraint_jacobian", "constraint_bias", "forward_dynamics",
           "forward_dynamics_derivatives", "inverse_dynamics"]
MODELS = ["spring_pendulum", "cartesian_pendulum", "double_pendulum", "closed_chain5", "chain10"]


def ns(x):
    return f"{x:.0f}" if x >= 100 else f"{x:.1f}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json")
    parser.add_argument("--md", required=True)
    parser.add_argument("--machine", nargs="*", default=[], help="KEY=VALUE lines for the header")
    args = parser.parse_args()
    with open(args.json) as fh:
        result = json.load(fh)
    rows = {}
    for b in result["benchmarks"]:
        name = b["name"].split("/iterations:")[0]  # Iterations(n) appends it
        if b.get("run_type") != "iteration" or not name.endswith("/generated/per_call"):
            continue
        model, kernel = name.split("/")[:2]
        rows[(model, kernel)] = b
    if not rows:
        raise SystemExit("determinism_report.py: no per_call benchmarks in " + args.json)
    order = sorted(rows, key=lambda k: (MODELS.index(k[0]) if k[0] in MODELS else 99,
                                        KERNELS.index(k[1]) if k[1] in KERNELS else 99))
    ctx = result.get("context", {})
    samples = int(next(iter(rows.values()))["iterations"])
    out = ["# Kernel timing determinism: min / median / p99 / max per call", ""]
    out.append("Regenerate with `bench/determinism.sh` (builds `eom_bench_kernels` in "
               "`build-bench/`, runs its `per_call` benchmarks, writes this file). Method and limits: "
               "`bench/bench_kernels.cpp`, \"Per-call timing\".")
    out += ["", "## Machine", ""]
    for line in args.machine:
        key, _, value = line.partition("=")
        out.append(f"- {key}: {value}")
    load = ", ".join(f"{x:.1f}" for x in ctx.get("load_avg", []))
    out.append(f"- date: {ctx.get('date', '?')}; load average at start {load or '?'} "
               f"(a shared 2-CPU machine)")
    out += ["", "## Method (short)", ""]
    out.append(f"- {samples} samples per kernel, after 1000 warm-up calls; each sample "
               "times `batch` consecutive calls, each on the next of 64 random states, with the "
               "time-stamp counter (rdtsc between lfences); ns per call = (ticks − timer "
               "overhead) · ns/tick / batch.")
    overheads = sorted(b["timer_ns"] for b in rows.values())
    resolution = max(b["resolution_ns"] for b in rows.values())
    out.append(f"- Timer overhead (median of 10001 empty timed regions, subtracted): "
               f"{overheads[len(overheads) // 2]:.1f} ns; timer resolution (gcd of those "
               f"durations): {resolution:.1f} ns, so a sample is quantized to "
               f"{resolution:.0f} ns / batch.")
    out.append("- batch = 1 (each call timed alone) for kernels of 250 ns and more; below that "
               "enough calls for ≥ 250 ns per sample, and the figures are per-call means over "
               "the batch: the spread between single calls of a fast kernel is not resolved.")
    out.append("- The samples are timed by the TSC reads above, not by Google Benchmark's timers "
               "(its \"Library was built as DEBUG\" warning concerns the installed library's "
               "own code; the kernels are compiled into the benchmark with -O3 -march=native).")
    out.append("- Wall-clock time on a core that is not isolated: max (and less so p99) includes "
               "interrupts, preemption and the sibling hyperthread's load. min ≈ median is the "
               "kernel's own figure.")
    out += ["", "## Generated kernels", ""]
    out.append("| model | kernel | batch | min ns | median ns | p99 ns | max ns | p99 / median "
               "| max / median |")
    out.append("|---|---|---|---|---|---|---|---|---|")
    for key in order:
        b = rows[key]
        med = b["median_ns"]
        out.append(f"| {key[0]} | {key[1]} | {int(b['batch'])} | {ns(b['min_ns'])} | {ns(med)} | "
                   f"{ns(b['p99_ns'])} | {ns(b['max_ns'])} | {b['p99_ns'] / med:.2f} | "
                   f"{b['max_ns'] / med:.1f} |")
    worst_p99 = max(rows.items(), key=lambda kv: kv[1]["p99_ns"] / kv[1]["median_ns"])
    out += ["", "## Reading", ""]
    spread = max(rows.items(), key=lambda kv: kv[1]["median_ns"] / kv[1]["min_ns"])
    out.append(f"- median / min at most {spread[1]['median_ns'] / spread[1]['min_ns']:.2f} "
               f"({spread[0][0]}/{spread[0][1]}): calls over different states take about the "
               "same time, as straight-line code should.")
    out.append(f"- p99 / median at most {worst_p99[1]['p99_ns'] / worst_p99[1]['median_ns']:.2f} "
               f"({worst_p99[0][0]}/{worst_p99[0][1]}) over all {len(rows)} kernels: 99% of the "
               "samples stay within that factor of the typical time even on this loaded machine.")
    out.append(f"- The max column is the machine's, not the kernel's: one preemption or interrupt "
               f"in one of the {samples} samples suffices. For a real-time budget, measure on the "
               "target with an isolated core (isolcpus, SCHED_FIFO, fixed clock) and budget the "
               "max there.")
    with open(args.md, "w") as fh:
        fh.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
