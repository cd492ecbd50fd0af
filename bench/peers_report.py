#!/usr/bin/env python3
"""Turns eom_bench_peers' JSON output into docs/benchmarks/kernels.md and kernels.csv.

    peers_report.py RESULT.json --md OUT.md --csv OUT.csv [--sympy-stats DIR] [--machine K=V ...]

Times are CPU ns per call, the fastest of the repetitions (the least disturbed by other work on
the machine); ratios are taken within the same run. Standard library only.
"""

import argparse
import csv
import glob
import json
import os
import re

ROUTES = ["generated", "reference", "adolc", "sympy"]
ROUTE_TITLES = {"generated": "generated", "reference": "eom::Reference", "adolc": "ADOL-C",
                "sympy": "SymPy"}
KERNELS = ["mass_matrix", "coriolis", "forward_dynamics"]
CASE_ORDER = ["spring_pendulum", "cartesian_pendulum", "double_pendulum", "closed_chain5",
              "chain2", "chain5", "chain10", "chain20", "chain50"]


def fastest_times(result):
    """{(case, kernel, route): ns}: the minimum CPU time per call over the repetitions."""
    best = {}
    for b in result["benchmarks"]:
        if b.get("run_type") != "iteration" or b.get("error_occurred"):
            continue
        case, kernel, route = b["run_name"].split("/")
        scale = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}[b.get("time_unit", "ns")]
        ns = b["cpu_time"] * scale
        key = (case, kernel, route)
        best[key] = min(best.get(key, ns), ns)
    return best


def format_ns(ns):
    if ns is None:
        return "—"
    if ns >= 1e6:
        return f"{ns / 1e6:.2f} ms"
    if ns >= 1e4:
        return f"{ns / 1e3:.1f} µs"
    if ns >= 1e3:
        return f"{ns / 1e3:.2f} µs"
    return f"{ns:.1f} ns" if ns < 10 else f"{ns:.0f} ns"


def format_ratio(other, generated):
    if other is None or generated is None:
        return "—"
    r = other / generated
    return f"{r:.0f}×" if r >= 100 else f"{r:.1f}×" if r >= 10 else f"{r:.2f}×"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("result")
    parser.add_argument("--md", required=True)
    parser.add_argument("--csv", required=True)
    parser.add_argument("--sympy-stats", help="directory of sympy_<model>.json (build/bench/sympy)")
    parser.add_argument("--machine", nargs="*", default=[], help="KEY=VALUE lines for the header")
    parser.add_argument("--command", default="bench/run_peers.sh")
    args = parser.parse_args()

    with open(args.result, encoding="utf-8") as fh:
        result = json.load(fh)
    best = fastest_times(result)
    context = result["context"]
    cases = [c for c in CASE_ORDER if any(k[0] == c for k in best)]
    cases += sorted({k[0] for k in best} - set(cases))
    routes = [r for r in ROUTES if any(k[2] == r for k in best)]

    with open(args.csv, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["case", "kernel", "route", "cpu_ns_per_call", "ratio_to_generated"])
        for case in cases:
            for kernel in KERNELS:
                gen = best.get((case, kernel, "generated"))
                for route in routes:
                    ns = best.get((case, kernel, route))
                    if ns is not None:
                        w.writerow([case, kernel, route, f"{ns:.2f}",
                                    f"{ns / gen:.4g}" if gen else ""])

    out = []
    out.append("# Kernel benchmarks: generated kernels against the peers\n")
    out.append(f"Regenerate with `{args.command}` (one command: checks its prerequisites, builds "
               "`eom_bench_peers` in `build-bench/`, runs it, writes this file, `kernels.json` "
               "and `kernels.csv`).\n")
    out.append("## Machine\n")
    for line in args.machine:
        key, _, value = line.partition("=")
        out.append(f"- {key}: {value}")
    out.append(f"- benchmark date: {context.get('date', '?')}; load average at start "
               f"{', '.join(f'{x:.1f}' for x in context.get('load_avg', []))} "
               f"(a shared machine: CPU time per call is reported, the fastest of "
               f"{result['benchmarks'][0].get('repetitions', 1)} repetitions)\n")
    out.append("## Routes\n")
    out.append("- **generated**: eomgen's kernels, compiled with the benchmark (-O3 "
               "-march=native), called out of line.")
    out.append("- **eom::Reference**: `eom::Reference<Model>`, pure operator-overloading AD "
               "(eom::Embedded Hessian numbers over (q, q̇)), inlined into the loop.")
    out.append("- **ADOL-C**: the model's own templated source taped once on `adouble` "
               "(parameters as tape parameters, changed per call with `set_param_vec`); M by "
               "one vector forward + second-order vector reverse sweep of T (nq directions), c "
               "by `fos_forward` + `hos_reverse` on T, q̈ by one sweep of L = T − V with nq + 1 "
               "directions, then the same numerical solve as the reference "
               "(bench/adolc_peer.hpp).")
    tapes = [f"{c} {context[f'adolc_tape_operations/{c}']}" for c in cases
             if f"adolc_tape_operations/{c}" in context]
    if tapes:
        out.append("  Tape sizes (ADOL-C operations on the T and L tapes): " + "; ".join(tapes)
                   + ".")
    out.append("- **SymPy**: `sympy.physics.mechanics.LagrangesMethod` (the chains as one "
               "RigidBody per link, the dampers and drive as frame torques), `cse`, `ccode`, "
               "written by bench/sympy_models.py at build time and compiled with the benchmark; "
               "q̈ from its M and forcing (and C, γ) by the reference's numerical solve "
               "(`eom::linalg::solve_constrained`). Chains above `EOM_SYMPY_MAX_LINKS` (20) are "
               "not derived: SymPy needs minutes at N = 20 and grows about as N³.\n")
    out.append("Every route was checked against the generated kernels before timing (16 random "
               "states and parameters; the benchmark refuses to run beyond 1e-12 relative to the "
               "largest entry). Largest relative differences measured:\n")
    out.append("| case | route | M | c | q̈ |")
    out.append("|---|---|---|---|---|")
    for case in cases:
        for route in routes:
            text = context.get(f"agreement/{case}/{route}")
            if text:
                parts = dict(re.findall(r"(M|c|qdd) ([0-9.e+-]+)", text))
                out.append(f"| {case} | {ROUTE_TITLES[route]} | {parts.get('M', '?')} | "
                           f"{parts.get('c', '?')} | {parts.get('qdd', '?')} |")
    out.append("")

    out.append("In the tables below, times are CPU time per call; a ratio is the peer's time over "
               "the generated kernel's (how many times faster the generated kernel is; below 1 "
               "it is slower). — : not measured (SymPy's code is not derived above N = 20).\n")
    for kernel in KERNELS:
        out.append(f"## {kernel}\n")
        head = "| case | " + " | ".join(ROUTE_TITLES[r] for r in routes) + " | " + \
               " | ".join(f"{ROUTE_TITLES[r]} / generated" for r in routes[1:]) + " |"
        out.append(head)
        out.append("|---" * (1 + len(routes) + len(routes) - 1) + "|")
        for case in cases:
            gen = best.get((case, kernel, "generated"))
            cells = [format_ns(best.get((case, kernel, r))) for r in routes]
            ratios = [format_ratio(best.get((case, kernel, r)), gen) for r in routes[1:]]
            out.append(f"| {case} | " + " | ".join(cells) + " | " + " | ".join(ratios) + " |")
        out.append("")

    # The aims and targets, from this run.
    out.append("## Aims and targets, from this run\n")
    fd = lambda case, route: best.get((case, "forward_dynamics", route))
    gen10, ref10 = fd("chain10", "generated"), fd("chain10", "reference")
    if gen10 and ref10:
        ratio = ref10 / gen10
        out.append(f"- Generated forward_dynamics ≥ 50× faster than eom::Reference at N = 10: "
                   f"**{ratio:.0f}×** ({format_ns(ref10)} / {format_ns(gen10)}) — "
                   f"{'met' if ratio >= 50 else 'missed'}.")
    rows = []
    for case in cases:
        g, s = fd(case, "generated"), fd(case, "sympy")
        if g and s:
            rows.append(f"{case} {s / g:.2f}×")
    if rows:
        slower = [r for r in rows if float(r.split()[1][:-1]) < 1.0]
        out.append("- Generated forward_dynamics no slower than the SymPy code (SymPy time / "
                   "generated time): " + ", ".join(rows) + " — " +
                   ("met wherever SymPy's code exists" if not slower else
                    "missed for " + ", ".join(r.split()[0] for r in slower)) + ".")
    s10 = fd("chain10", "sympy")
    if s10:
        out.append(f"- Target: SymPy-generated forward dynamics of the 10-link chain about "
                   f"0.5 µs: measured {format_ns(s10)}.")
    if ref10:
        out.append(f"- Target: pure operator-overloading AD about 40 µs: measured "
                   f"{format_ns(ref10)} (eom::Reference); the taped ADOL-C route "
                   f"{format_ns(fd('chain10', 'adolc'))}.")
    out.append("")

    if args.sympy_stats:
        stats = []
        for path in sorted(glob.glob(os.path.join(args.sympy_stats, "sympy_*.json"))):
            with open(path, encoding="utf-8") as fh:
                stats.append(json.load(fh))
        if stats:
            order = {c: i for i, c in enumerate(CASE_ORDER)}
            stats.sort(key=lambda s: order.get(s["model"], 99))
            out.append("## SymPy's side of the build\n")
            out.append("| model | derive s | cse s | print s | ops M | ops c | ops M, f (C, γ) "
                       "| bytes |")
            out.append("|---|---|---|---|---|---|---|---|")
            for s in stats:
                f = s["functions"]
                out.append(f"| {s['model']} | {s['derive_s']:.1f} | {s['cse_s']:.1f} | "
                           f"{s['print_s']:.1f} | {f['mass_matrix']['ops']} | "
                           f"{f['coriolis']['ops']} | {f['dynamics_terms']['ops']} | "
                           f"{s['bytes']} |")
            out.append("\n(Wall seconds of one build on the machine above; operation counts "
                       "are sympy.count_ops after cse.)\n")

    with open(args.md, "w", encoding="utf-8") as fh:
        fh.write("\n".join(out))


if __name__ == "__main__":
    main()
