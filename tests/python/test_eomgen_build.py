"""eomgen.build() end to end (opt-in, -DEOM_PYTHON_BUILD_TESTS=ON; the first run compiles the
generator into $EOMGEN_CACHE_DIR): a URDF robot and a model header, the cache (a second call
imports at once), a generator error raised with its file and line."""

import time
from pathlib import Path

import numpy as np
import pytest

import eomgen
from eomgen import _build

SOURCE = Path(__file__).resolve().parents[2]


@pytest.fixture
def frozen_tree(monkeypatch):
    """The eomgen tree's fingerprint taken once: others editing the tree meanwhile would make the
    second call a new model."""
    fingerprint = _build._tree_fingerprint(SOURCE)
    monkeypatch.setattr(_build, "_tree_fingerprint", lambda src: fingerprint)


def test_urdf_build_and_cache(frozen_tree):
    pendulum = SOURCE / "tests" / "urdf" / "robots" / "pendulum.urdf"
    m = eomgen.build(urdf=pendulum, quiet=True)
    assert m.nq >= 1 and hasattr(m, "forward_dynamics")
    qdd = m.forward_dynamics(np.zeros(m.nq), np.zeros(m.nv))
    assert np.isfinite(qdd).all()
    start = time.perf_counter()
    again = eomgen.build(urdf=pendulum, quiet=True)
    assert again is m and time.perf_counter() - start < 0.2
    _build._loaded.clear()  # as a new process would: from the cache directory
    start = time.perf_counter()
    fresh = eomgen.build(urdf=pendulum, quiet=True)
    assert fresh.__file__ == m.__file__ and time.perf_counter() - start < 0.2


def test_header_build_with_options():
    m = eomgen.build(header=SOURCE / "models" / "spring_pendulum.hpp", cls="eom::models::SpringPendulum",
                     name="spring", fixed={"g": 9.81}, kernels=["defaults", "forward_dynamics_batch"],
                     batch_lanes=2, quiet=True)
    assert m.name.startswith("spring") and m.np == 3 and "g" not in m.parameter_names
    assert m.batch_lanes == 2
    q, qd = np.array([0.55, 0.3]), np.array([0.01, 2.5])
    assert np.allclose(m.mass_matrix(q), np.diag([1.0, 0.55 ** 2]))


def test_generator_error_is_raised_with_file_and_line(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text((SOURCE / "tests" / "consumer" / "bad" / "inertia.urdf").read_text())
    with pytest.raises(eomgen.BuildError) as info:
        eomgen.build(urdf=bad, quiet=True)
    e = info.value
    assert "eomgen-urdf:" in str(e) and "bad.urdf" in str(e)
    assert e.file is not None and e.file.endswith("bad.urdf") and e.line == 5
    with pytest.raises(eomgen.BuildError, match="no_such_kernel"):
        eomgen.build(urdf=SOURCE / "tests" / "urdf" / "robots" / "pendulum.urdf", kernels=["no_such_kernel"],
                     quiet=True)


def test_mjcf_build_and_errors(tmp_path):
    """mjcf= end to end: MuJoCo's compiler reads the file where it is; q, v and u named as in the
    file, the equality constraints counted; the dynamics consistent (τ(a) = M a + τ(0), forward dynamics gives
    a back); an element refused names the user's file and line."""
    runner = SOURCE / "models" / "mjcf" / "runner.xml"
    m = eomgen.build(mjcf=runner, quiet=True)
    assert list(m.coordinate_names) == ["rootx", "rootz", "rooty", "hip", "knee", "ankle"]
    assert list(m.input_names) == ["hip_servo", "knee_damper", "ankle_general", "push"]
    rng = np.random.default_rng(47)
    for _ in range(5):
        q, v, a = rng.uniform(-1, 1, m.nq), rng.uniform(-2, 2, m.nv), rng.uniform(-3, 3, m.nv)
        u = rng.uniform(-0.5, 0.5, m.nu)  # within every ctrlrange: no clamp between the calls
        tau = m.inverse_dynamics(q, v, a, u)
        assert np.allclose(tau, m.mass_matrix(q) @ a + m.inverse_dynamics(q, v, np.zeros(m.nv), u),
                           rtol=1e-12, atol=1e-12)
        free = m.inverse_dynamics(q, v, np.zeros(m.nv), u)
        assert np.allclose(m.forward_dynamics(q, v, u), np.linalg.solve(m.mass_matrix(q), -free),
                           rtol=1e-10, atol=1e-10)
    loops = eomgen.build(mjcf=SOURCE / "models" / "mjcf" / "loops.xml", quiet=True,
                         kernels=["constraint_residual", "forward_dynamics"])
    assert loops.nc == 17 and loops.nq == loops.nv + 1  # 2 welds, a connect, 2 joint equalities
    bad = tmp_path / "tendon.xml"
    bad.write_text((SOURCE / "tests" / "mjcf" / "bad" / "tendon.xml").read_text())
    with pytest.raises(eomgen.BuildError) as info:
        eomgen.build(mjcf=bad, quiet=True)
    assert "tendon 'coupler'" in str(info.value)
    assert info.value.file is not None and info.value.file.endswith("tendon.xml")
    assert info.value.line == 5
