"""pip install <eomgen checkout>: the eomgen Python package with an eomgen installation inside it
(eomgen/_prefix: the generator library, eomgen-urdf, the runtime headers, the package config and
the binding header), so that eomgen.build() uses it through find_package and compiles no
generator. Offline, with Debian 12's setuptools (no download, no build isolation needed):

    python3 -m venv --system-site-packages venv     # numpy and pybind11 from Debian
    venv/bin/pip install <eomgen checkout>

The C++ part is built with CMake in <checkout>/build-pip/ (kept: installing again compiles only
what changed) and installed with `cmake --install --component Unspecified` (everything but the
Python package, which setuptools copies). Needs cmake, g++, libfmt-dev, libtinyxml2-dev
(scripts/setup.sh). Without pip: `cmake --install` also installs the package (python/README.md).
"""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
WORK = ROOT / "build-pip"  # setuptools' and CMake's build folders (/build*/ is ignored by git)
VERSION = re.search(r"project\(eomgen VERSION ([0-9.]+)", (ROOT / "CMakeLists.txt").read_text()).group(1)


def _run(command):
    print("eomgen setup:", " ".join(str(c) for c in command), flush=True)
    subprocess.run([str(c) for c in command], check=True)


class BuildWithEomgen(build_py):
    """build_py, then the C++ generator installed into the package as eomgen/_prefix."""

    def run(self):
        super().run()
        cmake = shutil.which("cmake")
        if cmake is None:
            sys.exit("eomgen setup: cmake not found (Debian: apt-get install cmake g++ libfmt-dev "
                     "libtinyxml2-dev; or scripts/setup.sh)")
        build = WORK / "cmake"
        _run([cmake, "-S", ROOT, "-B", build, "-DCMAKE_BUILD_TYPE=Release", "-DEOM_BUILD_TESTS=OFF",
              "-DEOM_BUILD_BENCH=OFF", "-DEOM_BUILD_DEMO=OFF", "-DEOM_CUDA=OFF",
              "-DEOM_INSTALL_PYTHONDIR=python", f"-DPython3_EXECUTABLE={sys.executable}"])
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 2)
        _run([cmake, "--build", build, "-j", jobs])
        package = Path(self.build_lib) / "eomgen"
        prefix = package / "_prefix"
        shutil.rmtree(prefix, ignore_errors=True)
        _run([cmake, "--install", build, "--prefix", prefix, "--component", "Unspecified"])
        # CMake's _installed.py names the installation from <prefix>/python/eomgen; here the
        # package holds it as _prefix.
        names = {}
        exec((build / "python" / "_installed.py").read_text(), names)

        def inside(path):
            assert path.startswith("../../"), path
            return "_prefix/" + path[len("../../"):]

        parts = "".join(f"    {inside(p)!r},\n" for p in names["PARTS"])
        (package / "_installed.py").write_text(
            "# Written by eomgen's setup.py: the eomgen installed inside this package (_prefix),\n"
            "# which eomgen.build() uses.\n"
            f"CMAKE_DIR = {inside(names['CMAKE_DIR'])!r}\nPARTS = [\n{parts}]\n")


class BinaryDistribution(Distribution):
    """The package holds compiled files (eomgen/_prefix): a platform wheel, not a pure one."""

    def has_ext_modules(self):
        return True


WORK.mkdir(exist_ok=True)
setup(
    name="eomgen",
    version=VERSION,
    description="Equations of motion from energies or URDF files, generated as C++ kernels, "
                "as Python modules",
    packages=["eomgen"],
    package_dir={"": "python"},
    python_requires=">=3.9",
    cmdclass={"build_py": BuildWithEomgen},
    distclass=BinaryDistribution,
    options={"build": {"build_base": str(WORK / "setuptools")},
             "egg_info": {"egg_base": str(WORK)}},
    zip_safe=False,
)
