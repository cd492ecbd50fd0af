#!/usr/bin/env python3
"""Turns the demo's CSV files into PNG plots and report/README.md. Usage: plot.py <report dir>"""
import csv
import sys
from pathlib import Path

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.exit("plot.py: matplotlib is missing; install it with: apt-get install python3-matplotlib")


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


def two_panel(t, top, bottom, labels, title, out):
    fig, ax = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    ax[0].plot(t, top)
    ax[0].set_ylabel(labels[0])
    ax[1].plot(t, bottom)
    ax[1].set_ylabel(labels[1])
    ax[1].set_xlabel("time [s]")
    for a in ax:
        a.grid(True, alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main():
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "report")
    sp = read(out / "spring_pendulum.csv")
    two_panel(sp["t"], sp["r"], sp["theta"], ("r [m]", "θ [rad]"),
              "Spring pendulum: position (paper Fig. 2)", out / "spring_pendulum_position.png")
    two_panel(sp["t"], sp["r_dot"], sp["theta_dot"], ("ṙ [m/s]", "θ̇ [rad/s]"),
              "Spring pendulum: velocity (paper Fig. 3)", out / "spring_pendulum_velocity.png")
    summary = (out / "summary.csv").read_text().strip().splitlines()
    lines = ["# eomgen demo report", "",
             "The paper's examples (AAS 04-242), simulated by `scripts/demo.sh`.", "",
             "## Spring pendulum (paper eqs. 29-30, Figures 2 and 3)", "",
             "m = 1 kg, k = 75 N/m, r0 = 0.5 m, g = 9.81 m/s²; start (r, θ, ṙ, θ̇) = (0.55, 0, 0.01, 2.5).", "",
             "![position](spring_pendulum_position.png)", "", "![velocity](spring_pendulum_velocity.png)", "",
             "## Run summary", ""] + [f"- {s}" for s in summary] + [""]
    (out / "README.md").write_text("\n".join(lines))


if __name__ == "__main__":
    main()
