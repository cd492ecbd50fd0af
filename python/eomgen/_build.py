"""eomgen.build(): the CMake project, the cache and the import (see the package docstring)."""

from __future__ import annotations

import fcntl
import hashlib
import importlib.machinery
import importlib.util
import json
import math
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import time
from pathlib import Path
from typing import Iterable, Mapping

# Bump when what a cache entry holds, or how it is made, changes.
_FORMAT = 3

# The parts of the eomgen tree a module is made from: a change there makes a new key.
_TREE_PARTS = ("CMakeLists.txt", "cmake", "generator", "runtime/include", "python/eom_python.hpp",
               "python/eom_python_contact.hpp")

_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

# Modules imported by this process, by key.
_loaded: dict[str, object] = {}


class BuildError(RuntimeError):
    """A model that could not be built: ``message`` is the generator's (or the compiler's, or
    CMake's) own, ``file`` and ``line`` where it names them (the user's file, never the cache's
    copy), ``log`` the whole build output. An interpreter that cannot build a module: ``python``
    (sys.executable), ``missing`` (e.g. ["numpy", "pybind11"]), ``candidates`` (interpreters
    here that can)."""

    def __init__(self, message: str, file: str | None = None, line: int | None = None, log: str = ""):
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.log = log
        self.python: str | None = None
        self.missing: list[str] = []
        self.candidates: list[str] = []


def _installed_config():
    """The installed eomgen this package belongs to (`cmake --install` or `pip install` wrote
    eomgen/_installed.py beside it): (the folder of eomgenConfig.cmake, the files whose change
    makes new modules), or None for the package inside a source tree."""
    try:
        from . import _installed  # written by the install, absent from the source tree
    except ImportError:
        return None
    here = Path(__file__).resolve().parent
    return (here / _installed.CMAKE_DIR).resolve(), [(here / part).resolve() for part in _installed.PARTS]


def source_dir() -> Path:
    """The eomgen source tree the modules are built from: $EOMGEN_SOURCE_DIR, else the tree this
    package is in (python/eomgen/ inside it). An installed package has none: see config_dir()."""
    path = Path(os.environ.get("EOMGEN_SOURCE_DIR") or Path(__file__).resolve().parents[2])
    if not (path / "cmake" / "EomGen.cmake").is_file():
        raise BuildError(f"eomgen: no eomgen source tree at {path} (set EOMGEN_SOURCE_DIR, or install "
                         "eomgen: cmake --install, or pip install <eomgen checkout>)")
    return path


def config_dir() -> Path | None:
    """The installed eomgen's package config folder (<prefix>/lib/cmake/eomgen) that build() uses,
    its generator already compiled; None when build() uses a source tree ($EOMGEN_SOURCE_DIR
    set, or this package run from a checkout)."""
    if os.environ.get("EOMGEN_SOURCE_DIR"):
        return None
    installed = _installed_config()
    return installed[0] if installed else None


class _Origin:
    """Where the modules' eomgen comes from: an installed package config (find_package, the
    generator built) or a source tree (add_subdirectory: the first build compiles the generator)."""

    def __init__(self):
        installed = None if os.environ.get("EOMGEN_SOURCE_DIR") else _installed_config()
        if installed is not None:
            self.cmake_dir, self.parts = installed
            if not (self.cmake_dir / "eomgenConfig.cmake").is_file():
                raise BuildError(f"eomgen: the installed eomgen's package config is missing from "
                                 f"{self.cmake_dir} (reinstall eomgen, or set EOMGEN_SOURCE_DIR to a "
                                 "source tree)")
            self.path, self.installed = self.cmake_dir, True
        else:
            self.path, self.installed = source_dir(), False

    def fingerprint(self) -> str:
        if not self.installed:
            return _tree_fingerprint(self.path)
        # Installed files keep the time stamps of what was built (cmake --install), so their
        # sizes and times tell a new install from the same one, without reading them.
        h = hashlib.sha256()
        for part in self.parts:
            files = [part] if part.is_file() else sorted(p for p in part.rglob("*") if p.is_file())
            for f in files:
                st = f.stat()
                h.update(f"{f}\0{st.st_size}\0{st.st_mtime_ns}\0".encode())
        return h.hexdigest()

    def project_line(self) -> str:
        if self.installed:
            # COMPONENTS python: the binding header, and no search for MPI (seconds of a first build)
            return (f"find_package(eomgen CONFIG REQUIRED COMPONENTS python PATHS "
                    f"{_cmake_quote(str(self.cmake_dir))} NO_DEFAULT_PATH)  # the installed eomgen: "
                    "its generator is built")
        return (f"add_subdirectory({_cmake_quote(str(self.path))} eomgen EXCLUDE_FROM_ALL)  "
                "# a source tree: the first model compiles the generator")


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


def _default_name(file: Path | None, cls: str | None) -> str:
    """The URDF or MJCF file's stem, or the class's own name with its template arguments
    (Chain<10>: Chain_10), made an identifier."""
    if file is not None:
        base = file.stem
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


def _contact_entries(contacts) -> list[str]:
    """CONTACTS entries "<set>=<frame>[:6d],...", from a mapping {set: [frames]} or the entries."""
    if contacts is None:
        return []
    if isinstance(contacts, Mapping):
        entries = []
        for name, frames in contacts.items():
            frames = _names(frames, f"contacts[{name!r}]")
            if not frames:
                raise ValueError(f"eomgen.build: contacts: the set {name!r} is empty; name its frames")
            entries.append(f"{name}=" + ",".join(frames))
        return _names(entries, "contacts")
    return _names(contacts, "contacts")


_INERTIA_POLICIES = ("error", "warn", "nearest")

# add_eom_model()'s keywords and build()'s options, one for one (python/README.md's table;
# tests/python/test_eomgen_package.py checks it against cmake/EomGen.cmake). PYTHON is what
# build() does; CUDA compiles the C++ library with nvcc, which a module (its own CPU build of
# the kernels) does not use: GPU ensembles are C++ (eom::cuda::ensemble).
OPTIONS = {
    "HEADER": "header", "CLASS": "cls", "URDF": "urdf", "MJCF": "mjcf",
    "FLOATING_BASE": "floating_base", "INERTIA_POLICY": "inertia_policy", "GROUND": "ground",
    "COLLISION_PAIRS": "collision_pairs", "FRAMES": "frames",
    "WRENCH_INPUTS": "wrench_inputs", "CONTACTS": "contacts", "KERNELS": "kernels", "FIXED_PARAMETERS": "fixed",
    "FREE_PARAMETERS": "free", "BATCH_LANES": "batch_lanes", "NAMESPACE": "namespace",
    "PYTHON_MODULE": "name", "PYTHON": None, "CUDA": None,
}


class _Spec:
    """What a module is made of (add_eom_model()'s options, one for one), and its cache key."""

    def __init__(self, urdf=None, header=None, cls=None, name=None, kernels=None, fixed=None,
                 frames=None, floating_base=False, batch_lanes=None, inertia_policy=None, free=None,
                 namespace=None, mjcf=None, wrench_inputs=None, contacts=None, ground=None,
                 collision_pairs=None):
        if sum(x is not None for x in (urdf, header, mjcf)) != 1:
            raise ValueError("eomgen.build: give one of urdf=<file>, mjcf=<file>, or header=<file> "
                             "with cls=<C++ type>")
        self.urdf = Path(urdf).resolve() if urdf is not None else None
        self.header = Path(header).resolve() if header is not None else None
        self.mjcf = Path(mjcf).resolve() if mjcf is not None else None
        if self.mjcf is not None and (cls or floating_base or inertia_policy is not None):
            raise ValueError("eomgen.build: cls, floating_base and inertia_policy are not for mjcf=; an "
                             "MJCF model states its free joint, and MuJoCo's compiler its inertias")
        if self.header is not None and not cls:
            raise ValueError("eomgen.build: header= needs cls=<C++ type>, e.g. cls='my::Pendulum'")
        if self.urdf is not None and cls:
            raise ValueError("eomgen.build: cls= is for header=; a URDF model's class is written for it")
        if floating_base and self.urdf is None:
            raise ValueError("eomgen.build: floating_base is for URDF files; a model header states "
                             "`static constexpr bool floating_base = true` itself")
        if inertia_policy is not None:
            if self.urdf is None:
                raise ValueError("eomgen.build: inertia_policy is for URDF files; a model header's "
                                 "bodies must be physically consistent")
            if inertia_policy not in _INERTIA_POLICIES:
                raise ValueError(f"eomgen.build: inertia_policy={inertia_policy!r}: expected one of "
                                 + ", ".join(repr(v) for v in _INERTIA_POLICIES))
        if (ground is not None or collision_pairs) and self.urdf is None:
            raise ValueError("eomgen.build: ground and collision_pairs are for URDF files; an MJCF "
                             "model states its geoms, pairs and options itself")
        if ground is not None:
            if isinstance(ground, bool) or not isinstance(ground, (int, float)) or not math.isfinite(ground):
                raise ValueError(f"eomgen.build: ground={ground!r}: expected a height in metres "
                                 "(0 for the plane z = 0)")
            ground = float(ground)
        if batch_lanes is not None and batch_lanes not in (2, 4, 8):
            raise ValueError(f"eomgen.build: batch_lanes={batch_lanes!r}: expected 2, 4 or 8")
        if namespace is not None and not re.match(r"^[A-Za-z_]\w*(::[A-Za-z_]\w*)*$", str(namespace)):
            raise ValueError(f"eomgen.build: namespace={namespace!r} is not a C++ namespace name")
        source = self.urdf or self.header or self.mjcf
        if not source.is_file():
            raise FileNotFoundError(f"eomgen.build: {source} not found")
        self.content = source.read_bytes()
        self.cls = cls
        self.name = name or _default_name(self.urdf or self.mjcf, cls)
        if not _IDENTIFIER.match(self.name):
            raise ValueError(f"eomgen.build: name {self.name!r} is not a Python identifier")
        self.kernels = _names(kernels, "kernels")
        self.fixed = _fixed_entries(fixed)
        self.free = _names(free, "free")
        self.frames = _names(frames, "frames")
        self.wrench_inputs = _names(wrench_inputs, "wrench_inputs")
        self.contacts = _contact_entries(contacts)
        self.ground = ground
        self.collision_pairs = _names(collision_pairs, "collision_pairs")
        for pair in self.collision_pairs:
            if not re.match(r"^[^:]+:[^:]+$", pair):
                raise ValueError(f"eomgen.build: collision_pairs: {pair!r}: expected '<linkA>:<linkB>'")
        self.floating_base = bool(floating_base)
        self.batch_lanes = batch_lanes
        self.inertia_policy = inertia_policy
        self.namespace = namespace

    def key(self, tree: str) -> str:
        spec = {
            "format": _FORMAT, "tree": tree, "name": self.name,
            "urdf": _sha(self.content) if self.urdf else None,
            # A header's includes are relative to it: its place matters, and its dependencies are
            # checked on every call (the manifest).
            "header": [str(self.header), _sha(self.content)] if self.header else None,
            # An MJCF file is read in place (it may include others beside it).
            "mjcf": [str(self.mjcf), _sha(self.content)] if self.mjcf else None,
            "wrench_inputs": self.wrench_inputs, "contacts": self.contacts,
            "ground": self.ground, "collision_pairs": self.collision_pairs,
            "cls": self.cls, "kernels": self.kernels, "fixed": self.fixed, "frames": self.frames,
            "floating_base": self.floating_base, "batch_lanes": self.batch_lanes,
            "inertia_policy": self.inertia_policy, "free": self.free, "namespace": self.namespace,
            "python": [sys.executable, sys.version, importlib.machinery.EXTENSION_SUFFIXES[0]],
        }
        return _sha(json.dumps(spec, sort_keys=True).encode())[:20]

    def copy_path(self, model_dir: Path) -> Path:
        """The copy of the URDF file that the build reads (what the key was made from)."""
        return model_dir / (self.name + ".urdf")

    def cmake(self, key: str, model_dir: Path) -> str:
        """The model's CMakeLists.txt in the shared project."""
        lines = []
        if self.urdf is not None:
            copy = self.copy_path(model_dir)  # the build reads this copy, not the user's file
            copy.write_bytes(self.content)
            lines.append(["URDF", _cmake_quote(str(copy))] + (["FLOATING_BASE"] if self.floating_base else []))
            if self.inertia_policy is not None:
                lines.append(["INERTIA_POLICY", self.inertia_policy])
            if self.ground is not None:
                lines.append(["GROUND", repr(self.ground)])
            if self.collision_pairs:
                lines.append(["COLLISION_PAIRS"] + [_cmake_quote(v) for v in self.collision_pairs])
        elif self.mjcf is not None:
            lines.append(["MJCF", _cmake_quote(str(self.mjcf))])
        else:
            lines += [["HEADER", _cmake_quote(str(self.header))], ["CLASS", _cmake_quote(self.cls)]]
        for keyword, values in (("FRAMES", self.frames), ("WRENCH_INPUTS", self.wrench_inputs),
                                ("CONTACTS", self.contacts),
                                ("KERNELS", self.kernels),
                                ("FIXED_PARAMETERS", self.fixed), ("FREE_PARAMETERS", self.free)):
            if values:
                lines.append([keyword] + [_cmake_quote(v) for v in values])
        if self.batch_lanes is not None:
            lines.append(["BATCH_LANES", str(int(self.batch_lanes))])
        if self.namespace is not None:
            lines.append(["NAMESPACE", str(self.namespace)])
        lines.append(["PYTHON_MODULE", self.name])
        target = f"{self.name}_{key[:8]}"
        return (f"# eomgen.build(): model {self.name} (key {key})\n"
                f"add_eom_model({target}\n  " + "\n  ".join(" ".join(l) for l in lines) + ")\n"
                # The tracer runs once: compiled unoptimized it is ready sooner (what it writes
                # does not depend on it); the kernels and the module stay optimized.
                f"get_target_property(tracer {target} EOMGEN_TRACER)\n"
                "target_compile_options(${tracer} PRIVATE $<$<CXX_COMPILER_ID:GNU,Clang>:-O0>)\n"
                # Models of one class share a tracer, built in the first one's folder: where its
                # objects are, for _depfile_paths.
                "get_target_property(tracer_dir ${tracer} BINARY_DIR)\n"
                'file(WRITE "${CMAKE_CURRENT_BINARY_DIR}/tracer_objects" '
                '"${tracer_dir}/CMakeFiles/${tracer}.dir")\n')


_PROJECT = """# eomgen.build()'s models: one folder per model under models/.
cmake_minimum_required(VERSION 3.25)
project(eomgen_python_models LANGUAGES CXX)
{eomgen}
file(GLOB model_dirs LIST_DIRECTORIES true "${{CMAKE_CURRENT_SOURCE_DIR}}/models/*")
foreach(dir IN LISTS model_dirs)
  if(EXISTS "${{dir}}/CMakeLists.txt")
    add_subdirectory("${{dir}}")
  endif()
endforeach()
"""


def _python_lacks(python: str | None = None) -> list[str]:
    """What an interpreter (default: this one) lacks to build and import a module: numpy,
    pybind11, Python.h (its development headers)."""
    if python is None:
        lacks = [m for m in ("numpy", "pybind11") if importlib.util.find_spec(m) is None]
        include = sysconfig.get_paths().get("include") or ""
        return lacks + ([] if Path(include, "Python.h").is_file() else ["Python.h"])
    code = ("import importlib.util, json, os, sysconfig\n"
            "lacks = [m for m in ('numpy', 'pybind11') if importlib.util.find_spec(m) is None]\n"
            "inc = sysconfig.get_paths().get('include') or ''\n"
            "print(json.dumps(lacks + ([] if os.path.isfile(os.path.join(inc, 'Python.h')) else ['Python.h'])))")
    try:
        out = subprocess.run([python, "-c", code], capture_output=True, text=True, timeout=30)
        return json.loads(out.stdout) if out.returncode == 0 else ["a working interpreter"]
    except (OSError, ValueError, subprocess.SubprocessError):
        return ["a working interpreter"]


def _other_pythons() -> list[str]:
    """Other python3 interpreters on this machine: those on PATH, /usr/bin/python3 (Debian's)."""
    # (A virtual environment's python is a link to the system's, with other packages: the same
    # file is another interpreter under another name, so only this very path is left out.)
    found, seen = [], set()
    dirs = os.environ.get("PATH", "").split(os.pathsep) + ["/usr/bin", "/usr/local/bin"]
    for d in dirs:
        path = os.path.join(d, "python3") if d else ""
        if (path and path != sys.executable and os.path.isfile(path) and os.access(path, os.X_OK)
                and os.path.dirname(os.path.realpath(path)) + os.path.realpath(path) not in seen):
            seen.add(os.path.dirname(os.path.realpath(path)) + os.path.realpath(path))
            found.append(path)
    return found


def _check_python() -> None:
    """Raises BuildError when this interpreter cannot build a module, naming it, what it lacks,
    and the interpreters here that can."""
    lacks = _python_lacks()
    if not lacks:
        return
    me = f"{sys.executable} (Python {sys.version.split()[0]})"
    what = " and ".join([", ".join(lacks[:-1]), lacks[-1]] if len(lacks) > 1 else lacks)
    packages = [m for m in lacks if m != "Python.h"]
    good = [p for p in _other_pythons() if not _python_lacks(p)]
    message = (f"eomgen.build: this interpreter, {me}, lacks {what}: a module is built for, and "
               f"imported by, the interpreter that runs eomgen.build(). ")
    if good:
        message += f"{good[0]} has them: run your script with it ({good[0]} script.py). Or give "
    else:
        message += "Give "
    message += "this interpreter "
    fixes = []
    if packages:
        fixes.append(f"{' and '.join(packages)} ({sys.executable} -m pip install {' '.join(packages)})")
    if "Python.h" in lacks:
        fixes.append("its development headers (for Debian's python3: apt-get install python3-dev)")
    message += " and ".join(fixes) + ("; Debian's /usr/bin/python3: apt-get install python3-dev "
                                      "python3-numpy python3-pybind11" if not good else "")
    error = BuildError(message)
    error.python, error.missing, error.candidates = sys.executable, lacks, good
    raise error


def _extract_error(log: str) -> tuple[str, str | None, int | None]:
    """The message that explains a failed build, with its file and line where it names them."""
    lines = log.splitlines()
    for ln in lines:  # eomgen-urdf or -mjcf: <file>:<line>: <problem> (not their warnings)
        m = re.search(r"(eomgen-(?:urdf|mjcf)): (?!warning: )(.*)$", ln)
        if m:
            text = m.group(2)
            fl = re.match(r"(.+?):(\d+): ", text) or re.match(r"(.+?\.xml): ()", text)
            line = int(fl.group(2)) if fl and fl.group(2) else None
            return f"{m.group(1)}: {text}", (fl.group(1) if fl else None), line
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
    where = build_model_dir / "tracer_objects"  # written by the model's CMakeLists (_Spec.cmake)
    objects = ([Path(where.read_text().strip())] if where.is_file()
               else build_model_dir.glob("CMakeFiles/eomgen_tracer_*.dir"))
    for dep in (d for o in objects for d in o.glob("**/*.o.d")):
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
    """One line per stage of the build, rewritten in place on a terminal. `rename` puts the
    user's file for the cache's copy in every line."""

    def __init__(self, name: str, quiet: bool, rename=lambda text: text):
        self.name, self.quiet, self.rename = name, quiet, rename
        self.tty = sys.stderr.isatty()
        self.last = ""

    def say(self, text: str, final: bool = False):
        if self.quiet:
            return
        line = f"eomgen: {self.name}: {self.rename(text)}"
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
          cls: str | None = None, *, mjcf: str | os.PathLike | None = None, name: str | None = None,
          kernels: Iterable[str] | None = None,
          fixed: Mapping[str, float] | Iterable[str] | str | None = None,
          free: Iterable[str] | None = None, frames: Iterable[str] | None = None,
          wrench_inputs: Iterable[str] | None = None,
          contacts: Mapping[str, Iterable[str]] | Iterable[str] | None = None, floating_base: bool = False,
          inertia_policy: str | None = None, ground: float | None = None,
          collision_pairs: Iterable[str] | None = None, batch_lanes: int | None = None,
          namespace: str | None = None, jobs: int | None = None, rebuild: bool = False,
          quiet: bool = False):
    """Builds (once) and imports the Python module of a model.

    urdf: a robot description file, mjcf: a MuJoCo model, or header and cls: a model header and
    its C++ type (e.g. ``header="pendulum.hpp", cls="SpringPendulum"``). The other options are
    add_eom_model()'s (docs/CONTRACT.md §3), one for one (OPTIONS): name (PYTHON_MODULE;
    default the file's stem or the class name), kernels (KERNELS), fixed (FIXED_PARAMETERS:
    {"g": 9.81}, ["g=9.81"] or "ALL"), free (FREE_PARAMETERS), frames (FRAMES), wrench_inputs
    (WRENCH_INPUTS: ["foot", "hand:force"]), contacts (CONTACTS: {"stance": ["FL_FOOT",
    "HR_FOOT"], "flat": ["l_foot:6d"]} or ["stance=FL_FOOT,HR_FOOT"]), floating_base (FLOATING_BASE), inertia_policy
    (INERTIA_POLICY: "error", "warn" or "nearest"), ground (GROUND: a height, 0 for z = 0),
    collision_pairs (COLLISION_PAIRS: ["gripper:box"]; with ground, the module steps the URDF
    robot with contact: rollout, contact_step), batch_lanes (BATCH_LANES), namespace
    (NAMESPACE). jobs: parallel compile jobs (default: the CPU count). rebuild: build again even
    when cached. quiet: no progress lines (and no warnings of the generator).

    Returns the imported module. Raises BuildError with the generator's message (naming your
    file and line) when the model cannot be generated or compiled, or naming the interpreter
    and what it lacks when it cannot build modules.
    """
    spec = _Spec(urdf, header, cls, name, kernels, fixed, frames, floating_base, batch_lanes,
                 inertia_policy, free, namespace, mjcf, wrench_inputs, contacts, ground,
                 collision_pairs)
    origin = _Origin()
    key = spec.key(origin.fingerprint())
    if not rebuild and key in _loaded:
        return _loaded[key]
    root = cache_dir() / ("py-" + _sha(f"{origin.path}\0{sys.executable}".encode())[:12])
    entry = root / "modules" / key
    if not rebuild:
        module = _warm(entry, spec.name)
        if module is not None:
            _loaded[key] = module
            return module

    _check_python()
    root.mkdir(parents=True, exist_ok=True)
    with open(root / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # one build at a time in this project
        if not rebuild:  # built by another process meanwhile?
            module = _warm(entry, spec.name)
            if module is not None:
                _loaded[key] = module
                return module
        module = _cold_build(spec, key, origin, root, entry, jobs, quiet)
    _loaded[key] = module
    return module


def _cold_build(spec: _Spec, key: str, origin: _Origin, root: Path, entry: Path, jobs, quiet: bool):
    project, build_dir = root / "project", root / "build"
    model_dir = project / "models" / key
    build_model_dir = build_dir / "models" / key
    shutil.rmtree(entry, ignore_errors=True)  # a stale or partial entry: made again below
    model_dir.mkdir(parents=True, exist_ok=True)
    (project / "CMakeLists.txt").write_text(_PROJECT.format(eomgen=origin.project_line()))
    (model_dir / "CMakeLists.txt").write_text(spec.cmake(key, model_dir))
    def users_file(text: str) -> str:
        """The build reads a copy of the URDF file: messages name the user's file instead."""
        return text.replace(str(spec.copy_path(model_dir)), str(spec.urdf)) if spec.urdf else text

    progress = _Progress(spec.name, quiet, users_file)
    start = time.perf_counter()
    progress.say("configuring" + ("" if origin.installed else
                                  " (the first model in this cache also compiles the generator)"))

    def failed(log: str):
        # Nothing half-made stays: the model's folders (the shared project stays configurable)
        # and any entry; a later call builds it again.
        for path in (model_dir, build_model_dir, entry):
            shutil.rmtree(path, ignore_errors=True)
        log = users_file(log)
        message, file, line = _extract_error(log)
        if file is not None and (not Path(file).is_absolute() or file.startswith(str(root) + os.sep)):
            # CMake refusing an option in the cache's own project: the user's model is at fault
            file, line = str(spec.urdf or spec.header or spec.mjcf), None
        message = message.replace(f"{spec.name}_{key[:8]}", spec.name)  # the cache's target name
        progress.say("failed", final=True)
        raise BuildError(message, file, line, log)

    cmake = shutil.which("cmake") or "cmake"
    import pybind11  # this interpreter has it (checked above): CMake need not start it to ask
    rc, log = _run([cmake, "-S", str(project), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
                    f"-DPython3_EXECUTABLE={sys.executable}",
                    f"-DEOMGEN_PYBIND11_INCLUDE_DIR={pybind11.get_include()}"], None)
    if rc != 0:
        failed(log)
    target = f"{spec.name}_{key[:8]}_python"
    progress.say("generating and compiling the kernels")
    rc, build_log = _run([cmake, "--build", str(build_dir), "--target", target, "-j",
                          str(jobs or os.cpu_count() or 2)], progress)
    if rc != 0:
        failed(log + build_log)
    if not quiet:  # the generator's warnings (an inertia taken as written, ...), naming the user's file
        for ln in users_file(build_log).splitlines():
            m = re.search(r"eomgen-(?:urdf|mjcf): warning: .*$", ln)
            if m:
                sys.stderr.write(("\r\x1b[K" if progress.tty else "") + m.group(0) + "\n")

    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    built = build_model_dir / (spec.name + suffix)
    if not built.is_file():
        failed(build_log + f"\neomgen: the module {built} was not made")
    depends = {}
    if spec.header is not None:
        own = [str(origin.path) + os.sep] + ([] if not origin.installed else
                                             [str(p) + os.sep for p in origin.parts])
        for path in _depfile_paths(build_model_dir):
            path = path if path.is_absolute() else (build_model_dir / path)
            resolved = path.resolve()
            if resolved.is_file() and not str(resolved).startswith(("/usr/", *own)):
                depends[str(resolved)] = _sha(resolved.read_bytes())
    entry.mkdir(parents=True, exist_ok=True)
    temporary = entry / (built.name + ".tmp")
    shutil.copy2(built, temporary)
    os.replace(temporary, entry / built.name)  # a module already loaded keeps its old file
    manifest = {"name": spec.name, "module": built.name, "depends": depends,
                "source": str(spec.urdf or spec.header or spec.mjcf), "built": time.time()}
    (entry / "manifest.json.tmp").write_text(json.dumps(manifest, indent=1))
    os.replace(entry / "manifest.json.tmp", entry / "manifest.json")  # written last: the entry is complete
    progress.say(f"built in {time.perf_counter() - start:.1f} s ({entry})", final=True)
    return _import(spec.name, entry / built.name)
