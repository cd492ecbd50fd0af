"""Every kernel of every test model from Python against the same kernel called from C++
(python_reference.cpp) at the same state: the same bits. Sizes, names, parameters; the spring
pendulum against its closed form."""

import math

import numpy as np
import pytest

from conftest import MODELS, call, inputs, kernel_layout, load


@pytest.mark.parametrize("model", MODELS)
def test_every_kernel_matches_cpp(reference, model):
    ref = reference["models"][model]
    m = load(model)
    x = inputs(ref)
    assert ref["kernels"], model
    for entry, expected in ref["kernels"].items():
        outputs, ok, layout = call(m, entry, x, expected)
        got = kernel_layout(outputs, layout)
        assert len(got) == len(expected["outputs"]), entry
        for k, (g, e) in enumerate(zip(got, expected["outputs"])):
            assert g.shape == (len(e),), (entry, k)
            # Bit for bit: the module compiles the same generated source.
            assert np.array_equal(g, np.array(e, dtype=float), equal_nan=True), (entry, k, g, e)
        if "result" in expected:
            assert ok is expected["result"], entry


@pytest.mark.parametrize("model", MODELS)
def test_exactly_the_kernels_of_the_type(reference, model):
    ref = reference["models"][model]
    m = load(model)
    generated = {entry.partition("/")[0] for entry in ref["kernels"]}
    listed = set(m.kernels) - {"forward_dynamics_batch"}  # used by forward_dynamics, no function
    assert listed == generated
    for kernel in ("mass_matrix", "forward_dynamics", "frame_jacobian", "center_of_mass",
                   "constraint_jacobian", "inverse_dynamics_derivatives",
                   "forward_dynamics_parameter_derivatives", "taylor_coefficients"):
        assert hasattr(m, kernel) == (kernel in generated), kernel
    assert hasattr(m, "integrate") == ("forward_dynamics" in generated)
    assert hasattr(m, "ensemble") == ("forward_dynamics" in generated)


@pytest.mark.parametrize("model", MODELS)
def test_sizes_and_names(reference, model):
    ref = reference["models"][model]
    m = load(model)
    x = inputs(ref)
    assert (m.nq, m.nv, m.nu, m.np) == (len(x.q), len(x.qd), len(x.u), len(x.p))
    assert m.state_size == m.nq + m.nv
    assert m.floating_base == (m.nv != m.nq)
    assert len(m.parameter_names) == m.np and all(isinstance(n, str) for n in m.parameter_names)
    assert m.parameter_values.dtype == np.float64 and np.array_equal(m.parameter_values, x.p)
    with pytest.raises(ValueError):
        m.parameter_values[0] = 1.0  # read-only
    assert len(m.frame_names) == m.nframes
    assert m.name


@pytest.mark.parametrize("model", MODELS)
def test_names_and_limits_as_in_the_header(reference, model):
    """coordinate_names, velocity_names, input_names (tuples of str) and position_lower/upper,
    effort_limit, velocity_limit (read-only float64 arrays) on every module, as in the C++ header."""
    header = reference["models"][model]["header"]
    m = load(model)
    for key in ("coordinate_names", "velocity_names", "input_names"):
        assert getattr(m, key) == tuple(header[key]), key
    for key in ("position_lower", "position_upper", "effort_limit", "velocity_limit"):
        got = getattr(m, key)
        assert got.dtype == np.float64 and np.array_equal(got, np.array(header[key], dtype=float)), key
        with pytest.raises(ValueError):
            got[0] = 0.0  # read-only
    assert (len(m.coordinate_names), len(m.velocity_names), len(m.input_names)) == (m.nq, m.nv, m.nu)
    assert (len(m.position_lower), len(m.effort_limit)) == (m.nq, m.nv)


def test_panda_limits_are_the_urdf_files():
    import xml.etree.ElementTree as ET
    from pathlib import Path
    panda = load("panda")
    root = ET.parse(Path(__file__).resolve().parents[2] / "models" / "robots" / "panda.urdf").getroot()
    moving = [j for j in root.iter("joint") if j.get("type") in ("revolute", "prismatic", "continuous")]
    assert panda.coordinate_names == tuple(j.get("name") for j in moving)
    limits = [j.find("limit") for j in moving]
    assert np.array_equal(panda.position_lower, [float(l.get("lower")) for l in limits])
    assert np.array_equal(panda.position_upper, [float(l.get("upper")) for l in limits])
    assert np.array_equal(panda.effort_limit, [float(l.get("effort")) for l in limits])
    assert np.array_equal(panda.velocity_limit, [float(l.get("velocity")) for l in limits])
    assert panda.input_names == tuple("u_" + j.get("name") for j in moving)


def test_model_facts():
    chain, panda, arm, pend = load("chain10"), load("panda"), load("frame_arm"), load("cartesian_pendulum")
    assert (chain.nq, chain.batch_lanes, chain.nc) == (10, 4, 0)
    assert (panda.nq, panda.nu, panda.batch_lanes) == (7, 7, 0)
    assert panda.parameter_names[0] == "g"
    assert arm.frame_names == ("tool", "elbow_marker") and arm.nframes == 2
    assert arm.frame_index("elbow_marker") == 1 and arm.frame_index(0) == 0
    assert pend.nc > 0
    free = load("spacecraft_free")
    assert free.floating_base and free.nv == free.nq - 1


def test_parameters_helper():
    m = load("chain10")
    p = m.parameters(g=0.0, m3=2.5)
    assert p[m.parameter_names.index("g")] == 0.0 and p[m.parameter_names.index("m3")] == 2.5
    assert np.array_equal(np.delete(p, [2, 40]), np.delete(m.parameter_values, [2, 40]))
    p[0] = 7.0  # a new, writable array
    assert m.parameter_values[0] != 7.0
    with pytest.raises(ValueError, match="unknown parameter 'nope'"):
        m.parameters(nope=1.0)


def test_frame_by_name_and_index(reference):
    m = load("frame_arm")
    x = inputs(reference["models"]["frame_arm"])
    assert np.array_equal(m.frame_jacobian("tool", x.q), m.frame_jacobian(0, x.q))
    pos, rot = m.frame_placement("elbow_marker", x.q)
    assert pos.shape == (3,) and rot.shape == (3, 3)
    assert np.allclose(rot @ rot.T, np.eye(3), atol=1e-14)


def test_spring_pendulum_closed_form():
    """py_pendulum is models/spring_pendulum.hpp: T = m/2 (r'^2 + r^2 th'^2),
    V = k/2 (r - r0)^2 + m g (r0 - r cos th)."""
    m = load("py_pendulum")
    mass, k, r0, g = m.parameter_values
    q, qd = np.array([0.55, 0.3]), np.array([0.01, 2.5])
    r, th = q
    rd, thd = qd
    assert np.allclose(m.mass_matrix(q), np.diag([mass, mass * r * r]), rtol=1e-15)
    assert math.isclose(m.potential_energy(q), 0.5 * k * (r - r0) ** 2 + mass * g * (r0 - r * math.cos(th)),
                        rel_tol=1e-14)
    assert math.isclose(m.kinetic_energy(q, qd), 0.5 * mass * (rd * rd + r * r * thd * thd), rel_tol=1e-15)
    rdd = r * thd * thd - k / mass * (r - r0) + g * math.cos(th)
    thdd = (-2 * rd * thd - g * math.sin(th)) / r
    assert np.allclose(m.forward_dynamics(q, qd), [rdd, thdd], rtol=1e-13, atol=1e-13)
    # dqdd/dp against central differences
    d = m.forward_dynamics_parameter_derivatives(q, qd)
    assert d.shape == (m.nv, m.np)
    for j in range(m.np):
        h = 1e-6 * max(1.0, abs(m.parameter_values[j]))
        p1, p0 = m.parameter_values.copy(), m.parameter_values.copy()
        p1[j] += h
        p0[j] -= h
        fd = (m.forward_dynamics(q, qd, p=p1) - m.forward_dynamics(q, qd, p=p0)) / (2 * h)
        assert np.allclose(d[:, j], fd, rtol=1e-6, atol=1e-7), j
    # inverse dynamics inverts forward dynamics; its derivative in qdd direction is M
    qdd = m.forward_dynamics(q, qd)
    assert np.allclose(m.inverse_dynamics(q, qd, qdd), 0.0, atol=1e-12)
    dq, dqd = m.inverse_dynamics_derivatives(q, qd, qdd)
    assert dq.shape == dqd.shape == (2, 2)


def test_matrices_are_row_major_views_of_the_kernel():
    """M is symmetric; C (nc x nq) is not square: its (i, j) entry is dphi_i/dq_j."""
    m = load("cartesian_pendulum")
    q = np.array([0.6, -0.8])
    C = m.constraint_jacobian(q)
    assert C.shape == (m.nc, m.nq) and C.flags.c_contiguous
    h = 1e-7
    for j in range(m.nq):
        dq = np.zeros(m.nq)
        dq[j] = h
        fd = (m.constraint_residual(q + dq) - m.constraint_residual(q - dq)) / (2 * h)
        assert np.allclose(C[:, j], fd, atol=1e-7)
    M = load("panda").mass_matrix(np.linspace(0.1, 0.7, 7))
    assert np.array_equal(M, M.T)
    d_q, d_qd, d_u = load("panda").forward_dynamics_derivatives(np.zeros(7), np.zeros(7))
    assert d_u.shape == (7, 7) and np.allclose(d_u, np.linalg.inv(load("panda").mass_matrix(np.zeros(7))))
