"""The installed eomgen package (cmake/Install.cmake): this build installed into a private prefix
(the eomgen_install fixture of tests/kernels), then eomgen.build() from there, in fresh
interpreters that see only the installed package. It uses the installed generator (find_package:
nothing of eomgen is compiled again), takes add_eom_model()'s options (inertia_policy,
floating_base), and its errors name the user's file and line, not the cache's copy: an
inconsistent inertia, a xacro file, a robot with nothing that moves. A failed build leaves no
module in the cache."""

import json
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

PREFIX = os.environ.get("EOMGEN_PREFIX")

# A two-link arm whose forearm's inertia violates the triangle inequality (line 9).
ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="upper"><inertial><origin xyz="0 0 0.2"/><mass value="1"/>
    <inertia ixx="0.02" iyy="0.02" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="2.5" effort="40" velocity="3"/></joint>
  <link name="fore"><inertial><origin xyz="0 0 0.2"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/><origin xyz="0 0 0.4"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="20" velocity="4"/></joint>
</robot>
"""

# A xacro file, named .urdf (its first xacro element on line 3).
XACRO = """<?xml version="1.0"?>
<robot name="gen3" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="dof" default="7"/>
  <xacro:include filename="$(find kortex_description)/arms/gen3/urdf/gen3_macro.xacro"/>
  <xacro:load_arm parent="" dof="$(arg dof)"/>
</robot>
"""

# A body with nothing that moves relative to it (a drone's frame and a camera).
DRONE = """<?xml version="1.0"?>
<robot name="drone">
  <link name="frame"><inertial><mass value="1.2"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.018" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="camera"/>
  <joint name="mount" type="fixed"><parent link="frame"/><child link="camera"/><origin xyz="0.1 0 0"/></joint>
</robot>
"""

# Runs in a fresh interpreter: builds, and prints what the test checks as one line of JSON.
SCRIPT = """
import json, sys, time
start = time.perf_counter()
import eomgen
result = {"package": eomgen.__file__, "config_dir": str(eomgen.config_dir())}
try:
    m = eomgen.build(**ARGS)
    result.update(ok=True, seconds=time.perf_counter() - start, file=m.__file__, nq=m.nq, nv=m.nv,
                  floating_base=m.floating_base, coordinate_names=list(m.coordinate_names),
                  position_lower=m.position_lower.tolist(), position_upper=m.position_upper.tolist(),
                  effort_limit=m.effort_limit.tolist(), velocity_limit=m.velocity_limit.tolist())
except eomgen.BuildError as e:
    result.update(ok=False, message=str(e), file=e.file, line=e.line, log=e.log)
print(json.dumps(result))
"""


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    if not PREFIX:
        pytest.skip("EOMGEN_PREFIX (this build installed) is not set; run through ctest")
    packages = sorted(Path(PREFIX).glob("lib*/python3*/*-packages/eomgen/_installed.py"))
    assert len(packages) == 1, f"cmake --install put no eomgen package (with _installed.py) under {PREFIX}"
    work = tmp_path_factory.mktemp("installed")
    return SimpleNamespace(pythonpath=packages[0].parents[1], cache=work / "cache", work=work)


def build(installed, **args):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "EOMGEN_SOURCE_DIR")}
    env.update(PYTHONPATH=str(installed.pythonpath), EOMGEN_CACHE_DIR=str(installed.cache))
    code = f"ARGS = {args!r}\n" + SCRIPT
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=installed.work, timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr
    result = json.loads(out.stdout.strip().splitlines()[-1])
    result["stderr"] = out.stderr
    return result


def write(installed, name, text):
    path = installed.work / "robots" / name
    path.parent.mkdir(exist_ok=True)
    path.write_text(text)
    return path


def modules_in_cache(installed):
    return sorted(p.name for p in installed.cache.glob("py-*/modules/*/*.so"))


def test_the_installed_package_uses_the_installed_generator(installed):
    arm = write(installed, "arm.urdf", ARM)
    # The policy is an option (it was a TypeError): the inconsistent inertia is taken, with a
    # warning naming the user's file and line.
    r = build(installed, urdf=str(arm), inertia_policy="warn")
    assert r["ok"], r.get("message")
    assert r["package"].startswith(str(installed.pythonpath))
    config = Path(r["config_dir"])
    assert config.is_relative_to(Path(PREFIX).resolve()) and (config / "eomgenConfig.cmake").is_file()
    assert f"eomgen-urdf: warning: {arm}:9: link 'fore'" in r["stderr"], r["stderr"]
    # Nothing of eomgen compiled in the cache's project: its generator is the installed one.
    assert not list(installed.cache.glob("py-*/build/eomgen")), "the generator was built again"
    # ... and MPI not looked for (COMPONENTS python): FindMPI's test compiles are a first build's seconds
    if (config / "eomgenMpiTargets.cmake").is_file():
        cache = next(installed.cache.glob("py-*/build/CMakeCache.txt")).read_text()
        assert "MPI_CXX_COMPILER" not in cache, "the package's project looked for MPI"
    # the names and limits of the file
    assert r["coordinate_names"] == ["shoulder", "elbow"]
    assert (r["position_lower"], r["position_upper"]) == ([-1.5, -2.0], [2.5, 2.0])
    assert (r["effort_limit"], r["velocity_limit"]) == ([40.0, 20.0], [3.0, 4.0])
    # warm: a new process imports the cached module, building nothing (no stage is reported;
    # not timed: a test on a loaded machine cannot tell seconds from work)
    again = build(installed, urdf=str(arm), inertia_policy="warn")
    assert again["ok"] and again["file"] == r["file"], again
    assert "eomgen: arm: configuring" in r["stderr"], r["stderr"]
    assert "configuring" not in again["stderr"], again["stderr"]


def test_errors_name_the_users_file_and_leave_nothing(installed):
    before = modules_in_cache(installed)
    arm = write(installed, "arm_strict.urdf", ARM)
    r = build(installed, urdf=str(arm))
    assert not r["ok"]
    assert r["message"].startswith(f"eomgen-urdf: {arm}:9: link 'fore': inertia tensor violates the "
                                   "triangle inequality"), r["message"]
    assert "INERTIA_POLICY warn" in r["message"] and (r["file"], r["line"]) == (str(arm), 9)
    assert str(installed.cache) not in r["message"]
    assert modules_in_cache(installed) == before  # nothing half-made
    assert not list(installed.cache.glob("py-*/project/models/*/arm_strict.urdf"))


def test_a_xacro_file_is_named_as_such(installed):
    gen3 = write(installed, "gen3.urdf", XACRO)
    r = build(installed, urdf=str(gen3))
    assert not r["ok"]
    assert r["message"].startswith(f"eomgen-urdf: {gen3}:3: this is a xacro file, not URDF"), r["message"]
    assert "xacro robot.urdf.xacro > robot.urdf" in r["message"] and (r["file"], r["line"]) == (str(gen3), 3)


def test_nothing_moves_suggests_floating_base(installed):
    drone = write(installed, "drone.urdf", DRONE)
    r = build(installed, urdf=str(drone))
    assert not r["ok"]
    assert r["message"].startswith(f"eomgen-urdf: {drone}:2: robot 'drone' has no moving joint"), r["message"]
    assert "eomgen.build(..., floating_base=True)" in r["message"]
    free = build(installed, urdf=str(drone), floating_base=True)
    assert free["ok"], free.get("message")
    assert (free["nq"], free["nv"], free["floating_base"]) == (7, 6, True)


def test_cmake_names_the_interpreter_and_what_it_lacks(installed):
    """add_eom_model(... PYTHON) with a Python3_EXECUTABLE that lacks numpy and pybind11 (a
    virtual environment without the system's packages): the configure error names it, both
    packages, and an interpreter here that has them."""
    venv = installed.work / "bare"
    made = subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], capture_output=True, text=True)
    if made.returncode != 0:
        pytest.skip("no venv module (Debian: apt-get install python3-venv): " + made.stderr.strip())
    project = installed.work / "cmake_project"
    project.mkdir()
    pendulum = Path(__file__).resolve().parents[1] / "urdf" / "robots" / "pendulum.urdf"
    config = next(Path(PREFIX).glob("lib*/cmake/eomgen"))
    (project / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.25)\nproject(p LANGUAGES CXX)\n"
        f'find_package(eomgen CONFIG REQUIRED PATHS "{config}" NO_DEFAULT_PATH)\n'
        f'add_eom_model(pend URDF "{pendulum}" PYTHON)\n')
    out = subprocess.run(["cmake", "-S", str(project), "-B", str(project / "build"),
                          f"-DPython3_EXECUTABLE={venv / 'bin' / 'python'}"], capture_output=True, text=True)
    text = " ".join(out.stderr.split())
    assert out.returncode != 0
    assert f"PYTHON: the interpreter {venv / 'bin' / 'python'} (Python3_EXECUTABLE) lacks numpy and pybind11" in text, text
    assert "-m pip install numpy pybind11" in text
    if subprocess.run(["/usr/bin/python3", "-c", "import numpy, pybind11"], capture_output=True).returncode == 0:
        assert "/usr/bin/python3 has them: -DPython3_EXECUTABLE=/usr/bin/python3" in text
