"""integrate() and ensemble() against eom::integrate / eom::ensemble called from C++
(python_reference.cpp): the same times and states, bit for bit; ensemble() against integrate()
case by case; statuses instead of exceptions for runs that cannot be done."""

import numpy as np
import pytest

from conftest import load

RUNS = ["chain10_dop853", "chain10_dopri5", "chain10_rk4", "chain10_radau5", "chain10_taylor",
        "panda_dop853", "spacecraft_free_dop853"]


@pytest.mark.parametrize("run", RUNS)
def test_integrate_matches_cpp(reference, run):
    r = reference["runs"][run]
    m = load(r["model"])
    t_eval = None if r["t_eval"] is None else np.array(r["t_eval"])
    times, states, status = m.integrate(0.0, r["t1"], np.array(r["x0"]), u=r["u"], method=r["method"],
                                        rtol=r["rtol"], atol=r["atol"], step=r["step"], t_eval=t_eval)
    assert status == "ok" == r["status"]
    assert states.shape == (len(r["times"]), m.state_size)
    assert np.array_equal(times, np.array(r["times"]))
    assert np.array_equal(states.ravel(), np.array(r["states"]))
    if t_eval is not None:
        assert np.array_equal(times, t_eval)
    else:
        assert times[0] == 0.0 and times[-1] == r["t1"]


def test_free_joint_keeps_its_quaternion_unit(reference):
    r = reference["runs"]["spacecraft_free_dop853"]
    m = load("spacecraft_free")
    _, states, status = m.integrate(0.0, 2.0, np.array(r["x0"]), u=r["u"])
    assert status == "ok"
    assert np.allclose(np.linalg.norm(states[:, 3:7], axis=1), 1.0, atol=1e-15)


@pytest.mark.parametrize("method", ["rk4", "dop853"])
def test_ensemble_matches_cpp(reference, method):
    r = reference["runs"]["ensemble_" + method]
    m = load("chain10")
    x0 = np.array(r["x0"]).reshape(-1, m.state_size)
    times, states, status = m.ensemble(0.0, r["t1"], x0, method=method, step=r["step"],
                                       t_eval=np.array(r["t_eval"]), threads=2)
    assert status == ["ok"] * len(x0) == r["status"]
    assert np.array_equal(times, np.array(r["t_eval"]))
    assert states.shape == (len(x0), len(times), m.state_size)
    assert np.array_equal(states.ravel(), np.array(r["samples"]))


@pytest.mark.parametrize("method", ["rk4", "dopri5", "dop853", "radau5", "taylor"])
def test_ensemble_equals_integrate_case_by_case(method):
    m = load("chain10")
    rng = np.random.default_rng(4)
    x0 = np.hstack([rng.uniform(-0.5, 0.5, (5, 10)), np.zeros((5, 10))])
    P = np.tile(m.parameter_values, (5, 1))
    P[:, -1] = np.linspace(5, 15, 5)  # g per case
    step = 0.01 if method == "rk4" else 0.0
    t_eval = np.array([0.05, 0.1, 0.2])
    times, states, status = m.ensemble(0.0, 0.2, x0, p=P, method=method, step=step, t_eval=t_eval, threads=3)
    assert status == ["ok"] * 5
    for c in range(5):
        t, x, s = m.integrate(0.0, 0.2, x0[c], p=P[c], method=method, step=step, t_eval=t_eval)
        assert s == "ok" and np.array_equal(x, states[c]), c
    # without t_eval: the states at t1
    times, ends, _ = m.ensemble(0.0, 0.2, x0, p=P, method=method, step=step)
    assert np.array_equal(times, [0.2]) and np.array_equal(ends[:, 0], states[:, -1])


def test_statuses_instead_of_exceptions():
    m = load("chain10")
    x0 = np.zeros(20)
    assert m.integrate(0.0, 1.0, x0, max_steps=3)[2] == "step_limit"
    free = load("spacecraft_free")  # the variational method refuses a free joint
    x_free = np.zeros(free.state_size)
    x_free[3] = 1.0
    assert free.integrate(0.0, 1.0, x_free, method="variational", step=0.1)[2] == "method_unavailable"
    # a case of an ensemble refused for its own x0 reports its status, with a warning saying why;
    # the others complete
    cases = np.zeros((3, 20))
    cases[1, 0] = np.nan
    with pytest.warns(RuntimeWarning, match=r"ensemble: 1 of 3 cases refused .*case 1: x0: the initial "
                                            r"state has a value that is not finite"):
        _, states, status = m.ensemble(0.0, 0.1, cases)
    assert status == ["ok", "invalid_argument", "ok"]
    assert np.isnan(states[1]).all() and np.isfinite(states[[0, 2]]).all()


def test_invalid_arguments_name_the_argument_and_why():
    """eom::integrate's invalid_argument carries its reason (IntegrationResult::message): Python
    raises ValueError with it."""
    m = load("chain10")
    x0 = np.zeros(20)
    cases = [
        (dict(t0=1.0, t1=0.0), r"integrate: t1: must be greater than t0"),
        (dict(method="rk4"), r"integrate: step: rk4 takes a fixed step: give step > 0"),
        (dict(method="variational"), r"integrate: step: variational takes a fixed step"),
        (dict(rtol=-1.0), r"integrate: rtol: must be finite and > 0"),
        (dict(atol=0.0), r"integrate: atol: must be finite and > 0"),
        (dict(max_steps=0), r"integrate: max_steps: must be > 0"),
        (dict(t_eval=[0.5, 0.2]), r"integrate: output_times \(t_eval\): must be finite, ascending"),
        (dict(stabilization="projection"), r"integrate: stabilization: the model has no constraints"),
        (dict(x0=np.r_[np.nan, np.zeros(19)]), r"integrate: x0: the initial state has a value that is not finite"),
    ]
    for change, message in cases:
        args = dict(t0=0.0, t1=1.0, x0=x0)
        args.update(change)
        with pytest.raises(ValueError, match=message):
            m.integrate(**args)
    free = load("spacecraft_free")
    x_free = np.zeros(free.state_size)
    x_free[3] = 2.0  # not a unit quaternion
    with pytest.raises(ValueError, match=r"integrate: x0: the free joint's quaternion"):
        free.integrate(0.0, 1.0, x_free)
    # the ensemble: shared arguments raise like integrate's
    with pytest.raises(ValueError, match=r"ensemble: step: rk4 takes a fixed step"):
        m.ensemble(0.0, 1.0, np.zeros((2, 20)), method="rk4")
    with pytest.raises(ValueError, match=r"ensemble: t_eval: must be finite, ascending and inside \[t0, t1\]"):
        m.ensemble(0.0, 1.0, np.zeros((2, 20)), t_eval=[0.5, 0.2])


def test_constrained_model_with_stabilization():
    m = load("cartesian_pendulum")
    l = m.parameter_values[m.parameter_names.index("l")]
    x0 = np.array([l, 0.0, 0.0, 0.0])  # horizontal, at rest: on the circle
    assert abs(m.constraint_residual(x0[:2])).max() < 1e-15
    for stabilization in ("baumgarte", "projection"):
        t, x, s = m.integrate(0.0, 1.0, x0, stabilization=stabilization)
        assert s == "ok", stabilization
        assert abs(m.constraint_residual(x[-1, :2])).max() < 1e-8, stabilization
    off = np.array([l * 1.01, 0.0, 0.0, 0.0])
    assert m.integrate(0.0, 1.0, off)[2] == "inconsistent_initial_state"
    with pytest.raises(ValueError, match="stabilization"):
        m.integrate(0.0, 1.0, x0, stabilization="nope")
