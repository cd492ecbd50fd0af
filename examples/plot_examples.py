#!/usr/bin/env python3
"""Plots the closed-loop responses the example controllers write (computed_torque.csv,
lqr_cartpole.csv, panda_osc.csv) to PNG files of the same names.

    plot_examples.py [--csv-dir DIR] [--out-dir DIR]

DIR defaults to the current directory; --out-dir defaults to --csv-dir. A missing CSV is
skipped with a note; the exit status is 1 when none was found.
"""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402


def read_columns(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {name: [float(r[name]) for r in rows] for name in rows[0]}


def plot_computed_torque(c, out):
    t = c["t"]
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    for i in range(1, 4):
        line, = axes[0].plot(t, c[f"q{i}"], label=f"q{i}")
        axes[0].plot(t, c[f"q{i}_ref"], "--", color=line.get_color(), linewidth=0.8)
    axes[0].set_ylabel("joint angle [rad]")
    axes[0].set_title("Computed-torque tracking, 3-link arm (dashed: reference)")
    axes[0].legend(loc="upper right", ncol=3)
    for i in range(1, 4):
        line, = axes[1].semilogy(t, [max(abs(v), 1e-12) for v in c[f"e{i}"]], label=f"e{i} exact model")
        axes[1].semilogy(t, [max(abs(v), 1e-12) for v in c[f"payload_e{i}"]], ":",
                         color=line.get_color(), label=f"e{i} payload +20%")
    axes[1].axhline(1e-3, color="k", linewidth=0.8, linestyle="--")
    axes[1].set_ylabel("|tracking error| [rad]")
    axes[1].legend(loc="upper right", ncol=2, fontsize="small")
    for i in range(1, 4):
        axes[2].plot(t, c[f"tau{i}"], label=f"tau{i}")
    axes[2].set_ylabel("joint torque [N m]")
    axes[2].set_xlabel("t [s]")
    axes[2].legend(loc="upper right", ncol=3)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_lqr_cartpole(c, out):
    t = c["t"]
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    axes[0].plot(t, c["x"], label="cart x [m]")
    axes[0].plot(t, c["theta"], label="pole angle [rad]")
    axes[0].axhline(0, color="k", linewidth=0.5)
    axes[0].set_title("LQR stabilization of the cart-pole at the upright")
    axes[0].legend(loc="upper right")
    axes[1].step(t, c["force"], where="post")  # zero-order hold
    axes[1].set_ylabel("force on the cart [N]")
    axes[2].semilogy(t, c["norm_inf"], label="|x|inf")
    axes[2].semilogy(t, c["cost_to_go"], label="x'Px (cost-to-go)")
    axes[2].axhline(1e-3, color="k", linewidth=0.8, linestyle="--", label="1e-3")
    axes[2].set_xlabel("t [s]")
    axes[2].legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_panda_osc(c, out):
    t = c["t"]
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    for axis, name in enumerate("xyz"):
        line, = axes[0].plot(t, c[name], label=name)
        axes[0].plot(t, c[f"{name}_ref"], "--", color=line.get_color(), linewidth=0.8)
    axes[0].set_ylabel("flange position [m]")
    axes[0].set_title("Operational-space control of the Panda's flange (dashed: reference)")
    axes[0].margins(y=0.3)  # room for the legend
    axes[0].legend(loc="upper right", ncol=3)
    floor = 1e-9  # the start is exact
    for prefix, style, label in (("", "-", "exact model"), ("no_bias_", ":", "without J'v"),
                                 ("payload_", "--", "0.5 kg payload unknown")):
        axes[1].semilogy(t, [max(v, floor) for v in c[f"{prefix}position_error"]], style,
                         label=label)
        axes[2].semilogy(t, [max(v, floor) for v in c[f"{prefix}orientation_error"]], style,
                         label=label)
    axes[1].axhline(5e-5, color="k", linewidth=0.8, linestyle="--")
    axes[1].set_ylabel("|position error| [m]")
    axes[1].legend(loc="lower right", fontsize="small")
    axes[2].axhline(1e-4, color="k", linewidth=0.8, linestyle="--")
    axes[2].set_ylabel("orientation error [rad]")
    axes[2].set_xlabel("t [s]")
    axes[2].legend(loc="lower right", fontsize="small")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--csv-dir", default=".")
    parser.add_argument("--out-dir")
    args = parser.parse_args()
    out_dir = args.out_dir or args.csv_dir
    os.makedirs(out_dir, exist_ok=True)
    found = 0
    for name, plot in (("computed_torque", plot_computed_torque),
                       ("lqr_cartpole", plot_lqr_cartpole),
                       ("panda_osc", plot_panda_osc)):
        path = os.path.join(args.csv_dir, name + ".csv")
        if not os.path.exists(path):
            print(f"plot_examples: {path} not found, skipped")
            continue
        out = os.path.join(out_dir, name + ".png")
        plot(read_columns(path), out)
        print(f"plot_examples: wrote {out}")
        found += 1
    return 0 if found else 1


if __name__ == "__main__":
    sys.exit(main())
