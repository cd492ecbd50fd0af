"""Bad input: a wrong shape or dtype is a ValueError naming the kernel, the argument, the expected
and the given shape; arrays in another layout are copied, never misread; NaN gives the kernel's
status (NaN outputs, False), never a crash."""

import re

import numpy as np
import pytest

from conftest import load


@pytest.fixture(scope="module")
def chain():
    return load("chain10")


def state(seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1, 1, 10), rng.uniform(-1, 1, 10)


def test_wrong_shape_names_argument_and_shapes(chain):
    q, qd = state()
    with pytest.raises(ValueError, match=re.escape("forward_dynamics: q: expected shape (10,) or (n, 10), given (3,)")):
        chain.forward_dynamics(q[:3], qd)
    with pytest.raises(ValueError, match=re.escape("mass_matrix: q: expected shape (10,) or (n, 10), given (2, 3, 10)")):
        chain.mass_matrix(np.zeros((2, 3, 10)))
    with pytest.raises(ValueError, match=re.escape("coriolis: qd: expected shape (10,) or (n, 10), given (4, 9)")):
        chain.coriolis(q, np.zeros((4, 9)))
    with pytest.raises(ValueError, match=re.escape("mass_matrix: p: expected shape (41,) or (n, 41), given (40,)")):
        chain.mass_matrix(q, np.zeros(40))
    with pytest.raises(ValueError, match=re.escape("mass_matrix: q: expected shape (10,) or (n, 10), given ()")):
        chain.mass_matrix(1.0)
    with pytest.raises(ValueError, match=r"forward_dynamics: qd: has 4 rows, but q has 3"):
        chain.forward_dynamics(np.zeros((3, 10)), np.zeros((4, 10)))
    with pytest.raises(ValueError, match=r"forward_dynamics: t: has 5 rows, but q has 3"):
        chain.forward_dynamics(np.zeros((3, 10)), qd, t=np.zeros(5))
    with pytest.raises(ValueError, match=r"forward_dynamics: q: required"):
        chain.forward_dynamics(None, qd)
    panda = load("panda")
    with pytest.raises(ValueError, match=re.escape("inverse_dynamics: u: expected shape (7,) or (n, 7), given (6,)")):
        panda.inverse_dynamics(np.zeros(7), np.zeros(7), np.zeros(7), np.zeros(6))
    free = load("spacecraft_free")  # qd holds nv = nq - 1 values
    with pytest.raises(ValueError, match=re.escape(f"coriolis: qd: expected shape ({free.nv},)")):
        free.coriolis(np.r_[0, 0, 0, 1, 0, 0, 0, np.zeros(free.nq - 7)], np.zeros(free.nq))


def test_wrong_dtype(chain):
    q, qd = state()
    with pytest.raises(ValueError, match=r"forward_dynamics: q: expected float64 values, given complex128"):
        chain.forward_dynamics(q.astype(complex), qd)
    with pytest.raises(ValueError, match=r"mass_matrix: q: expected float64 values, given <U"):
        chain.mass_matrix(np.array(["a"] * 10))
    with pytest.raises(ValueError, match=r"mass_matrix: q: expected float64 values, given object"):
        chain.mass_matrix(np.array([object()] * 10))
    with pytest.raises(ValueError, match=r"mass_matrix: q: expected float64 values, given object"):
        chain.mass_matrix({})
    with pytest.raises(ValueError, match=r"mass_matrix: q: expected a float64 array, given list"):
        chain.mass_matrix([[1.0, 2.0], [3.0]])  # ragged
    with pytest.raises(ValueError, match=r"expected float64 values"):
        chain.mass_matrix("abcdefghij")


def test_safe_casts_and_sequences_are_accepted(chain):
    q = np.arange(10)
    expected = chain.mass_matrix(q.astype(float))
    assert np.array_equal(chain.mass_matrix(q), expected)  # int64
    assert np.array_equal(chain.mass_matrix(list(range(10))), expected)  # a list
    assert np.array_equal(chain.mass_matrix(tuple(float(v) for v in q)), expected)
    q32 = np.linspace(0, 1, 10, dtype=np.float32)
    assert np.array_equal(chain.mass_matrix(q32), chain.mass_matrix(q32.astype(float)))
    assert chain.forward_dynamics(q, q, t=np.float64(0.5)).shape == (10,)
    assert chain.forward_dynamics(q, q, t=np.int32(1)).shape == (10,)


def test_other_layouts_are_copied_not_misread(chain):
    rng = np.random.default_rng(5)
    Q = rng.uniform(-1, 1, (6, 10))
    QD = rng.uniform(-1, 1, (6, 10))
    expected = chain.forward_dynamics(Q, QD)
    # Fortran order, a transposed view, every other row, reversed rows
    assert np.array_equal(chain.forward_dynamics(np.asfortranarray(Q), QD), expected)
    assert np.array_equal(chain.forward_dynamics(np.ascontiguousarray(Q.T).T, QD), expected)
    wide = np.zeros((12, 10))
    wide[::2] = Q
    assert np.array_equal(chain.forward_dynamics(wide[::2], QD), expected)
    assert np.array_equal(chain.forward_dynamics(Q[::-1], QD[::-1]), expected[::-1])
    # a column of a matrix (stride 2): one state
    both = np.stack([Q[0], QD[0]], axis=1)
    assert np.array_equal(chain.forward_dynamics(both[:, 0], both[:, 1]), expected[0])
    # big-endian, and misaligned
    assert np.array_equal(chain.forward_dynamics(Q.astype(">f8"), QD), expected)
    buffer = np.zeros(Q.size * 8 + 1, dtype=np.uint8)
    misaligned = np.ndarray(Q.shape, dtype=np.float64, buffer=buffer, offset=1)
    misaligned[...] = Q
    assert not misaligned.flags.aligned
    assert np.array_equal(chain.forward_dynamics(misaligned, QD), expected)
    # the inputs are not written to
    before = Q.copy()
    chain.forward_dynamics(Q, QD)
    assert np.array_equal(Q, before)


def test_nan_gives_the_kernel_status(chain):
    q, qd = state()
    bad = q.copy()
    bad[4] = np.nan
    qdd, ok = chain.forward_dynamics(bad, qd, status=True)
    assert ok is False and np.isnan(qdd).all()
    assert np.isnan(chain.forward_dynamics(bad, qd)).all()
    *derivatives, ok = chain.forward_dynamics_derivatives(q, qd * np.inf, status=True)
    assert ok is False and all(np.isnan(d).all() for d in derivatives)
    qk, qdk, ok = chain.taylor_coefficients(4, bad, qd, status=True)
    assert ok is False and np.isnan(qk).all()
    assert np.isnan(chain.kinetic_energy(bad, qd))
    assert np.isnan(chain.mass_matrix(bad)).any()
    params = chain.parameter_values.copy()
    params[0] = np.nan
    assert chain.forward_dynamics(q, qd, p=params, status=True)[1] is False
    # a singular mass matrix: every mass and inertia zero
    zero = chain.parameters(**{n: 0.0 for n in chain.parameter_names if n[0] in "mI"})
    qdd, ok = chain.forward_dynamics(q, qd, p=zero, status=True)
    assert ok is False and np.isnan(qdd).all()


def test_frame_arguments():
    arm = load("frame_arm")
    q = np.zeros(3)
    with pytest.raises(ValueError, match=r"frame_jacobian: frame: unknown frame 'hand'; the frames are: tool, elbow_marker"):
        arm.frame_jacobian("hand", q)
    with pytest.raises(IndexError, match=re.escape("frame_placement: frame: index 2 out of range [0, 2)")):
        arm.frame_placement(2, q)
    with pytest.raises(IndexError):
        arm.frame_acceleration_bias(-1, q, q)
    with pytest.raises(ValueError, match=r"frame: expected a frame index or name"):
        arm.frame_jacobian(0.5, q)


def test_other_arguments(chain):
    q, qd = state()
    with pytest.raises(ValueError, match=r"taylor_coefficients: order: expected 1 \.\.\. \d+, given 0"):
        chain.taylor_coefficients(0, q, qd)
    with pytest.raises(ValueError, match=r"method: unknown method 'rk5'; the methods are"):
        chain.integrate(0, 1, np.r_[q, qd], method="rk5")
    with pytest.raises(ValueError, match=re.escape("integrate: x0: expected shape (20,), given (10,)")):
        chain.integrate(0, 1, q)
    with pytest.raises(ValueError, match=re.escape("integrate: x0: expected shape (20,), given (2, 20)")):
        chain.integrate(0, 1, np.zeros((2, 20)))
    with pytest.raises(ValueError, match=re.escape("integrate: t_eval: expected shape (k,), given (2, 2)")):
        chain.integrate(0, 1, np.r_[q, qd], t_eval=np.zeros((2, 2)))
    with pytest.raises(ValueError, match=re.escape("ensemble: x0: expected shape (n, 20), given (20,)")):
        chain.ensemble(0, 1, np.r_[q, qd])
    with pytest.raises(ValueError, match=r"ensemble: t_eval: must be finite, ascending"):
        chain.ensemble(0, 1, np.zeros((2, 20)), t_eval=[0.5, 0.2])
    with pytest.raises(TypeError):
        chain.forward_dynamics(q)  # qd missing
