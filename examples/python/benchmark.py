#!/usr/bin/env python3
"""What the Python bindings cost, measured:

1. one call with 100 000 states of chain10's forward_dynamics against the same loop in C++
   (tests/python/python_reference.cpp --bench: K::forward_dynamics state by state, one thread);
2. the overhead of a single-state call above the kernel itself (chain10, the Panda);
3. eomgen.build() of the Panda from a warm cache (a new process: the import alone) and, with
   --cold, from an empty cache (the generator and the model compiled).

    PYTHONPATH=build/tests/python /usr/bin/python3 examples/python/benchmark.py \
        --reference build/tests/python/python_reference [--cold]

The chain10 and panda modules are taken from PYTHONPATH (the test build's), else built with
eomgen.build().
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
import timeit
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "python"))
import eomgen  # noqa: E402


def module(name):
    try:
        return __import__(name)
    except ImportError:
        if name == "chain10":
            return eomgen.build(header=ROOT / "models" / "chain.hpp", cls="eom::models::Chain<10>", name="chain10",
                                kernels=["defaults", "forward_dynamics_batch"])
        return eomgen.build(urdf=ROOT / "models" / "robots" / "panda.urdf")


def best(fn, repeat=7):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def per_call(fn, number=20000, repeat=7):  # seconds per call
    return min(timeit.repeat(fn, number=number, repeat=repeat)) / number


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--reference", default=os.environ.get("EOM_PYTHON_REFERENCE"),
                        help="tests/python's python_reference program (the C++ loop)")
    parser.add_argument("--states", type=int, default=100_000)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--cold", action="store_true", help="also time eomgen.build() from an empty cache")
    args = parser.parse_args()
    n = args.states

    # The machine may be shared: every figure is the minimum over `rounds` rounds, the C++ loop and
    # the Python calls interleaved, so that both see the same load.
    def cxx_loop():
        out = subprocess.run([args.reference, "--bench", str(n)], check=True, capture_output=True, text=True).stdout
        return {m.group(1): float(m.group(2))
                for m in re.finditer(r"(\w+) forward_dynamics: ([\d.]+) ns per state", out)}

    models = {name: module(name) for name in ("chain10", "panda")}
    rng = np.random.default_rng(1)
    data = {}
    for name, m in models.items():
        Q = rng.uniform(-1, 1, (n, m.nq))
        QD = rng.uniform(-1, 1, (n, m.nv))
        u = 0.5 - 0.1 * np.arange(m.nu)  # as the C++ loop
        data[name] = (Q, QD, u, [(Q[i].copy(), QD[i].copy()) for i in range(20000)])

    def configs(m):
        c = [("scalar kernel, 1 thread", False, 1)]
        if m.batch_lanes:
            c.append((f"batch kernel ({m.batch_lanes} lanes), 1 thread", True, 1))
        return c + [("default (batch kernel if any, all threads)", True, 0)]

    fig = {}  # figure -> minimum over rounds

    def record(key, value):
        fig[key] = min(fig.get(key, float("inf")), value)

    for _ in range(args.rounds):
        if args.reference:
            for name, ns in cxx_loop().items():
                record(("cxx", name), ns)
        for name, m in models.items():
            Q, QD, u, pairs = data[name]
            for label, batch_kernel, threads in configs(m):
                m.set_batch_kernel(batch_kernel)
                m.set_num_threads(threads)
                record((name, label), 1e9 * best(lambda: m.forward_dynamics(Q, QD, u), repeat=3) / n)
            m.set_num_threads(1)
            record((name, "gf kernel"), 1e9 * best(lambda: m.generalized_forces(Q, QD, u), repeat=3) / n)
            m.set_batch_kernel(True)
            m.set_num_threads(0)
            k = len(pairs)
            record((name, "single"), 1e9 * best(lambda: [m.forward_dynamics(a, b, u) for a, b in pairs], 3) / k)
            record((name, "gf single"), 1e9 * best(lambda: [m.generalized_forces(a, b, u) for a, b in pairs], 3) / k)
            record((name, "loop"), 1e9 * best(lambda: [None for a, b in pairs], 3) / k)
            q = Q[0].copy()
            record((name, "mass_matrix"), 1e9 * per_call(lambda: m.mass_matrix(q), repeat=3))

    rows = []
    for name, m in models.items():
        cxx = fig.get(("cxx", name))
        if cxx:
            rows.append(f"{name} forward_dynamics, C++ loop over {n} states: {cxx:.1f} ns per state")
        for label, _, _ in configs(m):
            ns = fig[(name, label)]
            ratio = f", {cxx / ns:.2f}x the C++ loop's throughput" if cxx else ""
            rows.append(f"{name} forward_dynamics, {n} states in one call, {label}: {ns:.1f} ns per state{ratio}")
        loop, kernel = fig[(name, "loop")], fig[(name, "scalar kernel, 1 thread")]
        rows.append(f"{name} one state per call, in a Python loop ({loop:.0f} ns of it the loop): "
                    f"generalized_forces {fig[(name, 'gf single')]:.0f} ns, "
                    f"{fig[(name, 'gf single')] - loop - fig[(name, 'gf kernel')]:.0f} ns above its "
                    f"{fig[(name, 'gf kernel')]:.0f} ns kernel (the binding's own cost); forward_dynamics "
                    f"{fig[(name, 'single')]:.0f} ns, {fig[(name, 'single')] - loop - kernel:.0f} ns above the "
                    f"kernel's time in a batch; mass_matrix(q) {fig[(name, 'mass_matrix')]:.0f} ns")
    print(f"(minimum over {args.rounds} interleaved rounds)")
    print("\n".join(rows))

    # eomgen.build() of the Panda: warm (cached: a new process imports it), then cold if asked.
    urdf = ROOT / "models" / "robots" / "panda.urdf"
    code = ("import sys, time; sys.path.insert(0, %r); import eomgen; t = time.perf_counter(); "
            "eomgen.build(urdf=%r); print(time.perf_counter() - t)" % (str(ROOT / "python"), str(urdf)))
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)  # make sure it is cached
    warm = min(float(subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                                    text=True).stdout) for _ in range(5))
    start = time.perf_counter()
    eomgen.build(urdf=urdf)
    eomgen.build(urdf=urdf)
    same = (time.perf_counter() - start) / 2
    print(f"eomgen.build(panda), warm cache: {1e3 * warm:.0f} ms in a new process (hash, check, import), "
          f"{1e3 * same:.2f} ms again in the same process")
    if args.cold:
        with tempfile.TemporaryDirectory() as cache:
            env = {**os.environ, "EOMGEN_CACHE_DIR": cache}
            start = time.perf_counter()
            subprocess.run([sys.executable, "-c", code], check=True, env=env)
            print(f"eomgen.build(panda), cold (empty cache: the generator, the URDF tool, the tracer, the "
                  f"kernels and the module compiled): {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
