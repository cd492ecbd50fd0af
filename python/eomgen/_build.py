"""eomgen.build(): the CMake project, the cache and the import (see the package docstring)."""

from __future__ import annotations

import fcntl
import hashlib
import importlib.machinery
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Iterable, Mapping

# Bump when what a cache entry holds, or how it is made, changes.
_FORMAT = 1

# The parts of the eomgen tree a module is made from: a change there makes a new key.
_TREE_PARTS = ("CMakeLists.txt", "cmake", "generator", "runtime/include", "python/eom_python.hpp")

_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

# Modules imported by this process, by key.
_loaded: dict[str, object] = {}


class BuildError(RuntimeError):
    """A model that could not be built: ``message`` is the generator's (or the compiler's, or
    CMake's) own, ``file`` and ``line`` where it names them, ``log`` the whole build output."""

    def __init__(self, message: str, file: str | None = None, line: int | None = None, log: str = ""):
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.log = log


def source_dir() -> Path:
    """The eomgen source tree the modules are built from: $EOMGEN_SOURCE_DIR, else the tree this
    package is in (python/eomgen/ inside it)."""
    path = Path(os.environ.get("EOMGEN_SOURCE_DIR") or Path(__file__).resolve().parents[2])
    if not (path / "cmake" / "EomGen.cmake").is_file():
        raise BuildError(f"eomgen: no eomgen source tree at {path} (set EOMGEN_SOURCE_DIR)")
    return path


def cache_dir() -> Path:
    """Where built modules are kept: $EOMGEN_CACHE_DIR, else $XDG_CACHE_HOME/eomgen, else
    ~/.cache/eomgen."""
    if os.environ.get("EOMGEN_CACHE_DIR"):
        return Path(os.environ["EOMGEN_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "eomgen"


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _tree_fingerprint(src: Path) -> str:
    """A hash of the eomgen sources a module is made from (their paths and content)."""
    h = hashlib.sha256()
    for part in _TREE_PARTS:
        path = src / part
        files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
        for f in files:
            h.update(str(f.relative_to(src)).encode())
            h.update(b"\0")
            h.update(f.read_bytes())
            h.update(b"\0")
    return h.hexdigest()


def _cmake_quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("$", "\\$").replace(";", "\\;") + '"'


def _default_name(urdf: Path | None, cls: str | None) -> str:
    """The URDF file's stem, or the class's own name with its template arguments (Chain<10>:
    Chain_10), made an identifier."""
    if urdf is not None:
        base = urdf.stem
    else:
        head, _, rest = (cls or "").partition("<")
        base = "_".join([head.split("::")[-1]] + re.findall(r"[A-Za-z0-9_]+", rest))
    name = re.sub(r"[^A-Za-z0-9_]", "_", base).strip("_") or "model"
    return "_" + name if name[0].isdigit() else name


def _fixed_entries(fixed) -> list[str]:
    if fixed is None:
        return []
    if isinstance(fixed, Mapping):
        return [f"{k}={float(v)!r}" for k, v in fixed.items()]
    if isinstance(fixed, str):
        return [fixed]
    return [str(e) for e in fixed]


def _names(values, what: str) -> list[str]:
    if values is None:
        return []
    if isinstance(values, str):
        values = [values]
    values = [str(v) for v in values]
    for v in values:
        if not v or any(c.isspace() or c in '";$' for c in v):
            raise ValueError(f"eomgen.build: {what}: {v!r} is not a name")
    return values


class _Spec:
    """What a module is made of, and its cache key."""

    def __init__(self, urdf, header, cls, name, kernels, fixed, frames, floating_base, batch_lanes):
        if (urdf is None) == (header is None):
            raise ValueError("eomgen.build: give either urdf=<file> or header=<file> with cls=<C++ type>")
        self.urdf = Path(urdf).resolve() if urdf is not None else None
        self.header = Path(header).resolve() if header is not None else None
        if self.header is not None and not cls:
            raise ValueError("eomgen.build: header= needs cls=<C++ type>, e.g. cls='my::Pendulum'")
        if self.urdf is not None and cls:
            raise ValueError("eomgen.build: cls= is for header=; a URDF model's class is written for it")
        if floating_base and self.urdf is None:
            raise ValueError("eomgen.build: floating_base is for URDF files; a model header states "
                             "`static constexpr bool floating_base = true` itself")
        source = self.urdf or self.header
        if not source.is_file():
            raise FileNotFoundError(f"eomgen.build: {source} not found")
        self.content = source.read_bytes()
        self.cls = cls
        self.name = name or _default_name(self.urdf, cls)
        if not _IDENTIFIER.match(self.name):
            raise ValueError(f"eomgen.build: name {self.name!r} is not a Python identifier")
        self.kernels = _names(kernels, "kernels")
        self.fixed = _fixed_entries(fixed)
        self.frames = _names(frames, "frames")
        self.floating_base = bool(floating_base)
        self.batch_lanes = batch_lanes

    def key(self, tree: str) -> str:
        spec = {
            "format": _FORMAT, "tree": tree, "name": self.name,
            "urdf": _sha(self.content) if self.urdf else None,
            # A header's includes are relative to it: its place matters, and its dependencies are
            # checked on every call (the manifest).
            "header": [str(self.header), _sha(self.content)] if self.header else None,
            "cls": self.cls, "kernels": self.kernels, "fixed": self.fixed, "frames": self.frames,
            "floating_base": self.floating_base, "batch_lanes": self.batch_lanes,
            "python": [sys.executable, sys.version, importlib.machinery.EXTENSION_SUFFIXES[0]],
        }
        return _sha(json.dumps(spec, sort_keys=True).encode())[:20]

    def cmake(self, key: str, model_dir: Path) -> str:
        """The model's CMakeLists.txt in the shared project."""
        lines = []
        if self.urdf is not None:
            copy = model_dir / (self.name + ".urdf")  # the build reads this copy, not the user's file
            copy.write_bytes(self.content)
            lines.append(["URDF", _cmake_quote(str(copy))] + (["FLOATING_BASE"] if self.floating_base else []))
        else:
            lines += [["HEADER", _cmake_quote(str(self.header))], ["CLASS", _cmake_quote(self.cls)]]
        for keyword, values in (("FRAMES", self.frames), ("KERNELS", self.kernels),
                                ("FIXED_PARAMETERS", self.fixed)):
            if values:
                lines.append([keyword] + [_cmake_quote(v) for v in values])
        if self.batch_lanes is not None:
            lines.append(["BATCH_LANES", str(int(self.batch_lanes))])
        lines.append(["PYTHON_MODULE", self.name])
        return (f"# eomgen.build(): model {self.name} (key {key})\n"
                f"add_eom_model({self.name}_{key[:8]}\n  " + "\n  ".join(" ".join(l) for l in lines) + ")\n")


_PROJECT = """# eomgen.build()'s models: one folder per model under models/, against this eomgen tree.
cmake_minimum_required(VERSION 3.25)
project(eomgen_python_models LANGUAGES CXX)
add_subdirectory({src} eomgen EXCLUDE_FROM_ALL)
file(GLOB model_dirs LIST_DIRECTORIES true "${{CMAKE_CURRENT_SOURCE_DIR}}/models/*")
foreach(dir IN LISTS model_dirs)
  if(EXISTS "${{dir}}/CMakeLists.txt")
    add_subdirectory("${{dir}}")
  endif()
endforeach()
"""


def _extract_error(log: str) -> tuple[str, str | None, int | None]:
    """The message that explains a failed build, with its file and line where it names them."""
    lines = log.splitlines()
    for ln in lines:  # eomgen-urdf: <file>:<line>: <problem>
        m = re.search(r"eomgen-urdf: (.*)$", ln)
        if m:
            text = m.group(1)
            fl = re.match(r"(.+?):(\d+): ", text)
            return "eomgen-urdf: " + text, (fl.group(1) if fl else None), (int(fl.group(2)) if fl else None)
    for ln in lines:  # the tracer: eomgen: model <name> (<class>): <problem>
        if re.match(r"^eomgen: ", ln) and ": note: " not in ln:
            fl = re.search(r"([^\s:()]+\.(?:hpp|h|hh|hxx|urdf|cpp)):(\d+)", ln)
            return ln.strip(), (fl.group(1) if fl else None), (int(fl.group(2)) if fl else None)
    for ln in lines:  # the compiler, e.g. a model header that does not compile
        m = re.match(r"^(.+?):(\d+):(?:\d+:)? (?:fatal )?error: (.*)$", ln)
        if m:
            return ln.strip(), m.group(1), int(m.group(2))
    for i, ln in enumerate(lines):  # CMake: the block after "CMake Error at <file>:<line>"
        m = re.match(r"^CMake Error(?: at (.+?):(\d+))?", ln)
        if m:
            block = [ln]
            for more in lines[i + 1:]:
                if not more.strip() and len(block) > 1:
                    break
                block.append(more)
            text = " ".join(b.strip() for b in block if b.strip())
            return text, m.group(1), (int(m.group(2)) if m.group(2) else None)
    tail = [ln for ln in lines if ln.strip()][-15:]
    return "eomgen: the build failed:\n" + "\n".join(tail), None, None


def _depfile_paths(build_model_dir: Path) -> list[Path]:
    """The files the model's tracer was compiled from (the compiler's dependency file)."""
    paths: set[Path] = set()
    for dep in build_model_dir.glob("CMakeFiles/eomgen_tracer_*.dir/**/*.o.d"):
        text = dep.read_text(errors="replace").replace("\\\n", " ")
        for entry in text.split(":", 1)[-1].split():
            paths.add(Path(entry))
    return sorted(paths)


def _manifest_ok(manifest: dict) -> bool:
    for path, digest in manifest.get("depends", {}).items():
        try:
            if _sha(Path(path).read_bytes()) != digest:
                return False
        except OSError:
            return False
    return True


def _import(name: str, path: Path):
    loader = importlib.machinery.ExtensionFileLoader(name, str(path))
    spec = importlib.util.spec_from_file_location(name, str(path), loader=loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def _warm(entry: Path, name: str):
    """The cached module of an entry, or None when there is none or it is stale."""
    try:
        manifest = json.loads((entry / "manifest.json").read_text())
    except (OSError, ValueError):
        return None
    if not _manifest_ok(manifest):
        return None
    path = entry / manifest["module"]
    return _import(name, path) if path.is_file() else None


class _Progress:
    """One line per stage of the build, rewritten in place on a terminal."""

    def __init__(self, name: str, quiet: bool):
        self.name, self.quiet = name, quiet
        self.tty = sys.stderr.isatty()
        self.last = ""

    def say(self, text: str, final: bool = False):
        if self.quiet:
            return
        line = f"eomgen: {self.name}: {text}"
        if self.tty:
            sys.stderr.write("\r\x1b[K" + line[:150] + ("\n" if final else ""))
        elif final or text != self.last:
            sys.stderr.write(line + "\n")
        sys.stderr.flush()
        self.last = text

    def build_line(self, ln: str):
        m = re.match(r"^\[\s*(\d+)%\]\s*(.*)$", ln)
        if not m:
            return
        percent, what = m.group(1), m.group(2)
        if what.startswith("Built target"):
            return
        what = re.sub(r"Building CXX object .*/([^/]+)\.o$", r"compiling \1", what)
        if self.tty:
            self.say(f"[{percent:>3}%] {what}")
        elif re.match(r"(Generating|Writing|Linking|compiling .*(_module|\b\w+)\.cpp)", what):
            self.say(what)


def _run(cmd: list[str], progress: _Progress | None) -> tuple[int, str]:
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            errors="replace", env={**os.environ, "LC_ALL": "C"})
    out = []
    for ln in proc.stdout:
        out.append(ln)
        if progress is not None:
            progress.build_line(ln.rstrip("\n"))
    return proc.wait(), "".join(out)


def build(urdf: str | os.PathLike | None = None, header: str | os.PathLike | None = None,
          cls: str | None = None, *, name: str | None = None, kernels: Iterable[str] | None = None,
          fixed: Mapping[str, float] | Iterable[str] | None = None, frames: Iterable[str] | None = None,
          floating_base: bool = False, batch_lanes: int | None = None, jobs: int | None = None,
          rebuild: bool = False, quiet: bool = False):
    """Builds (once) and imports the Python module of a model.

    urdf: a robot description file, or header and cls: a model header and its C++ type (e.g.
    ``header="pendulum.hpp", cls="SpringPendulum"``). name: the module's name (default: the URDF
    file's stem, or the class name). kernels, fixed, frames, floating_base, batch_lanes: as
    add_eom_model()'s KERNELS, FIXED_PARAMETERS ({"g": 9.81} or ["g=9.81"]), FRAMES,
    FLOATING_BASE, BATCH_LANES (docs/CONTRACT.md §3). jobs: parallel compile jobs (default: the
    CPU count). rebuild: build again even when cached. quiet: no progress lines.

    Returns the imported module. Raises BuildError with the generator's message when the model
    cannot be generated or compiled.
    """
    spec = _Spec(urdf, header, cls, name, kernels, fixed, frames, floating_base, batch_lanes)
    src = source_dir()
    key = spec.key(_tree_fingerprint(src))
    if not rebuild and key in _loaded:
        return _loaded[key]
    root = cache_dir() / ("py-" + _sha(f"{src}\0{sys.executable}".encode())[:12])
    entry = root / "modules" / key
    if not rebuild:
        module = _warm(entry, spec.name)
        if module is not None:
            _loaded[key] = module
            return module

    root.mkdir(parents=True, exist_ok=True)
    with open(root / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # one build at a time in this project
        if not rebuild:  # built by another process meanwhile?
            module = _warm(entry, spec.name)
            if module is not None:
                _loaded[key] = module
                return module
        module = _cold_build(spec, key, src, root, entry, jobs, quiet)
    _loaded[key] = module
    return module


def _cold_build(spec: _Spec, key: str, src: Path, root: Path, entry: Path, jobs, quiet: bool):
    project, build_dir = root / "project", root / "build"
    model_dir = project / "models" / key
    model_dir.mkdir(parents=True, exist_ok=True)
    (project / "CMakeLists.txt").write_text(_PROJECT.format(src=_cmake_quote(str(src))))
    (model_dir / "CMakeLists.txt").write_text(spec.cmake(key, model_dir))
    progress = _Progress(spec.name, quiet)
    start = time.perf_counter()
    progress.say("configuring (the first model in this cache also compiles the generator)")

    def failed(log: str):
        shutil.rmtree(model_dir, ignore_errors=True)  # keep the shared project configurable
        message, file, line = _extract_error(log)
        progress.say("failed", final=True)
        raise BuildError(message, file, line, log)

    cmake = shutil.which("cmake") or "cmake"
    rc, log = _run([cmake, "-S", str(project), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
                    f"-DPython3_EXECUTABLE={sys.executable}"], None)
    if rc != 0:
        failed(log)
    target = f"{spec.name}_{key[:8]}_python"
    progress.say("generating and compiling the kernels")
    rc, build_log = _run([cmake, "--build", str(build_dir), "--target", target, "-j",
                          str(jobs or os.cpu_count() or 2)], progress)
    if rc != 0:
        failed(log + build_log)

    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    build_model_dir = build_dir / "models" / key
    built = build_model_dir / (spec.name + suffix)
    if not built.is_file():
        failed(build_log + f"\neomgen: the module {built} was not made")
    depends = {}
    if spec.header is not None:
        for path in _depfile_paths(build_model_dir):
            path = path if path.is_absolute() else (build_model_dir / path)
            resolved = path.resolve()
            if resolved.is_file() and not str(resolved).startswith(("/usr/", str(src) + os.sep)):
                depends[str(resolved)] = _sha(resolved.read_bytes())
    entry.mkdir(parents=True, exist_ok=True)
    temporary = entry / (built.name + ".tmp")
    shutil.copy2(built, temporary)
    os.replace(temporary, entry / built.name)  # a module already loaded keeps its old file
    manifest = {"name": spec.name, "module": built.name, "depends": depends,
                "source": str(spec.urdf or spec.header), "built": time.time()}
    (entry / "manifest.json.tmp").write_text(json.dumps(manifest, indent=1))
    os.replace(entry / "manifest.json.tmp", entry / "manifest.json")  # written last: the entry is complete
    progress.say(f"built in {time.perf_counter() - start:.1f} s ({entry})", final=True)
    return _import(spec.name, entry / built.name)
