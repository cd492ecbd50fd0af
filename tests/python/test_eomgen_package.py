"""The eomgen package without compiling anything: the cache key (content and options, not the
path of a URDF), the CMake text it writes, the error it extracts from a build log, the argument
checks. test_eomgen_build.py builds for real (opt-in: EOM_PYTHON_BUILD_TESTS)."""

from pathlib import Path

import pytest

import eomgen
from eomgen import _build

SOURCE = Path(__file__).resolve().parents[2]
PANDA = SOURCE / "models" / "robots" / "panda.urdf"


def spec(**kw):
    args = dict(urdf=None, header=None, cls=None, name=None, kernels=None, fixed=None, frames=None,
                floating_base=False, batch_lanes=None)
    args.update(kw)
    return _build._Spec(**args)


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
    with pytest.raises(ValueError, match="either urdf"):
        spec()
    with pytest.raises(ValueError, match="either urdf"):
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
