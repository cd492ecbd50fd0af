#!/usr/bin/env python3
"""The hand-derived floor: writes docs/benchmarks/hand_derived.md (and
hand_derived.json).

    bench/hand_chain.py [--build-dir build-hand-chain] [--runs 3] [--repetitions 9]
                        [--min-time 0.2] [--out docs/benchmarks] [--report-only]

1. Configures <build-dir> (Release, EOM_BENCH_HAND_CHAINS=ON: N = 2, 5, 10, 20, 50) and builds
   eom_bench_hand_chain.
2. Runs it --runs times, each with --benchmark_repetitions (one repetition = one batch of
   iterations over the 64 random states), and takes each benchmark's median CPU time per run;
   the table shows the best (lowest) median over the runs, the ratios of those, and the range of
   the ratios within single runs.
3. Operation counts: the generated kernels' from the comment the emitter writes above each kernel
   in the emitted source; the hand-derived code's from the benchmark's counters (the formulas of
   bench/hand_chain.hpp, which tests/hand_chain checks against the code).
--report-only rewrites the report from hand_derived.json. Standard library only; needs cmake and
g++.
"""

import argparse
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scaling import fmt_ns, machine_info, run_or_exit  # shared with the other studies

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
START = time.monotonic()
SIZES = [2, 5, 10, 20, 50]
ROUTES = ["generated_free", "generated_fixed", "generated_free_libmvec", "generated_fixed_libmvec",
          "hand", "hand_per_call", "hand_rows"]
STATES = 64  # per iteration (bench_hand_chain.cpp)


def progress(message):
    print(f"hand_chain: [{time.monotonic() - START:6.0f} s] {message}", file=sys.stderr, flush=True)


def run(command, **kw):
    return run_or_exit("hand_chain.py", command, **kw)


def build(build_dir):
    for tool in ("cmake", "g++"):
        if shutil.which(tool) is None:
            sys.exit(f"hand_chain.py: {tool} not found (apt-get install {tool})")
    progress(f"configuring {build_dir}")
    run(["cmake", "-S", ROOT, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release", "-DEOM_BUILD_BENCH=ON",
         "-DEOM_BENCH_HAND_CHAINS=ON"], stdout=subprocess.DEVNULL)
    progress("building eom_bench_hand_chain (twenty generated chains: free, fixed and their libmvec builds, N up to 50)")
    run(["cmake", "--build", build_dir, "-j2", "--target", "eom_bench_hand_chain"],
        stdout=subprocess.DEVNULL)


def run_benchmark(build_dir, runs, repetitions, min_time):
    exe = os.path.join(build_dir, "bench", "eom_bench_hand_chain")
    out = []
    with tempfile.TemporaryDirectory(prefix="eom-hand-chain-") as work:
        for r in range(runs):
            progress(f"run {r + 1} of {runs}: {repetitions} repetitions of every benchmark")
            json_out = os.path.join(work, f"run{r}.json")
            run([exe, f"--benchmark_repetitions={repetitions}", f"--benchmark_min_time={min_time}",
                 "--benchmark_report_aggregates_only=true", f"--benchmark_out={json_out}",
                 "--benchmark_out_format=json"], stdout=subprocess.DEVNULL)
            with open(json_out, encoding="utf-8") as f:
                data = json.load(f)
            data["context"]["executable"] = "bench/eom_bench_hand_chain"  # no machine path
            medians, counters = {}, {}
            for b in data["benchmarks"]:
                if b.get("run_type") == "aggregate" and b.get("aggregate_name") == "median":
                    assert b["time_unit"] == "ns"
                    medians[b["run_name"]] = b["cpu_time"] / STATES  # ns per state
                    counters[b["run_name"]] = {k: b[k] for k in ("operations", "max_rel_diff")
                                               if k in b}
            progress(f"run {r + 1} of {runs}: paired rounds (--paired)")
            paired = {}
            text = run([exe, "--paired"], stdout=subprocess.PIPE, text=True).stdout
            for m in re.finditer(r"^N = (\d+): (\S+) / (\S+) .*ratio ([0-9.]+)$", text, re.M):
                paired[f"{m.group(1)}/{m.group(2)}/{m.group(3)}"] = float(m.group(4))
            out.append({"medians": medians, "counters": counters, "context": data["context"],
                        "paired": paired})
    return out


def dense_routine_operations(n):
    """The looped form's solve_dense_system for nc = 0 (generator/src/emit.cpp), counted from its
    loops: arithmetic only (the pivot and finiteness tests not counted)."""
    def dot(m):
        return 2 * m + 3
    # right-looking: per column a reciprocal, the m = n - 1 - j multipliers, and the update of
    # the m rows below (row i: i - j multiply-adds)
    factor = sum(1 + (n - 1 - j) + (n - 1 - j) * (n - j) for j in range(n))
    solve = sum(dot(i) + 1 for i in range(1, n)) + n + sum(2 * k for k in range(1, n))
    return factor + solve


def generated_operations(build_dir):
    """From the emitted sources: `// <name>: forward_dynamics (<k> operations[ and the looped
    dense solve of <n> + <nc> unknowns]...`."""
    counts = {}
    for n in SIZES:
        for form in ("free", "fixed"):
            name = f"hand_chain{n}_{form}"
            files = glob.glob(os.path.join(build_dir, "**", "eomgen", name, name + ".cpp"),
                              recursive=True)
            if not files:
                continue
            with open(files[0], encoding="utf-8") as f:
                source = f.read()
            m = re.search(rf"^// {name}: forward_dynamics \((\d+) operations?"
                          rf"( and the looped dense solve)?", source, re.M)
            if m:
                counts[f"{n}/{form}"] = {"statements": int(m.group(1)),
                                         "looped": m.group(2) is not None}
    return counts


def fmt_ratio(x):
    return "–" if x is None else f"{x:.2f}"


def report(result, path):
    runs = result["runs"]
    sizes = [n for n in SIZES if f"hand_chain/{n}/hand" in runs[0]["medians"]]

    def best(n, route):
        values = [r["medians"].get(f"hand_chain/{n}/{route}") for r in runs]
        values = [v for v in values if v is not None]
        return min(values) if values else None

    def ratio_range(n, a, b):
        rs = [r["medians"][f"hand_chain/{n}/{a}"] / r["medians"][f"hand_chain/{n}/{b}"]
              for r in runs]
        return f"{min(rs):.2f}–{max(rs):.2f}"

    machine = result["machine"]
    context = runs[0]["context"]
    lines = [
        "# The hand-derived floor: generated forward dynamics against a hand-derived chain",
        "",
        "The baseline the optimizer is judged against. Regenerate with "
        f"`{result['command']}` (configures `{result['build_dir']}/` with "
        "`-DCMAKE_BUILD_TYPE=Release -DEOM_BENCH_HAND_CHAINS=ON`, builds `eom_bench_hand_chain`, "
        "runs it, writes this file and `hand_derived.json`; `--report-only` rewrites this file "
        "from the json). The agreement of the hand-derived code with the generated kernels and "
        "`eom::Reference` is tested by `tests/hand_chain` (N = 2, 5, 10, 100 random states and "
        "random non-uniform links each, ≤ 1e-12 relative); the benchmark itself checks all "
        "routes against each other on its 64 states at every N before timing.",
        "",
        "## Machine",
        "",
    ]
    lines += [f"- {k}: {v}" for k, v in machine.items()]
    lines += [
        f"- Google Benchmark library: built as {context.get('library_build_type', '?')} (the "
        "distribution's package; it only times the loop)",
        "",
        "## What is timed",
        "",
        "`eom::models::UndampedChain<N>` (models/chain.hpp: absolute link angles, m = l = 1, "
        "I = 1/12, g = 9.81), forward dynamics q̈(q, q̇), one binary (`bench/bench_hand_chain.cpp`), "
        "everything at `-O3 -march=native` (the generated libraries too), each call through a "
        "function the compiler cannot inline into the timing loop:",
        "",
        "- **generated free**: `add_eom_model(... KERNELS forward_dynamics)`, parameters passed at "
        "every call (the default); what depends on the parameters alone is computed once per "
        "parameter set (the kernel's thread_local parameter cache, checked by one memcmp of p per "
        "call), so it is the like-for-like partner of hand;",
        "- **generated fixed**: the same with every parameter in `FIXED_PARAMETERS` (constants in "
        "the emitted code, np = 0);",
        "- **libmvec**: both generated forms again, compiled with `EOM_LIBMVEC`: the sines and "
        "cosines of the angles from glibc's vector math library, 4 per call (within 4 ulp "
        "instead of correctly rounded; opt-in);",
        "- **hand**: `bench/hand_chain.hpp`, the parameter-only products (a_jk, −g b_j: "
        "11N + N(N−1)/2 operations) computed once per parameter set, outside the timing — what a "
        "careful engineer precomputes; then per call N sin/cos (paired into sincos by the "
        "compiler), M_jk = a_jk (c_j c_k + s_j s_k) and c_j = Σ_k a_jk (s_j c_k − c_j s_k) θ̇_k² "
        "over the pairs j < k, gravity, an in-place LDLᵀ with reciprocal pivots (no square "
        "roots) and the two triangular solves; no input or pivot checks;",
        "- **hand per call**: the same, the parameter-only products computed at every call too;",
        "- **hand rows**: hand's M and f, then the factorization a tuned hand-written code would "
        "use (`forward_dynamics_rows`): LDLᵀ in place, right-looking, every update a multiply-add "
        "along a contiguous row of L (vectorized as written), L y = f during the factorization, "
        "the back substitution along rows — the floor at large N.",
        "",
        f"ns per state: CPU time of one iteration over the same 64 random states (θ in [−π, π], "
        f"θ̇ in [−2, 2]) / 64; per run the median of {result['repetitions']} repetitions "
        f"(batches, min time {result['min_time']} s each), then the best of {len(runs)} runs. "
        "Ratios are of those best medians; in brackets, the range of the same ratio within "
        "single runs.",
        "",
        "## Time (ns per state)",
        "",
        "| N | generated free | generated fixed | free, libmvec | fixed, libmvec | hand | "
        "hand per call | hand rows | free / hand | fixed / hand | free, libmvec / hand | "
        "fixed, libmvec / hand |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for n in sizes:
        gf, gx, vf, vx, h, hp, hr = (best(n, r) for r in ROUTES)
        lines.append(
            f"| {n} | {fmt_ns(gf)} | {fmt_ns(gx)} | {fmt_ns(vf)} | {fmt_ns(vx)} | {fmt_ns(h)} | "
            f"{fmt_ns(hp)} | {fmt_ns(hr)} | "
            f"**{fmt_ratio(gf / h)}** ({ratio_range(n, 'generated_free', 'hand')}) | "
            f"**{fmt_ratio(gx / h)}** ({ratio_range(n, 'generated_fixed', 'hand')}) | "
            f"{fmt_ratio(vf / h)} ({ratio_range(n, 'generated_free_libmvec', 'hand')}) | "
            f"{fmt_ratio(vx / h)} ({ratio_range(n, 'generated_fixed_libmvec', 'hand')}) |")
    worst = max(c.get("max_rel_diff", 0) for r in runs for c in r["counters"].values())
    lines += [
        "",
        f"All seven routes agree on the benchmark's states to {worst:.1e} (max |Δq̈| / max |q̈|, "
        "every N).",
        "",
        "## Paired: generated fixed against the floor and against generated free",
        "",
        "`eom_bench_hand_chain --paired`: the two routes called in alternating rounds (1000 calls "
        "each, 201 rounds, one state after another), the median of the per-round ratios "
        "(bench/paired_timing.hpp), so that a change in the machine's load hits both alike; one "
        "figure per run.",
        "",
        "| N | generated fixed / hand rows | generated fixed / generated free |",
        "|---|---|---|",
    ]
    for n in sizes:
        rows = [r.get("paired", {}).get(f"{n}/generated_fixed/hand_rows") for r in runs]
        free = [r.get("paired", {}).get(f"{n}/generated_fixed/generated_free") for r in runs]
        cell = lambda v: ", ".join(f"{x:.2f}" for x in v if x is not None) or "–"
        lines.append(f"| {n} | {cell(rows)} | {cell(free)} |")
    lines += [
        "",
        "## Operation counts",
        "",
        "Generated: the operations of forward_dynamics per call (the count the emitter writes above "
        "the kernel; every statement one operation: +, −, ×, ÷, negation, sin, cos, and the "
        "finiteness and pivot tests of the checked kernel; the angles' sines and cosines count "
        "two per angle; what depends on the parameters alone is computed once per parameter "
        "set, in forward_dynamics_prepare, and not counted, as for hand). From N = 30 the emitter writes the "
        "looped form (`eomgen/kernels.hpp`): its statements build M and f, and one dense LDLᵀ "
        "routine solves them; the column \"+ dense routine\" adds that routine's arithmetic "
        "counted from its loops. Hand-derived: every +, −, ×, ÷, negation, sin and cos the code "
        "does, as formulas in N (checked against the code run on a counting number type by "
        "tests/hand_chain):",
        "",
        "- per call, prepared: 6N + 19N(N−1)/2 + N(N−1)(2N−1)/6 = 2N sin/cos + 2N (θ̇², gravity) "
        "+ 12 per pair j < k (cos and sin of the difference, M_jk, both Coriolis terms) + "
        "N(N−1)(2N−1)/6 + 3N(N−1)/2 + N (LDLᵀ, ≈ N³/6 multiply-adds) + 2N(N−1) + N (solves);",
        "- per call with the parameter products: + 11N + N(N−1)/2.",
        "",
        "| N | generated free | generated fixed | + dense routine | hand | hand per call | "
        "generated free / hand | generated fixed / hand |",
        "|---|---|---|---|---|---|---|---|",
    ]
    ops = result["operations"]
    for n in sizes:
        free, fixed = ops.get(f"{n}/free"), ops.get(f"{n}/fixed")
        counters = runs[0]["counters"]
        h = counters.get(f"hand_chain/{n}/hand", {}).get("operations")
        hp = counters.get(f"hand_chain/{n}/hand_per_call", {}).get("operations")
        looped = free and free["looped"]
        extra = dense_routine_operations(n) if looped else 0
        gf = free["statements"] + extra if free else None
        gx = fixed["statements"] + extra if fixed else None
        lines.append(
            f"| {n} | {free['statements'] if free else '–'} | {fixed['statements'] if fixed else '–'}"
            f" | {('+ ' + str(extra)) if looped else '(unrolled)'} | {int(h) if h else '–'} | "
            f"{int(hp) if hp else '–'} | {fmt_ratio(gf / h) if gf and h else '–'} | "
            f"{fmt_ratio(gx / h) if gx and h else '–'} |")
    lines += [
        "",
        "<!-- discussion: hand-written, kept by bench/hand_chain.py -->",
        result.get("discussion", "").strip(),
        "<!-- end of discussion -->",
        "",
    ]
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))


def kept_discussion(path):
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError:
        return ""
    m = re.search(r"<!-- discussion: hand-written, kept by bench/hand_chain.py -->\n(.*?)"
                  r"<!-- end of discussion -->", text, re.S)
    return m.group(1) if m else ""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build-dir", default="build-hand-chain")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--repetitions", type=int, default=9)
    parser.add_argument("--min-time", default="0.2")
    parser.add_argument("--out", default=os.path.join(ROOT, "docs", "benchmarks"))
    parser.add_argument("--report-only", action="store_true")
    args = parser.parse_args()
    md = os.path.join(args.out, "hand_derived.md")
    js = os.path.join(args.out, "hand_derived.json")
    if args.report_only:
        with open(js, encoding="utf-8") as f:
            result = json.load(f)
    else:
        build_dir = os.path.abspath(args.build_dir)
        machine = machine_info()
        build(build_dir)
        result = {
            "command": "bench/hand_chain.py" + ("" if args.build_dir == "build-hand-chain"
                                               else f" --build-dir {args.build_dir}"),
            "build_dir": args.build_dir, "machine": machine, "repetitions": args.repetitions,
            "min_time": args.min_time,
            "runs": run_benchmark(build_dir, args.runs, args.repetitions, args.min_time),
            "operations": generated_operations(build_dir),
        }
        with open(js, "w", encoding="utf-8") as f:
            json.dump(result, f, indent=1)
    result["discussion"] = kept_discussion(md)
    report(result, md)
    progress(f"wrote {md}")


if __name__ == "__main__":
    main()
