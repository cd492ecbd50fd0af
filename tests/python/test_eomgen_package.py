"""The eomgen package without compiling anything: the cache key (content and options, not the
path of a URDF), the CMake text it writes, the error it extracts from a build log, the argument
checks. test_eomgen_build.py builds for real (opt-in: EOM_PYTHON_BUILD_TESTS)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

import eomgen
from eomgen import _build

SOURCE = Path(__file__).resolve().parents[2]
PANDA = SOURCE / "models" / "robots" / "panda.urdf"


def spec(**kw):
    return _build._Spec(**kw)


def test_key_follows_content_and_options(tmp_path):
    tree = _build._tree_fingerprint(SOURCE)
    assert tree == _build._tree_fingerprint(SOURCE)
    base = spec(urdf=PANDA).key(tree)
    copy = tmp_path / "panda.urdf"
    copy.write_bytes(PANDA.read_bytes())
    assert spec(urdf=copy).key(tree) == base  # the same content elsewhere: the same module
    assert spec(urdf=PANDA, frames=["panda_link8"]).key(tree) != base
    assert spec(urdf=PANDA, fixed={"g": 9.81}).key(tree) != base
    assert spec(urdf=PANDA, kernels=["mass_matrix"]).key(tree) != base
    assert spec(urdf=PANDA, floating_base=True).key(tree) != base
    assert spec(urdf=PANDA, name="robot").key(tree) != base
    assert spec(urdf=PANDA).key("another tree") != base
    copy.write_bytes(PANDA.read_bytes().replace(b"4.970684", b"4.970685"))
    assert spec(urdf=copy).key(tree) != base


def test_names_and_cmake_text(tmp_path):
    s = spec(urdf=PANDA, frames=["panda_link8"], fixed={"g": 9.81}, kernels=["defaults", "center_of_mass"])
    assert s.name == "panda"
    text = s.cmake("0123456789abcdef0123", tmp_path)
    assert "add_eom_model(panda_01234567" in text and "URDF" in text
    assert '\n  FRAMES "panda_link8"\n' in text and '\n  KERNELS "defaults" "center_of_mass"\n' in text and '"g=9.81"' in text and "\n  PYTHON_MODULE panda)" in text
    assert (tmp_path / "panda.urdf").read_bytes() == PANDA.read_bytes()
    h = spec(header=SOURCE / "models" / "chain.hpp", cls="eom::models::Chain<10>")
    assert h.name == "Chain_10"
    assert '"eom::models::Chain<10>"' in h.cmake("k" * 20, tmp_path)
    assert _build._cmake_quote('a"b$c;d\\') == '"a\\"b\\$c\\;d\\\\"'


def test_argument_checks(tmp_path):
    with pytest.raises(ValueError, match="give one of urdf"):
        spec()
    with pytest.raises(ValueError, match="give one of urdf"):
        spec(urdf=PANDA, header=PANDA)
    with pytest.raises(ValueError, match="needs cls"):
        spec(header=SOURCE / "models" / "chain.hpp")
    with pytest.raises(ValueError, match="floating_base is for URDF"):
        spec(header=SOURCE / "models" / "chain.hpp", cls="X", floating_base=True)
    with pytest.raises(FileNotFoundError):
        spec(urdf=tmp_path / "none.urdf")
    with pytest.raises(ValueError, match="not a Python identifier"):
        spec(urdf=PANDA, name="my-robot")
    with pytest.raises(ValueError, match="frames"):
        spec(urdf=PANDA, frames=["a b"])


def test_error_extraction():
    log = ("[ 50%] Writing the model of robot.urdf (robot_model.hpp)\n"
           "eomgen-urdf: /tmp/robot.urdf:12: link 'arm': the inertia is not physical (principal moments -0.4, 0.1, 0.6)\n"
           "make[2]: *** [models/x] Error 1\n")
    message, file, line = _build._extract_error(log)
    assert message.startswith("eomgen-urdf: /tmp/robot.urdf:12: link 'arm'")
    assert (file, line) == ("/tmp/robot.urdf", 12)
    log = ("eomgen-mjcf: warning: /tmp/m.xml: joint 'knee': frictionloss is a constraint of MuJoCo's solver\n"
           "eomgen-mjcf: /tmp/m.xml:5: tendon 'coupler': tendons are not supported yet (issue 47)\n")
    message, file, line = _build._extract_error(log)
    assert message.startswith("eomgen-mjcf: /tmp/m.xml:5: tendon 'coupler'")
    assert (file, line) == ("/tmp/m.xml", 5)
    log = "eomgen-mjcf: /tmp/m.xml: MuJoCo cannot load it: Error: unrecognized attribute\n"
    assert _build._extract_error(log)[1:] == ("/tmp/m.xml", None)
    log = ("eomgen: model m_1 (Good): note: mass_matrix has 12 operations\n"
           "eomgen: model m_1 (Good): unknown kernel 'no_such_kernel'\n")
    assert _build._extract_error(log)[0] == "eomgen: model m_1 (Good): unknown kernel 'no_such_kernel'"
    log = "/work/m/pendulum.hpp:14:5: error: 'foo' was not declared in this scope\n"
    message, file, line = _build._extract_error(log)
    assert (file, line) == ("/work/m/pendulum.hpp", 14) and "not declared" in message
    log = ("CMake Error at models/k/CMakeLists.txt:2 (add_eom_model):\n"
           "  add_eom_model(x): FIXED_PARAMETERS entry \"g=\" is malformed\n\n-- Configuring incomplete\n")
    message, file, line = _build._extract_error(log)
    assert "FIXED_PARAMETERS entry" in message and (file, line) == ("models/k/CMakeLists.txt", 2)


def test_public_api():
    assert eomgen.source_dir() == SOURCE
    assert issubclass(eomgen.BuildError, RuntimeError)
    e = eomgen.BuildError("eomgen-urdf: a.urdf:3: bad", "a.urdf", 3, "log")
    assert (str(e), e.file, e.line, e.log) == ("eomgen-urdf: a.urdf:3: bad", "a.urdf", 3, "log")


def test_every_add_eom_model_option_has_its_python_option(tmp_path):
    """The options of build() are add_eom_model()'s, one for one (python/README.md's table)."""
    s = spec(urdf=PANDA, inertia_policy="warn", free=["g"], fixed="ALL", namespace="robots::panda",
             floating_base=True, batch_lanes=8, kernels=["defaults"], frames=["panda_link8"], name="arm")
    text = s.cmake("0123456789abcdef0123", tmp_path)
    for line in ("URDF", "FLOATING_BASE", "\n  INERTIA_POLICY warn\n", '\n  FIXED_PARAMETERS "ALL"\n',
                 '\n  FREE_PARAMETERS "g"\n', "\n  NAMESPACE robots::panda\n", "\n  BATCH_LANES 8\n",
                 '\n  KERNELS "defaults"\n', '\n  FRAMES "panda_link8"\n', "\n  PYTHON_MODULE arm)"):
        assert line in text, (line, text)
    tree = "tree"
    base = spec(urdf=PANDA).key(tree)
    for change in (dict(inertia_policy="warn"), dict(inertia_policy="nearest"), dict(free=["g"]),
                   dict(namespace="ns")):
        assert spec(urdf=PANDA, **change).key(tree) != base, change
    with pytest.raises(ValueError, match=r"inertia_policy='loose': expected one of 'error', 'warn', 'nearest'"):
        spec(urdf=PANDA, inertia_policy="loose")
    with pytest.raises(ValueError, match="inertia_policy is for URDF files"):
        spec(header=SOURCE / "models" / "chain.hpp", cls="X", inertia_policy="warn")
    with pytest.raises(ValueError, match=r"batch_lanes=3: expected 2, 4 or 8"):
        spec(urdf=PANDA, batch_lanes=3)
    with pytest.raises(ValueError, match=r"namespace='a-b' is not a C\+\+ namespace"):
        spec(urdf=PANDA, namespace="a-b")
    # Every keyword of add_eom_model() (read from cmake/EomGen.cmake) is an option of build(),
    # documented in python/README.md's table (before: inertia_policy was a TypeError)
    import inspect
    import re
    cmake = (SOURCE / "cmake" / "EomGen.cmake").read_text()
    call = re.search(r'cmake_parse_arguments\(PARSE_ARGV 1 arg ((?:"[^"]*"\s*){3})\)', cmake)
    keywords = re.findall(r"[A-Z_]+", call.group(1))
    assert {"URDF", "HEADER", "INERTIA_POLICY", "FLOATING_BASE"} <= set(keywords)
    parameters = inspect.signature(eomgen.build).parameters
    readme = (SOURCE / "python" / "README.md").read_text()
    for keyword in keywords:
        assert keyword in _build.OPTIONS, f"add_eom_model's {keyword} has no build() option"
        assert f"| `{keyword}" in readme, f"python/README.md's table has no row for {keyword}"
        option = _build.OPTIONS[keyword]
        if option is not None:
            assert option in parameters, option
            assert f"`{option}=" in readme, option
    # GROUND and COLLISION_PAIRS: URDF only, a height, <linkA>:<linkB>
    text = spec(urdf=PANDA, ground=0, collision_pairs=["panda_hand:panda_link0"]).cmake("k" * 20, tmp_path)
    assert '\n  GROUND 0.0\n' in text and '\n  COLLISION_PAIRS "panda_hand:panda_link0"\n' in text, text
    with pytest.raises(ValueError, match=r"ground and collision_pairs are for URDF files"):
        spec(mjcf=PANDA, ground=0.0)
    with pytest.raises(ValueError, match=r"ground='low': expected a height in metres"):
        spec(urdf=PANDA, ground="low")
    with pytest.raises(ValueError, match=r"collision_pairs: 'hand': expected '<linkA>:<linkB>'"):
        spec(urdf=PANDA, collision_pairs=["hand"])
    s = spec(mjcf=PANDA, wrench_inputs=["panda_link8", "panda_hand:force"])  # the file is read in place
    text = s.cmake("k" * 20, tmp_path)
    assert f'\n  MJCF "{PANDA}"\n' in text and '\n  WRENCH_INPUTS "panda_link8" "panda_hand:force"\n' in text
    with pytest.raises(ValueError, match="give one of urdf=<file>, mjcf=<file>"):
        spec(urdf=PANDA, mjcf=PANDA)
    s = spec(urdf=PANDA, contacts={"hand": ["panda_hand:6d"], "two": ["panda_link7", "panda_link8"]})
    assert '\n  CONTACTS "hand=panda_hand:6d" "two=panda_link7,panda_link8"\n' in s.cmake("k" * 20, tmp_path)
    assert spec(urdf=PANDA, contacts=["two=panda_link7,panda_link8"]).contacts == ["two=panda_link7,panda_link8"]
    with pytest.raises(ValueError, match="the set 'hand' is empty"):
        spec(urdf=PANDA, contacts={"hand": []})


def test_a_failed_build_names_the_users_file_and_leaves_nothing(tmp_path, monkeypatch):
    """The build reads a copy of the URDF in the cache: the error, e.file and e.log name the
    user's file instead, and the model's folders and entry are removed."""
    user = tmp_path / "robots" / "arm.urdf"
    user.parent.mkdir()
    user.write_bytes(PANDA.read_bytes())
    monkeypatch.setenv("EOMGEN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(_build, "_check_python", lambda: None)

    def fake_run(cmd, progress):  # what eomgen-urdf prints about the copy it was given
        copies = list((tmp_path / "cache").glob("py-*/project/models/*/arm.urdf"))
        assert len(copies) == 1
        if "--build" not in cmd:
            return 0, "-- Configuring done\n"
        return 2, (f"[ 50%] Writing the model of {copies[0]} (arm_model.hpp)\n"
                   f"eomgen-urdf: {copies[0]}:52: link 'panda_link3': inertia tensor is not positive definite\n")

    monkeypatch.setattr(_build, "_run", fake_run)
    with pytest.raises(eomgen.BuildError) as info:
        eomgen.build(urdf=user, quiet=True)
    e = info.value
    assert (e.file, e.line) == (str(user), 52)
    assert str(e) == f"eomgen-urdf: {user}:52: link 'panda_link3': inertia tensor is not positive definite"
    assert "cache" not in str(e) and "/cache/" not in e.log
    root = next((tmp_path / "cache").glob("py-*"))
    assert not list(root.glob("project/models/*")) and not list(root.glob("modules/*"))


def test_an_interpreter_without_numpy_or_pybind11_is_named(tmp_path):
    """A python3 without numpy and pybind11 (here a virtual environment without the system's
    packages) gets a message naming it, what it lacks, and an interpreter here that has them."""
    venv = tmp_path / "bare"
    made = subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], capture_output=True, text=True)
    if made.returncode != 0:
        pytest.skip("no venv module (Debian: apt-get install python3-venv): " + made.stderr.strip())
    python = venv / "bin" / "python"
    code = ("import eomgen\n"
            "try:\n"
            f"    eomgen.build(urdf={str(PANDA)!r}, quiet=True)\n"
            "except eomgen.BuildError as e:\n"
            "    print(e); print(e.python); print(','.join(e.missing)); print(','.join(e.candidates))\n")
    env = {**os.environ, "PYTHONPATH": str(SOURCE / "python"), "EOMGEN_CACHE_DIR": str(tmp_path / "cache")}
    out = subprocess.run([str(python), "-c", code], capture_output=True, text=True, env=env, timeout=120)
    lines = out.stdout.splitlines()
    assert len(lines) == 4, out.stdout + out.stderr
    message, named, missing, candidates = lines
    assert named == str(python) and message.startswith(f"eomgen.build: this interpreter, {python} (Python ")
    assert missing.split(",")[:2] == ["numpy", "pybind11"] and "lacks numpy and pybind11" in message
    assert f"{python} -m pip install numpy pybind11" in message
    if candidates:  # the one it recommends does have them
        first = candidates.split(",")[0]
        assert f"{first} has them: run your script with it" in message
        check = subprocess.run([first, "-c", "import numpy, pybind11"], capture_output=True)
        assert check.returncode == 0
    assert not (tmp_path / "cache").exists()  # nothing was started


def test_an_option_cmake_refuses_names_the_users_file(tmp_path, monkeypatch):
    """CMake refusing an option of the cache's project (its CMakeLists.txt, its target name):
    the error names the user's model and the model's own name instead."""
    user = tmp_path / "arm.urdf"
    user.write_bytes(PANDA.read_bytes())
    monkeypatch.setenv("EOMGEN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(_build, "_check_python", lambda: None)

    def fake_run(cmd, progress):
        target = next((tmp_path / "cache").glob("py-*/project/models/*/CMakeLists.txt")).read_text()
        name = target.split("add_eom_model(")[1].split()[0]
        key = target.split("/models/")[1].split("/")[0]
        return 1, (f"CMake Error at models/{key}/CMakeLists.txt:2 (add_eom_model):\n"
                   f"  add_eom_model({name}): FIXED_PARAMETERS entry \"g=\" is malformed\n\n")

    monkeypatch.setattr(_build, "_run", fake_run)
    with pytest.raises(eomgen.BuildError) as info:
        eomgen.build(urdf=user, fixed=["g="], quiet=True)
    e = info.value
    assert (e.file, e.line) == (str(user), None)
    assert "add_eom_model(arm): FIXED_PARAMETERS entry \"g=\" is malformed" in str(e), str(e)
