"""The contact kernels from Python (python/eom_python.hpp) on Solo12 (tests/contacts/CMakeLists.txt:
the one set trot, a diagonal pair of point feet): the set by name and index, batches against single calls, the impulse
balance M (v+ - v-) = J' impulse with the module's own M and frame Jacobians, J v+ = -e J v-, the
derivatives along v and u against central differences, and bad input (unknown set, kd < 0,
restitution outside [0, 1])."""

import importlib

import numpy as np
import pytest

m = importlib.import_module("contact_solo12_derivatives")


def state(seed):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1, 1, m.nq)
    q[3:7] /= np.linalg.norm(q[3:7])
    return q, rng.uniform(-2, 2, m.nv), rng.uniform(-3, 3, m.nu)


def stacked_jacobian(s, q):
    rows = []
    sets = {"trot": [("FL_FOOT", 3), ("HR_FOOT", 3)]}
    for frame, k in sets[s]:
        rows.append(m.frame_jacobian(frame, q)[:k])
    return np.vstack(rows)


def test_the_sets_as_the_header_states_them():
    assert m.ncontact_sets == 1
    assert m.contact_set_names == ("trot",)
    assert m.contact_rows == (6,)
    assert m.frame_names == ("FL_FOOT", "HR_FOOT")


def test_by_name_by_index_and_in_batches():
    q, v, u = state(1)
    a, la = m.contact_dynamics("trot", q, v, u, kd=5.0)
    b, lb = m.contact_dynamics(0, q, v, u, kd=5.0)
    assert a.shape == (m.nv,) and la.shape == (6,)
    assert np.array_equal(a, b) and np.array_equal(la, lb)
    qs, vs, us = zip(*(state(k) for k in range(5)))
    A, LA = m.contact_dynamics("trot", np.array(qs), np.array(vs), np.array(us))
    assert A.shape == (5, m.nv) and LA.shape == (5, 6)
    for k in range(5):
        a, la = m.contact_dynamics("trot", qs[k], vs[k], us[k])
        assert np.array_equal(A[k], a) and np.array_equal(LA[k], la)


@pytest.mark.parametrize("s", ["trot", 0])
def test_impulse_balances_momentum(s):
    for seed in range(3):
        q, v, _ = state(seed)
        for e in (0.0, 0.7):
            v_plus, impulse = m.impulse_dynamics(s, q, v, restitution=e)
            M = m.mass_matrix(q)
            J = stacked_jacobian("trot", q)
            scale = max(1.0, np.abs(M @ v).max())
            assert np.abs(M @ (v_plus - v) - J.T @ impulse).max() < 1e-12 * scale
            assert np.abs(J @ v_plus + e * (J @ v)).max() < 1e-9 * max(1.0, np.abs(J @ v).max())


def test_bad_input():
    q, v, u = state(2)
    with pytest.raises(ValueError, match="unknown set 'trop'; the sets are: trot"):
        m.contact_dynamics("trop", q, v, u)
    with pytest.raises(IndexError, match="out of range"):
        m.impulse_dynamics(1, q, v)
    vdot, lam, ok = m.contact_dynamics("trot", q, v, u, kd=-1.0, status=True)
    assert not ok and np.isnan(vdot).all() and np.isnan(lam).all()
    v_plus, impulse, ok = m.impulse_dynamics("trot", q, v, restitution=1.5, status=True)
    assert not ok and np.isnan(v_plus).all()
    *outputs, ok = m.contact_dynamics_derivatives("trot", q, v, u, rho=-1.0, status=True)
    assert not ok and all(np.isnan(x).all() for x in outputs)


def test_derivatives_along_v_and_u_match_differences():
    q, v, u = state(3)
    dq, dv, du, lq, lv, lu = m.contact_dynamics_derivatives("trot", q, v, u, kd=2.0)
    assert dq.shape == (m.nv, m.nv) and du.shape == (m.nv, m.nu) and lq.shape == (6, m.nv) and lu.shape == (6, m.nu)
    h = 1e-6
    for j in range(m.nv):
        e = np.zeros(m.nv)
        e[j] = h
        (a, la), (b, lb) = m.contact_dynamics("trot", q, v + e, u, kd=2.0), m.contact_dynamics("trot", q, v - e, u, kd=2.0)
        assert np.allclose((a - b) / (2 * h), dv[:, j], rtol=1e-6, atol=1e-6 * np.abs(dv).max())
        assert np.allclose((la - lb) / (2 * h), lv[:, j], rtol=1e-6, atol=1e-6 * np.abs(lv).max())
    for j in range(m.nu):
        e = np.zeros(m.nu)
        e[j] = h
        (a, la), (b, lb) = m.contact_dynamics("trot", q, v, u + e, kd=2.0), m.contact_dynamics("trot", q, v, u - e, kd=2.0)
        assert np.allclose((a - b) / (2 * h), du[:, j], rtol=1e-6, atol=1e-6 * np.abs(du).max())
        assert np.allclose((la - lb) / (2 * h), lu[:, j], rtol=1e-6, atol=1e-6 * np.abs(lu).max())
    pq, pv, iq, iv = m.impulse_dynamics_derivatives("trot", q, v, restitution=0.3)
    assert pv.shape == (m.nv, m.nv) and iv.shape == (6, m.nv)
    for j in range(m.nv):  # v+ and the impulse are linear in v-
        e = np.zeros(m.nv)
        e[j] = 1.0
        (a, ia), (b, ib) = m.impulse_dynamics("trot", q, v + e, restitution=0.3), m.impulse_dynamics("trot", q, v, restitution=0.3)
        assert np.allclose(a - b, pv[:, j], rtol=1e-9, atol=1e-9 * np.abs(pv).max())
        assert np.allclose(ia - ib, iv[:, j], rtol=1e-9, atol=1e-9 * np.abs(iv).max())
