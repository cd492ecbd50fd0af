#!/usr/bin/env python3
"""Generator scaling study: eomgen against SymPy on the N-link chain, N = 2 … 100.

    bench/scaling.py [--sizes 2 5 10 ...] [--sympy-cap 120] [--compile-cap 600]
                     [--build-dir build-bench] [--python /usr/bin/python3] [--out docs/benchmarks]
                     [--reuse-sympy]

For each N, for the kernels mass_matrix, coriolis and forward_dynamics of eom::models::Chain<N>:
  eomgen  the tracer's run (trace + derive + emit, one process: wall and CPU seconds, peak
          memory), emitted bytes and operation count per kernel (from the generated comments),
          and the compile of the emitted .cpp at -O2 (seconds, peak memory by /usr/bin/time -v);
  SymPy   bench/sympy_models.py (LagrangesMethod + cse + ccode) likewise, until one N takes
          longer than --sympy-cap seconds: larger N are not attempted (recorded as stopped);
          --reuse-sympy keeps the SymPy rows of the existing scaling.json instead (they do not
          depend on eomgen, and take most of the study's time).
Then forward_dynamics alone in its two forms (eomgen/kernels.hpp: unrolled, looped) for
N = 5 … 100: operations, compile time and memory, and run time by eom_bench_solve_forms.
Writes <out>/scaling.md, scaling.json and scaling.csv; progress goes to stderr. Standard library
only; the SymPy side runs under --python (default /usr/bin/python3, where Debian's
python3-sympy lives).
"""

import argparse
import datetime
import json
import math
import os
import re
import shutil
import subprocess
import sys
import time

KERNELS = ["mass_matrix", "coriolis", "forward_dynamics"]
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
START = time.monotonic()


def progress(message):
    print(f"scaling: [{time.monotonic() - START:6.0f} s] {message}", file=sys.stderr, flush=True)


def check_prerequisites(python):
    """Names every missing tool and the Debian package that brings it, then exits."""
    missing = []
    if not os.access("/usr/bin/time", os.X_OK):
        missing.append(("time", "GNU time at /usr/bin/time (peak memory by time -v)"))
    for tool, package in (("cmake", "cmake"), ("g++", "g++"), ("timeout", "coreutils")):
        if shutil.which(tool) is None:
            missing.append((package, tool))
    if not os.access(python, os.X_OK):
        missing.append(("python3-sympy", f"a Python 3 at {python} (--python) with SymPy"))
    elif subprocess.run([python, "-c", "import sympy"], capture_output=True).returncode != 0:
        missing.append(("python3-sympy", f"SymPy ({python} -c 'import sympy' fails)"))
    if missing:
        print("scaling.py: missing prerequisites:", file=sys.stderr)
        for _, what in missing:
            print(f"  - {what}", file=sys.stderr)
        packages = " ".join(dict.fromkeys(p for p, _ in missing))
        sys.exit(f"install them with: apt-get install {packages}")


def timed(command, cwd=None):
    """Runs command under /usr/bin/time -v: (returncode, wall s, cpu s, peak MB, stderr)."""
    result = subprocess.run(["/usr/bin/time", "-v", *command], cwd=cwd, capture_output=True,
                            text=True)
    err = result.stderr

    def field(name):
        m = re.search(rf"^\s*{re.escape(name)}: (.*)$", err, re.M)
        return m.group(1).strip() if m else None

    wall = 0.0
    clock = field("Elapsed (wall clock) time (h:mm:ss or m:ss)")
    if clock:
        for part in clock.split(":"):
            wall = wall * 60 + float(part)
    cpu = float(field("User time (seconds)") or 0) + float(field("System time (seconds)") or 0)
    peak_mb = int(field("Maximum resident set size (kbytes)") or 0) / 1024
    return result.returncode, wall, cpu, peak_mb, err


def kernel_sections(source, prefix):
    """{kernel: (ops, bytes)} from a generated .cpp: a kernel's text runs from its first
    '// <name>: <kernel>' comment (its parts come first) to the next kernel's."""
    marks = [(m.start(), m.group(1)) for m in
             re.finditer(rf"^// {re.escape(prefix)}: (\w+)", source, re.M)]
    out = {}
    for i, (pos, kernel) in enumerate(marks):
        if kernel not in KERNELS:
            continue
        end = next((p for p, k in marks[i + 1:] if k != kernel), len(source))
        size = len(source[pos:end].encode())
        ops = re.search(rf"^// {re.escape(prefix)}: {kernel} \((\d+) operations", source, re.M)
        prev = out.get(kernel, (None, 0))
        out[kernel] = (int(ops.group(1)) if ops else prev[0], max(prev[1], size))
    return out


def compile_o2(cpp, include_dir, cap):
    command = ["timeout", "-k", "5", str(cap), "g++", "-std=c++17", "-O2", "-c", cpp,
               "-I", include_dir, "-o", cpp + ".o"]
    rc, wall, cpu, mb, err = timed(command)
    if os.path.exists(cpp + ".o"):
        os.remove(cpp + ".o")
    if rc == 124:
        return {"compile_s": None, "compile_note": f"> {cap} s (cap)", "compile_mb": mb}
    if rc != 0:
        raise SystemExit(f"scaling.py: compiling {cpp} failed:\n{err[-2000:]}")
    return {"compile_s": wall, "compile_cpu_s": cpu, "compile_mb": mb}


def eomgen_row(n, tracer, work, compile_cap, kernels=KERNELS, solve=None):
    name = f"chain{n}" if kernels == KERNELS else f"chain{n}_" + "_".join(kernels)
    if solve:
        name += "_" + solve
    out_dir = os.path.join(work, "eomgen", name)
    os.makedirs(out_dir, exist_ok=True)
    command = [tracer, str(n), "--name", name, "--class", f"eom::models::Chain<{n}>",
               "--out-dir", out_dir]
    for k in kernels:
        command += ["--kernel", k]
    if solve:
        command += ["--solve", solve]
    rc, wall, cpu, mb, err = timed(command)
    if rc != 0:
        raise SystemExit(f"scaling.py: the tracer failed for N = {n}:\n{err[-2000:]}")
    cpp = os.path.join(out_dir, name + ".cpp")
    with open(cpp, encoding="utf-8") as fh:
        source = fh.read()
    row = {"n": n, "generate_s": wall, "generate_cpu_s": cpu, "generate_mb": mb,
           "bytes": len(source.encode()) + os.path.getsize(os.path.join(out_dir, name + ".hpp")),
           "kernels": {k: {"ops": o, "bytes": b} for k, (o, b) in
                       kernel_sections(source, name).items()}}
    what = ("" if kernels == KERNELS else " (" + ", ".join(kernels) + " only)") + \
        (f" {solve}" if solve else "")
    progress(f"N = {n:3d} eomgen{what}: generated in {wall:.2f} s ({mb:.0f} MB), "
             f"{row['bytes']} bytes; compiling at -O2")
    row.update(compile_o2(cpp, out_dir, compile_cap))
    progress(f"N = {n:3d} eomgen{what}: compiled in "
             f"{row.get('compile_s') or row.get('compile_note')} s, {row['compile_mb']:.0f} MB")
    return row


def sympy_row(n, python, work, cap, compile_cap):
    name = f"chain{n}"
    out_dir = os.path.join(work, "sympy")
    stats = os.path.join(out_dir, f"sympy_{name}.json")
    os.makedirs(out_dir, exist_ok=True)
    if os.path.exists(stats):
        os.remove(stats)
    command = ["timeout", "-k", "5", str(cap), python,
               os.path.join(ROOT, "bench", "sympy_models.py"), name, "--out-dir", out_dir,
               "--stats", stats]
    progress(f"N = {n:3d} SymPy: deriving (cap {cap} s)")
    rc, wall, cpu, mb, err = timed(command)
    if rc == 124:
        progress(f"N = {n:3d} SymPy: stopped at the {cap} s cap")
        return {"n": n, "stopped": f"> {cap} s (cap)", "generate_mb": mb}
    if rc != 0:
        raise SystemExit(f"scaling.py: sympy_models.py failed for N = {n}:\n{err[-2000:]}")
    with open(stats, encoding="utf-8") as fh:
        s = json.load(fh)
    row = {"n": n, "generate_s": wall, "generate_cpu_s": cpu, "generate_mb": mb,
           "derive_s": s["derive_s"], "cse_s": s["cse_s"], "print_s": s["print_s"],
           "bytes": s["bytes"], "kernels": s["functions"]}
    progress(f"N = {n:3d} SymPy: {wall:.1f} s, {row['bytes']} bytes; compiling at -O2")
    row.update(compile_o2(os.path.join(out_dir, f"sympy_{name}.cpp"), out_dir, compile_cap))
    progress(f"N = {n:3d} SymPy: compiled in {row.get('compile_s') or row.get('compile_note')}"
             f" s, {row['compile_mb']:.0f} MB")
    return row


def growth(rows, kernel, lo, what="bytes"):
    """Least-squares slope of log(what) against log(N) over N >= lo (the growth exponent)."""
    pts = [(math.log(r["n"]), math.log(r["kernels"][kernel][what])) for r in rows
           if r["n"] >= lo and kernel in r.get("kernels", {})]
    if len(pts) < 2:
        return None
    mx = sum(x for x, _ in pts) / len(pts)
    my = sum(y for _, y in pts) / len(pts)
    return (sum((x - mx) * (y - my) for x, y in pts) /
            sum((x - mx) ** 2 for x, _ in pts))


def fmt(x, digits=2):
    return "—" if x is None else f"{x:.{digits}f}"


def compile_cell(row):
    s = row.get("compile_s")
    return fmt(s, 1) if s is not None else row.get("compile_note", "—")


def report(result, path, machine):
    eom, sym = result["eomgen"], result["sympy"]
    lines = ["# Generator scaling: the N-link chain, eomgen against SymPy\n",
             f"Regenerate with `{result['command']}` (checks its prerequisites, builds "
             "`eom_chain_tracer` in `build-bench/`, writes this file, `scaling.json` and "
             "`scaling.csv`; about 15-20 minutes on this machine; `--report-only` rewrites "
             "this file from scaling.json).\n",
             "## Machine\n"]
    lines += [f"- {k}: {v}" for k, v in machine.items()]
    lines.append("")
    lines.append("Kernels: mass_matrix, coriolis, forward_dynamics of `eom::models::Chain<N>` "
                 "(for SymPy: M, c, and M with the forcing f, q̈ being left to a numerical "
                 "solve). Seconds are wall-clock seconds of one process on a shared machine "
                 "(CPU seconds beside them); memory is the peak resident set size by "
                 "`/usr/bin/time -v`; compile is `g++ -std=c++17 -O2 -c` of the emitted "
                 "source alone.\n")
    lines.append("## eomgen\n")
    lines.append("| N | generate s | (CPU s) | peak MB | bytes | bytes M | bytes c | bytes q̈ | "
                 "ops M | ops c | ops q̈ | compile -O2 s | compile MB |")
    lines.append("|---" * 13 + "|")
    for r in eom:
        k = r["kernels"]
        lines.append(
            f"| {r['n']} | {fmt(r['generate_s'])} | {fmt(r['generate_cpu_s'])} | "
            f"{r['generate_mb']:.0f} | {r['bytes']} | {k['mass_matrix']['bytes']} | "
            f"{k['coriolis']['bytes']} | {k['forward_dynamics']['bytes']} | "
            f"{k['mass_matrix']['ops']} | {k['coriolis']['ops']} | "
            f"{k['forward_dynamics']['ops']} | "
            f"{compile_cell(r)} | "
            f"{r['compile_mb']:.0f} |")
    lines.append("")
    lines.append("## SymPy (LagrangesMethod + cse + ccode)\n")
    lines.append("| N | generate s | (CPU s) | derive s | cse s | print s | peak MB | bytes | "
                 "ops M | ops c | ops M, f | compile -O2 s | compile MB |")
    lines.append("|---" * 13 + "|")
    for r in sym:
        if "stopped" in r:
            lines.append(f"| {r['n']} | {r['stopped']} | | | | | {r['generate_mb']:.0f} | "
                         "| | | | | |")
            continue
        k = r["kernels"]
        lines.append(
            f"| {r['n']} | {fmt(r['generate_s'], 1)} | {fmt(r['generate_cpu_s'], 1)} | "
            f"{fmt(r['derive_s'], 1)} | {fmt(r['cse_s'], 1)} | {fmt(r['print_s'], 1)} | "
            f"{r['generate_mb']:.0f} | {r['bytes']} | {k['mass_matrix']['ops']} | "
            f"{k['coriolis']['ops']} | {k['dynamics_terms']['ops']} | "
            f"{compile_cell(r)} | "
            f"{r['compile_mb']:.0f} |")
    not_tried = [n for n in result["sizes"] if n not in {r["n"] for r in sym}]
    if not_tried:
        lines.append(f"\nNot attempted after the cap: N = {', '.join(map(str, not_tried))}.")
    lines.append("")

    lines.append("## Aims, from this run\n")
    by_n = {r["n"]: r for r in eom}
    for n, limit in ((30, 3.0), (100, 30.0)):
        if n in by_n:
            s = by_n[n]["generate_s"]
            lines.append(f"- N = {n} generates in under {limit:.0f} s: **{s:.2f} s** — "
                         f"{'met' if s < limit else 'missed'}.")
    for kernel in ("mass_matrix", "coriolis", "forward_dynamics"):
        slope, ops_slope = growth(eom, kernel, 20), growth(eom, kernel, 20, "ops")
        if slope is not None:
            # M has N² entries, so N² is its floor. Bytes also carry the temporaries' names,
            # whose digits grow as log N: 2.1 allows for that and for the fit.
            verdict = ("" if kernel == "forward_dynamics" else
                       (" — met (aim: no faster than N²)" if slope <= 2.1 else " — missed"))
            lines.append(f"- emitted size of {kernel} grows as N^{slope:.2f}, its operation "
                         f"count as N^{ops_slope:.2f} (least-squares slopes in log-log, "
                         f"N ≥ 20){verdict}.")
    if 100 in by_n:
        r = by_n[100]
        s, mb = r.get("compile_s"), r["compile_mb"]
        ok = s is not None and s < 120 and mb < 2048
        lines.append(f"- N = 100 compiles (-O2) in under 2 min and 2 GiB: **"
                     f"{fmt(s, 1) if s is not None else r.get('compile_note')} s, {mb:.0f} MB**"
                     f" — {'met' if ok else 'missed'}.")
    forms = result.get("solve_forms")
    if forms:
        unrolled = {r["n"]: r for r in forms["unrolled"]}
        looped = {r["n"]: r for r in forms["looped"]}
        big = max(looped)
        lines.append(f"- forward_dynamics alone at N = {big}: unrolled compiles in "
                     f"{compile_cell(unrolled[big])} s, {unrolled[big]['compile_mb']:.0f} MB; "
                     f"looped (the default from N = {forms['looped_solve_from']}) in "
                     f"{compile_cell(looped[big])} s, {looped[big]['compile_mb']:.0f} MB "
                     "(next section).")
    stopped = [r for r in sym if "stopped" in r]
    done = [r for r in sym if "stopped" not in r]
    if done:
        lines.append(f"- SymPy: largest N derived within the {result['sympy_cap']} s cap: "
                     f"N = {max(r['n'] for r in done)}" +
                     (f"; stopped at N = {stopped[0]['n']}." if stopped else "."))
    lines.append("")
    if forms:
        lines += solve_forms_section(forms)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines))


def solve_forms_section(forms):
    """forward_dynamics unrolled against looped: size, compile, run time."""
    lines = ["## forward_dynamics: unrolled or looped\n",
             "The generator writes forward_dynamics' LDLᵀ factorization and solves either as "
             "straight-line statements (unrolled: structural zeros vanish, O(N³) statements for "
             "the chain's dense M) or as loops over M and f written straight-line (looped: "
             "O(N²) statements; `eomgen/kernels.hpp`). From N = "
             f"{forms['looped_solve_from']} coordinates it takes the looped form by default "
             "(`--solve unrolled|looped` on the tracer forces one). Below, forward_dynamics "
             "alone in both forms: operations as emitted (the looped form's dense routine not "
             "counted), compile at -O2, and CPU ns per call by `eom_bench_solve_forms` (-O3 "
             "-march=native, median of 5 repetitions over 32 random states, both forms in one "
             "run; they agree to the worst relative difference given).\n",
             "| N | ops unrolled | ops looped | compile unrolled s | MB | compile looped s | MB | "
             "ns unrolled | ns looped | looped / unrolled time | agreement |",
             "|---" * 11 + "|"]
    unrolled = {r["n"]: r for r in forms["unrolled"]}
    run = forms.get("run_ns", {})
    for r in forms["looped"]:
        n = r["n"]
        u = unrolled[n]
        t = run.get(str(n), {})
        ratio = (f"{t['looped'] / t['unrolled']:.2f}" if t.get("looped") and t.get("unrolled")
                 else "—")
        lines.append(
            f"| {n} | {u['kernels']['forward_dynamics']['ops']} | "
            f"{r['kernels']['forward_dynamics']['ops']} | {compile_cell(u)} | "
            f"{u['compile_mb']:.0f} | {compile_cell(r)} | {r['compile_mb']:.0f} | "
            f"{fmt(t.get('unrolled'), 0)} | {fmt(t.get('looped'), 0)} | {ratio} | "
            f"{t.get('agreement', '—')} |")
    lines.append("")
    return lines


def run_solve_forms(build_dir, sizes):
    """CPU ns per call of both forms by eom_bench_solve_forms: {n: {unrolled, looped, agreement}}."""
    subprocess.run(["cmake", "--build", build_dir, "-j2", "--target", "eom_bench_solve_forms"],
                   check=True, stdout=subprocess.DEVNULL)
    result = subprocess.run(
        [os.path.join(build_dir, "bench", "eom_bench_solve_forms"), "--benchmark_format=json",
         "--benchmark_repetitions=5", "--benchmark_report_aggregates_only=true"],
        capture_output=True, text=True, check=True)
    data = json.loads(result.stdout[result.stdout.index("{"):])
    out = {}
    for b in data["benchmarks"]:
        m = re.fullmatch(r"chain(\d+)/(unrolled|looped)_median", b["name"])
        if m and int(m.group(1)) in sizes:
            out.setdefault(m.group(1), {})[m.group(2)] = b["cpu_time"]
    for key, value in data["context"].items():
        m = re.fullmatch(r"agreement/chain(\d+)", key)
        if m and m.group(1) in out:
            out[m.group(1)]["agreement"] = f"{float(value):.1e}"
    return out


def looped_solve_from():
    """The generator's threshold, read from its header (the one source of the number)."""
    with open(os.path.join(ROOT, "generator", "include", "eomgen", "kernels.hpp"),
              encoding="utf-8") as fh:
        return int(re.search(r"looped_solve_from = (\d+);", fh.read()).group(1))


def machine_info():
    def run(cmd):
        try:
            return subprocess.run(cmd, capture_output=True, text=True, shell=True).stdout.strip()
        except OSError:
            return "?"
    return {
        "CPU": run("lscpu | sed -n 's/^Model name: *//p' | head -1"),
        "cores": run("nproc") + " logical CPUs (" +
                 run("lscpu | sed -n 's/^Core(s) per socket: *//p' | head -1") + " per socket)",
        "compiler": run("g++ --version | head -1"),
        "date": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
        "load average at start": run("cut -d' ' -f1-3 /proc/loadavg") +
                                 " (a shared machine: wall times include waiting for a core)",
    }


def fmt_ns(x):
    """A time in ns for the reports' tables (– when missing)."""
    if x is None:
        return "–"
    return f"{x:,.0f}" if x >= 100 else f"{x:.1f}"


def run_or_exit(script, command, **kw):
    """subprocess.run for the benchmark scripts' steps: exits naming the command when it fails."""
    result = subprocess.run(command, **kw)
    if result.returncode != 0:
        sys.exit(f"{script}: failed: {' '.join(command)}")
    return result


DISCUSSION_END = "<!-- end of discussion -->"


def discussion_begin(script):
    """The marker before the hand-written discussion a report of bench/<script> keeps."""
    return f"<!-- discussion: hand-written, kept by bench/{script} -->"


def discussion_section(script, text):
    """A report's closing lines: its hand-written discussion between the markers."""
    return ["## Discussion", "", discussion_begin(script), (text or "(to be written)").strip(),
            DISCUSSION_END, ""]


def kept_discussion(path, script):
    """The hand-written discussion between the markers of the report at path (None: none)."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError:
        return None
    begin = discussion_begin(script)
    i, j = text.find(begin), text.find(DISCUSSION_END)
    return text[i + len(begin):j].strip() if 0 <= i < j else None


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+",
                        default=[2, 3, 5, 7, 10, 15, 20, 30, 40, 50, 70, 100])
    parser.add_argument("--sympy-cap", type=int, default=120,
                        help="seconds; SymPy is not tried at larger N after one N exceeds it")
    parser.add_argument("--compile-cap", type=int, default=600, help="seconds per compile")
    parser.add_argument("--build-dir", default=os.environ.get("EOM_BENCH_BUILD_DIR",
                                                               "build-bench"))
    parser.add_argument("--python", default=os.environ.get("EOM_SYMPY_PYTHON", "/usr/bin/python3"))
    parser.add_argument("--out", default="docs/benchmarks")
    parser.add_argument("--reuse-sympy", action="store_true",
                        help="keep the SymPy rows of the existing scaling.json")
    parser.add_argument("--report-only", action="store_true",
                        help="rewrite scaling.md from the existing scaling.json, measuring nothing")
    args = parser.parse_args()
    os.chdir(ROOT)
    if args.report_only:
        with open(os.path.join(args.out, "scaling.json"), encoding="utf-8") as fh:
            result = json.load(fh)
        report(result, os.path.join(args.out, "scaling.md"), result["machine"])
        return
    check_prerequisites(args.python)
    machine = machine_info()

    progress(f"building eom_chain_tracer in {args.build_dir}")
    subprocess.run(["cmake", "-S", ".", "-B", args.build_dir, "-DCMAKE_BUILD_TYPE=Release",
                    "-DEOM_BENCH_PEERS=ON",
                    f"-DEOM_SYMPY_PYTHON={args.python}"], check=True, stdout=subprocess.DEVNULL)
    subprocess.run(["cmake", "--build", args.build_dir, "-j2", "--target", "eom_chain_tracer"],
                   check=True, stdout=subprocess.DEVNULL)
    tracer = os.path.join(args.build_dir, "bench", "eom_chain_tracer")
    compiled = set(map(int, subprocess.run([tracer, "--sizes"], capture_output=True, text=True,
                                           check=True).stdout.split()))
    unknown = [n for n in args.sizes if n not in compiled]
    if unknown:
        sys.exit(f"scaling.py: eom_chain_tracer has no Chain<N> for N = {unknown}; it knows "
                 f"{sorted(compiled)} (bench/chain_tracer.cpp)")
    work = os.path.join(args.build_dir, "scaling")
    result = {"command": "bench/scaling.py", "sizes": args.sizes, "sympy_cap": args.sympy_cap,
              "machine": machine, "eomgen": [], "sympy": []}
    sympy_stopped = False
    if args.reuse_sympy:
        with open(os.path.join(args.out, "scaling.json"), encoding="utf-8") as fh:
            result["sympy"] = json.load(fh)["sympy"]
        sympy_stopped = True
        progress("SymPy: the rows of the existing scaling.json (--reuse-sympy)")
    for n in args.sizes:
        result["eomgen"].append(eomgen_row(n, os.path.abspath(tracer), work, args.compile_cap))
        if not sympy_stopped:
            row = sympy_row(n, args.python, work, args.sympy_cap, args.compile_cap)
            result["sympy"].append(row)
            sympy_stopped = "stopped" in row

    # forward_dynamics alone in both forms, at the sizes eom_bench_solve_forms times.
    form_sizes = [n for n in (5, 10, 20, 30, 50, 100) if n in args.sizes]
    forms = {"looped_solve_from": looped_solve_from(), "unrolled": [], "looped": []}
    for n in form_sizes:
        for form in ("unrolled", "looped"):
            forms[form].append(eomgen_row(n, os.path.abspath(tracer), work, args.compile_cap,
                                          ["forward_dynamics"], form))
    progress("timing both forms (eom_bench_solve_forms)")
    forms["run_ns"] = run_solve_forms(args.build_dir, form_sizes)
    result["solve_forms"] = forms

    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "scaling.json"), "w", encoding="utf-8") as fh:
        json.dump(result, fh, indent=1)
    with open(os.path.join(args.out, "scaling.csv"), "w", encoding="utf-8") as fh:
        fh.write("route,n,generate_s,generate_cpu_s,generate_mb,bytes,ops_mass_matrix,"
                 "ops_coriolis,ops_dynamics,compile_s,compile_mb,note\n")
        for route, rows, dyn in (("eomgen", result["eomgen"], "forward_dynamics"),
                                 ("eomgen_forward_dynamics_unrolled", forms["unrolled"],
                                  "forward_dynamics"),
                                 ("eomgen_forward_dynamics_looped", forms["looped"],
                                  "forward_dynamics"),
                                 ("sympy", result["sympy"], "dynamics_terms")):
            for r in rows:
                k = r.get("kernels", {})
                ops = [str(k.get(x, {}).get("ops", "")) for x in ("mass_matrix", "coriolis", dyn)]
                seconds = [f"{r[k]:.2f}" if r.get(k) is not None else ""
                           for k in ("generate_s", "generate_cpu_s", "compile_s")]
                fh.write(",".join([route, str(r["n"]), seconds[0], seconds[1],
                                   f"{r['generate_mb']:.1f}",
                                   str(r.get("bytes", "")), *ops, seconds[2],
                                   f"{r.get('compile_mb', 0):.1f}",
                                   r.get("stopped", r.get("compile_note", ""))]) + "\n")
    report(result, os.path.join(args.out, "scaling.md"), machine)
    progress(f"done: {args.out}/scaling.md, scaling.json, scaling.csv")


if __name__ == "__main__":
    main()
