#!/usr/bin/env python3
"""Compile cost of the default kernels at humanoid scale: generation and compile, time and memory.

    bench/compile_cost.py [--build-dir build] [--models chain30 humanoid chain60]
                          [--out docs/benchmarks] [--report-only]

The models of bench/compile_cost/CMakeLists.txt, each with add_eom_model()'s default kernels, as a
user's project builds them against this build installed into a prefix (find_package):
  chain30   bench/robots/chain30.urdf (30 revolute joints, fixed base)
  humanoid  MuJoCo's humanoid.xml (libmujoco-samples: a free base and 21 hinges, nv = 27)
  chain60   bench/robots/make_chains.py's chain at N = 60 (written into the work folder)
One model at a time, one core (`cmake --build -j1`), the kernels at -O2 (CMAKE_BUILD_TYPE Release
with CMAKE_CXX_FLAGS_RELEASE=-O2). Every compile and build-time command runs under GNU time
(the project's launchers), which gives each step's wall and CPU seconds and peak memory: the
URDF/MJCF reader, the tracer's compile (-O0) and link, the tracer's run (trace, derive, optimize,
emit) and the compile of the generated source. The bound checked: no step above 2 GB.
Writes <out>/compile_cost.md and compile_cost.json; progress goes to stderr. Standard library only.
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "robots"))
from make_chains import chain  # noqa: E402  the benchmark chains' URDF, at any N
from scaling import discussion_section, kept_discussion, machine_info, run_or_exit  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MODELS = ["chain30", "humanoid", "chain60"]
BOUND_MB = 2048
START = time.monotonic()
SCRIPT = "compile_cost.py"


def progress(message):
    print(f"compile_cost: [{time.monotonic() - START:6.0f} s] {message}", file=sys.stderr,
          flush=True)


def check_prerequisites(build_dir, humanoid):
    problems = []
    if not os.access("/usr/bin/time", os.X_OK):
        problems.append("GNU time at /usr/bin/time (apt-get install time)")
    if not os.path.exists(humanoid):
        problems.append(f"MuJoCo's humanoid at {humanoid} (apt-get install libmujoco-samples)")
    if not os.path.exists(os.path.join(build_dir, "cmake_install.cmake")):
        problems.append(f"a configured and built eomgen in {build_dir} (--build-dir; "
                        "cmake -S . -B build && cmake --build build -j2)")
    if problems:
        sys.exit("compile_cost.py: missing:\n  - " + "\n  - ".join(problems))


def steps(log, model):
    """The timed commands of one model's build, from GNU time's lines
    'wall|user|sys|peak KB|command', as (step, wall s, CPU s, peak MB)."""
    out = []
    with open(log, encoding="utf-8") as f:
        for line in f:
            parts = line.rstrip("\n").split("|", 4)
            if len(parts) != 5 or not re.match(r"^[\d.]+$", parts[0]):
                continue  # GNU time's own notes ("Command exited with non-zero status")
            wall, user, system, kb, command = parts
            if " -E touch " in command:
                continue
            if "eomgen-urdf" in command or "eomgen-mjcf" in command:
                step = "read"
            elif "--out-dir" in command:
                step = "generate"
            elif f"eomgen_tracer_{model}" in command:
                step = "tracer"  # its compile and its link
            elif f"/{model}.cpp.o" in command and " -c " in command:
                step = "compile"
            else:
                step = "other"
            out.append((step, float(wall), float(user) + float(system), int(kb) / 1024))
    return out


def kernels_of(source_dir, model):
    """{kernel: (operations, looped)} from the generated source's comments, and its bytes."""
    cpp = os.path.join(source_dir, f"{model}.cpp")
    with open(cpp, encoding="utf-8") as f:
        text = f.read()
    found = {}
    for m in re.finditer(rf"^// {re.escape(model)}: (\w+) \((\d+) operations([^\n]*)", text, re.M):
        if m.group(1) not in found:
            found[m.group(1)] = (int(m.group(2)), "looped dense solve" in m.group(3))
    sizes = {}
    with open(os.path.join(source_dir, f"{model}.hpp"), encoding="utf-8") as f:
        header = f.read()
    for name in ("nq", "nv"):
        m = re.search(rf"inline constexpr int {name} = (\d+);", header)
        sizes[name] = int(m.group(1)) if m else None
    return found, len(text.encode()), sizes


def measure(args, work, models):
    prefix, build = os.path.join(work, "prefix"), os.path.join(work, "build")
    log = os.path.join(work, "times.txt")
    progress(f"installing {args.build_dir} into {prefix}")
    shutil.rmtree(prefix, ignore_errors=True)
    run_or_exit(SCRIPT, ["cmake", "--install", args.build_dir, "--prefix", prefix],
                stdout=subprocess.DEVNULL)
    chain60 = os.path.join(work, "chain60.urdf")
    with open(chain60, "w", encoding="ascii") as f:
        f.write(chain(60))
    shutil.rmtree(build, ignore_errors=True)
    run_or_exit(SCRIPT, ["cmake", "-S", os.path.join(ROOT, "bench", "compile_cost"), "-B", build,
                         "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_CXX_FLAGS_RELEASE=-O2 -DNDEBUG",
                         f"-DCMAKE_PREFIX_PATH={prefix}", f"-DEOM_COST_LOG={log}",
                         f"-DEOM_COST_CHAIN60={chain60}", f"-DEOM_COST_HUMANOID={args.humanoid}"],
                stdout=subprocess.DEVNULL)
    rows = []
    for model in models:
        if os.path.exists(log):
            os.remove(log)
        progress(f"{model}: building its default kernels on one core")
        t0 = time.monotonic()
        run_or_exit(SCRIPT, ["cmake", "--build", build, "--target", model, "-j1"],
                    stdout=subprocess.DEVNULL)
        wall = time.monotonic() - t0
        timed = steps(log, model)
        kernels, source_bytes, sizes = kernels_of(os.path.join(build, "eomgen", model), model)
        row = {"model": model, **sizes, "build_wall_s": wall, "source_bytes": source_bytes,
               "kernels": {k: {"ops": o, "looped": lp} for k, (o, lp) in kernels.items()},
               "steps": {}}
        for step, w, cpu, mb in timed:
            s = row["steps"].setdefault(step, {"wall_s": 0.0, "cpu_s": 0.0, "peak_mb": 0.0})
            s["wall_s"] += w
            s["cpu_s"] += cpu
            s["peak_mb"] = max(s["peak_mb"], mb)
        row["peak_mb"] = max((s["peak_mb"] for s in row["steps"].values()), default=0.0)
        progress(f"{model}: {wall:.1f} s, {len(kernels)} kernels, {source_bytes} bytes, "
                 f"peak {row['peak_mb']:.0f} MB")
        rows.append(row)
    return rows


def cell(row, step, what, digits=1):
    s = row["steps"].get(step)
    return "–" if s is None else f"{s[what]:.{digits}f}"


def report(result, path, discussion):
    lines = ["# Compile cost at humanoid scale: the default kernels, generated and compiled\n",
             "Regenerate with `bench/compile_cost.py --build-dir <a built eomgen>` (installs the "
             "build into a prefix, builds the "
             "models of `bench/compile_cost/CMakeLists.txt` one at a time on one core, writes this "
             "file and `compile_cost.json`; `--report-only` rewrites this file from the JSON).\n",
             "## Machine\n"]
    lines += [f"- {k}: {v}" for k, v in result["machine"].items()]
    lines += ["",
              "Each model with add_eom_model()'s default kernels, built as a user's project builds "
              "it (find_package of the installed eomgen), `cmake --build -j1`, the kernels at -O2. "
              "CPU seconds of each step by GNU time (wall seconds include waiting for a core on "
              "this shared machine); peak is the largest resident set of any one process of the "
              "step. read: the URDF/MJCF reader writing the model header; tracer: compiling (-O0) "
              "and linking the model's tracer; generate: the tracer's run (trace, derive, "
              "optimize, emit); compile: the generated source at -O2.\n",
              "| model | nq | nv | kernels | operations | source MB | read s | tracer s | "
              "generate s | generate MB | compile s | compile MB | build wall s | peak MB |",
              "|---" * 14 + "|"]
    for r in result["rows"]:
        ops = sum(k["ops"] for k in r["kernels"].values())
        lines.append(
            f"| {r['model']} | {r['nq']} | {r['nv']} | {len(r['kernels'])} | {ops:,} | "
            f"{r['source_bytes'] / 1e6:.2f} | {cell(r, 'read', 'cpu_s')} | "
            f"{cell(r, 'tracer', 'cpu_s')} | {cell(r, 'generate', 'cpu_s')} | "
            f"{cell(r, 'generate', 'peak_mb', 0)} | {cell(r, 'compile', 'cpu_s')} | "
            f"{cell(r, 'compile', 'peak_mb', 0)} | {r['build_wall_s']:.1f} | {r['peak_mb']:.0f} |")
    lines += ["", "Kernels and their operations (looped: the dense solve written as loops, "
              "eomgen/kernels.hpp's automatic choice where M's factor is as full as a dense M of 30 coordinates):\n"]
    for r in result["rows"]:
        listed = ", ".join(f"{k} {v['ops']:,}" + (" (looped)" if v["looped"] else "")
                           for k, v in r["kernels"].items())
        lines.append(f"- {r['model']}: {listed}")
    worst = max(result["rows"], key=lambda r: r["peak_mb"])
    verdict = "met" if worst["peak_mb"] <= BOUND_MB else "**missed**"
    lines += ["", "## The bound\n",
              f"No step above {BOUND_MB} MB: the largest, {worst['model']}'s, "
              f"**{worst['peak_mb']:.0f} MB** — {verdict}.", ""]
    lines += discussion_section(SCRIPT, discussion)
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build-dir", default="build")
    parser.add_argument("--models", nargs="+", default=MODELS, choices=MODELS)
    parser.add_argument("--humanoid", default="/usr/share/mujoco/model/humanoid/humanoid.xml")
    parser.add_argument("--out", default="docs/benchmarks")
    parser.add_argument("--report-only", action="store_true")
    args = parser.parse_args()
    json_path = os.path.join(args.out, "compile_cost.json")
    md_path = os.path.join(args.out, "compile_cost.md")
    if args.report_only:
        with open(json_path, encoding="utf-8") as f:
            result = json.load(f)
    else:
        args.build_dir = os.path.abspath(args.build_dir)
        check_prerequisites(args.build_dir, args.humanoid)
        work = os.path.join(args.build_dir, "compile_cost")
        os.makedirs(work, exist_ok=True)
        os.makedirs(args.out, exist_ok=True)
        machine = machine_info()
        rows = measure(args, work, args.models)
        result = {"machine": machine, "rows": rows}
        with open(json_path, "w", encoding="utf-8") as f:
            json.dump(result, f, indent=1)
    report(result, md_path, kept_discussion(md_path, SCRIPT))
    progress(f"wrote {md_path}")


if __name__ == "__main__":
    main()
