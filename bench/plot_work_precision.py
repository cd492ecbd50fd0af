#!/usr/bin/env python3
"""Plots and tables of the work-precision study (bench/work_precision.cpp).

Usage: plot_work_precision.py <work_precision.csv> <output directory> <machine description file>

Writes <dir>/<problem>.png (error against wall time and against kernel evaluations, one line per
method and kernel kind) and <dir>/README.md (the tables: for each problem and method the cheapest
run that reaches each error level, plus every run).
"""
import csv
import math
import sys
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LEVELS = [1e-4, 1e-7, 1e-10]
DESCRIPTIONS = {
    "spring_pendulum": "the paper's spring pendulum, 10 s from (0.55, 0, 0.01, 2.5)",
    "double_pendulum_t5": "chaotic double pendulum (a1 = 2.0, a2 = 2.5 at rest), t = 5",
    "double_pendulum_t10": "chaotic double pendulum, t = 10 (errors grow ~1e6-fold per 5 s)",
    "deployment": "10-link deployment (paper Fig. 5), first 2 s",
    "closed_chain": "5-link closed chain (paper Fig. 7), 2 s, explicit methods with projection",
    "stiff_spring_pendulum": "spring pendulum, k = 1e6 N/m, 1 g bob (stiff: 3.2e4 rad/s spring, "
                             "4.4 rad/s swing), 2 s from the slow manifold",
}


# What the plot cannot say by itself, printed under it in the report.
NOTES = {
    "stiff_spring_pendulum": "Every method levels off near 3e-10: that is the reference's own "
    "accuracy here (long double, tolerance limited to 1e-15 by the round-off of the stiff "
    "extrapolation; its self-difference is printed by the run). Radau IIA reaches 1e-7 with ~360 "
    "times fewer evaluations than the explicit methods, whose step is bounded by stability.",
    "double_pendulum_t10": "No double-precision method can do much better than ~1e-5 here: errors "
    "of 1e-16 grow about a million-fold every 5 time units.",
}


def load(path):
    rows = []
    with open(path) as f:
        for r in csv.DictReader(f):
            r["error"] = float(r["error"])
            r["seconds"] = float(r["seconds"])
            r["evaluations"] = int(r["evaluations"])
            r["parameter"] = float(r["parameter"])
            rows.append(r)
    return rows


def label(r):
    return r["method"] + ("" if r["kernels"] == "generated" else " (reference kernels)")


def plot(problem, rows, out):
    fig, axes = plt.subplots(1, 2, figsize=(13, 5))
    series = defaultdict(list)
    for r in rows:
        if r["status"] == "ok" and math.isfinite(r["error"]) and r["error"] > 0:
            series[label(r)].append(r)
    colors = plt.get_cmap("tab20").colors
    for index, (name, rs) in enumerate(sorted(series.items())):
        style = "--" if "reference" in name else ("-." if name.startswith("odeint") else "-")
        for ax, key in zip(axes, ["seconds", "evaluations"]):
            pts = sorted(rs, key=lambda r: r[key])
            ax.loglog([r[key] for r in pts], [r["error"] for r in pts], style, marker="o",
                      markersize=3, label=name, color=colors[(2 * index) % 20 + (index >= 10)])
    axes[0].set_xlabel("wall time per integration [s]")
    axes[1].set_xlabel("right-hand-side evaluations")
    for ax in axes:
        ax.set_ylabel("max |x - x_ref| at the end")
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=7, loc="lower left")
    fig.suptitle(f"{problem}: {DESCRIPTIONS.get(problem, '')}", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def cheapest(rs, level):
    ok = [r for r in rs if r["status"] == "ok" and r["error"] <= level]
    return min(ok, key=lambda r: r["seconds"]) if ok else None


def main():
    csv_path, out_dir, machine = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = load(csv_path)
    by_problem = defaultdict(list)
    for r in rows:
        by_problem[r["problem"]].append(r)

    lines = [
        "# Work-precision report",
        "",
        "Regenerate with `scripts/work_precision.sh` (builds `eom_work_precision`, runs it, plots).",
        "Every integrator runs on the generated kernels of each problem at a sweep of tolerances",
        "(adaptive methods, rtol = atol = tol) or step counts (fixed-step methods). The error is the",
        "largest state error at the end time against a reference computed in a wider type",
        "(double-double or long double) by Gragg-Bulirsch-Stoer extrapolation over `eom::Reference`",
        "(`bench/work_precision_reference.cpp`). Wall time is the fastest of repeated runs.",
        "Boost.Odeint's steppers run on the same generated right-hand side (unconstrained problems",
        "only: odeint has no projection step). Lines marked *reference kernels* run the same method",
        "on `eom::Reference` (pure operator overloading): the distance between the solid and dashed",
        "lines is the price of not generating code. For the Taylor methods an evaluation is one",
        "call of `taylor_coefficients` (all orders of one step), so compare them by wall time.",
        "",
        "## Machine",
        "",
        "```",
        machine.read_text().strip(),
        "```",
        "",
    ]
    for problem, rs in by_problem.items():
        png = f"{problem}.png"
        plot(problem, rs, out_dir / png)
        lines += [f"## {problem}", "", DESCRIPTIONS.get(problem, ""), "", f"![{problem}]({png})", ""]
        if problem in NOTES:
            lines += [NOTES[problem], ""]
        header = "| method | " + " | ".join(f"time to ≤ {lv:.0e}" for lv in LEVELS) + " |"
        lines += [header, "|---|" + "---|" * len(LEVELS)]
        methods = defaultdict(list)
        for r in rs:
            methods[label(r)].append(r)
        for name, mrs in methods.items():
            cells = []
            for lv in LEVELS:
                c = cheapest(mrs, lv)
                cells.append("—" if c is None else
                             f"{c['seconds'] * 1e3:.3g} ms ({c['setting']} {c['parameter']:.3g}, "
                             f"{c['evaluations']} evals)")
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
        failed = [r for r in rs if r["status"] != "ok"]
        if failed:
            lines += ["", "Runs that stopped with a status (never a silent NaN):", ""]
            for r in failed:
                lines.append(f"- {label(r)}, {r['setting']} {r['parameter']:.3g}: {r['status']}")
        lines.append("")
    lines += ["## Every run", "", f"The raw data: [{csv_path.name}]({csv_path.name}).", ""]
    (out_dir / "README.md").write_text("\n".join(lines))
    print(f"wrote {out_dir / 'README.md'}")


if __name__ == "__main__":
    main()
