#!/usr/bin/env python3
"""Writes the planar N-link chains of the robot benchmark (bench/bench_robots.cpp) as URDF files:

    bench/robots/make_chains.py [N ...]      (default: 2 5 10 20 30; writes chain<N>.urdf here)

A chain of N revolute joints about y (gravity along -z, so it moves in the x-z plane). Link k is
a slender rod of length 0.3 m and mass 1 kg along its x axis: mass centre at (0.15, 0, 0),
inertia about it Ixx = 1e-4 (thin), Iyy = Izz = m l^2/12; joint k+1 sits at the rod's far end,
(0.3, 0, 0). Joint damping 0.01 N m s/rad. Standard library only; the output is deterministic
(the committed files are this script's output).
"""

import os
import sys

LENGTH, MASS, DAMPING, THIN = 0.3, 1.0, 0.01, 0.0001


def chain(n):
    rod = MASS * LENGTH * LENGTH / 12.0
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- Planar chain of {n} revolute joints about y, slender links (bench/robots/make_chains.py). -->",
        f'<robot name="chain{n}">',
        '  <link name="base"/>',
    ]
    for k in range(1, n + 1):
        parent = "base" if k == 1 else f"link{k - 1}"
        x = 0.0 if k == 1 else LENGTH
        lines += [
            f'  <joint name="joint{k}" type="revolute">',
            f'    <parent link="{parent}"/>',
            f'    <child link="link{k}"/>',
            f'    <origin xyz="{x:g} 0 0" rpy="0 0 0"/>',
            '    <axis xyz="0 1 0"/>',
            '    <limit lower="-3.14" upper="3.14" velocity="10" effort="100"/>',
            f'    <dynamics damping="{DAMPING:g}"/>',
            "  </joint>",
            f'  <link name="link{k}">',
            "    <inertial>",
            f'      <origin xyz="{LENGTH / 2:g} 0 0" rpy="0 0 0"/>',
            f'      <mass value="{MASS:g}"/>',
            f'      <inertia ixx="{THIN:.4f}" ixy="0" ixz="0" iyy="{rod:.4f}" iyz="0" izz="{rod:.4f}"/>',
            "    </inertial>",
            "  </link>",
        ]
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def main():
    sizes = [int(a) for a in sys.argv[1:]] or [2, 5, 10, 20, 30]
    here = os.path.dirname(os.path.abspath(__file__))
    for n in sizes:
        if n < 1:
            sys.exit(f"make_chains.py: N must be positive, not {n}")
        with open(os.path.join(here, f"chain{n}.urdf"), "w", encoding="ascii") as f:
            f.write(chain(n))


if __name__ == "__main__":
    main()
