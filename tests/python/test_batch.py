"""Batches (a leading axis of n states) against single calls, bit for bit: every kernel of every
model; shared (1-D) arguments broadcast; per-row t and p; the SIMD batch kernel and the threads
give the same bits; a failing row leaves the others alone."""

import numpy as np
import pytest

from conftest import CALLS, MODELS, call, inputs, load
from types import SimpleNamespace


def batch_inputs(x, n, rng):
    """n states around x, per row (q, qd, qdd, u), parameters and t shared."""
    def rows(v, scale):
        return v + scale * rng.standard_normal((n, v.size)) if v.size else np.zeros((n, 0))
    b = SimpleNamespace(q=rows(x.q, 0.1), qd=rows(x.qd, 0.1), qdd=rows(x.qdd, 0.1), u=rows(x.u, 0.1),
                        p=x.p, t=x.t)
    if b.q.shape[1] != b.qd.shape[1]:  # a free joint: unit quaternions
        b.q[:, 3:7] /= np.linalg.norm(b.q[:, 3:7], axis=1, keepdims=True)
    return b


def row(b, i):
    return SimpleNamespace(q=b.q[i], qd=b.qd[i], qdd=b.qdd[i], u=b.u[i], p=b.p if b.p.ndim == 1 else b.p[i],
                           t=b.t if np.ndim(b.t) == 0 else float(b.t[i]))


@pytest.mark.parametrize("model", MODELS)
def test_batch_equals_single_calls(reference, model):
    ref = reference["models"][model]
    m = load(model)
    n = 7
    b = batch_inputs(inputs(ref), n, np.random.default_rng(1))
    for entry, expected in ref["kernels"].items():
        outputs, ok, _ = call(m, entry, b, expected)
        for i in range(n):
            single, ok_i, _ = call(m, entry, row(b, i), expected)
            for k, (o, s) in enumerate(zip(outputs, single)):
                assert o.shape == (n,) + np.shape(s), (entry, k)
                assert np.array_equal(o[i], s, equal_nan=True), (entry, k, i)
            if ok is not None:
                assert ok.dtype == bool and ok.shape == (n,)
                assert ok[i] == ok_i


def test_per_row_parameters_and_times(reference):
    m = load("chain10")
    x = inputs(reference["models"]["chain10"])
    n = 5
    rng = np.random.default_rng(2)
    Q = x.q + 0.1 * rng.standard_normal((n, m.nq))
    P = np.tile(x.p, (n, 1))
    P[:, m.parameter_names.index("g")] = np.linspace(0, 20, n)
    T = np.linspace(0, 1, n)
    U = None
    qdd = m.forward_dynamics(Q, x.qd, U, P, T)
    for i in range(n):
        assert np.array_equal(qdd[i], m.forward_dynamics(Q[i], x.qd, None, P[i], T[i]))
    # everything shared but t: a batch of n with one state
    tau = load("panda").inverse_dynamics(np.zeros(7), np.zeros(7), np.zeros(7), t=np.zeros(3))
    assert tau.shape == (3, 7)


@pytest.mark.parametrize("n", [3, 4, 9, 4099])
def test_simd_batch_kernel_and_threads_give_the_same_bits(n):
    m = load("chain10")
    rng = np.random.default_rng(n)
    Q = rng.uniform(-1, 1, (n, m.nq))
    QD = rng.uniform(-1, 1, (n, m.nq))
    Q[n // 2, 3] = np.nan  # a failing row in the middle
    single = np.array([m.forward_dynamics(Q[i], QD[i]) for i in range(n)])
    results = []
    try:
        for batch_kernel in (True, False):
            for threads in (1, 3):
                m.set_batch_kernel(batch_kernel)
                m.set_num_threads(threads)
                qdd, ok = m.forward_dynamics(Q, QD, status=True)
                assert np.array_equal(qdd, single, equal_nan=True), (batch_kernel, threads)
                assert not ok[n // 2] and ok.sum() == n - 1
                assert np.isnan(qdd[n // 2]).all()
                results.append(qdd)
    finally:
        m.set_batch_kernel(True)
        m.set_num_threads(0)


def test_threads_for_large_batches_of_any_kernel():
    m = load("panda")
    n = 5000
    Q = np.random.default_rng(3).uniform(-1, 1, (n, 7))
    try:
        m.set_num_threads(1)
        one = m.mass_matrix(Q)
        m.set_num_threads(4)
        assert m.get_num_threads() == 4
        assert np.array_equal(m.mass_matrix(Q), one)
    finally:
        m.set_num_threads(0)


def test_empty_batch():
    m = load("chain10")
    assert m.forward_dynamics(np.zeros((0, 10)), np.zeros((0, 10))).shape == (0, 10)
    assert m.mass_matrix(np.zeros((0, 10))).shape == (0, 10, 10)
    assert m.kinetic_energy(np.zeros((0, 10)), np.zeros(10)).shape == (0,)


def test_batched_shapes():
    m = load("chain10")
    n = 6
    Q = np.zeros((n, 10))
    assert m.kinetic_energy(Q, np.ones(10)).shape == (n,)
    assert isinstance(m.kinetic_energy(Q[0], np.ones(10)), float)
    a, b, c = m.forward_dynamics_derivatives(Q, Q)
    assert a.shape == b.shape == (n, 10, 10) and c.shape == (n, 10, m.nu)
    qk, qdk = m.taylor_coefficients(3, Q, Q)
    assert qk.shape == qdk.shape == (n, 4, 10)
    # the zeroth coefficients are the state itself
    assert np.array_equal(qk[:, 0], Q) and np.array_equal(qdk[:, 0], Q)
    assert CALLS  # the table covers every kernel the tests compare
