"""The contact step from Python (python/eom_python_contact.hpp) on tests/mjcf's boxes on an incline
(models/mjcf/incline.xml): rollout against the closed form (the slider's acceleration, the sticker
held), rollout against contact_step repeated (the same bits), controls held or per step, n cases
at once on threads (each bitwise its own rollout, a failing case alone), and the arguments it
refuses."""

import math

import numpy as np
import pytest

import mjcf_incline as m


def start():
    """At rest where the file places the boxes (MuJoCo's qpos0)."""
    return np.concatenate([m.qpos0, np.zeros(m.nv)])


def test_qpos0_and_keyframes_are_the_files():
    # the slider's free joint at its body's pos and euler="0 0.3 0", the sticker's slides at 0
    expected = [0.014776, -0.5, 0.047767, math.cos(0.15), 0.0, math.sin(0.15), 0.0, 0.0, 0.0, 0.0]
    np.testing.assert_allclose(m.qpos0, expected, rtol=0, atol=1e-15)
    assert m.qpos0.shape == (m.nq,) and not m.qpos0.flags.writeable
    assert len(m.keyframes) == 1
    key = m.keyframes[0]
    assert key["name"] == "pushed" and key["time"] == 0.0
    np.testing.assert_array_equal(key["qpos"], m.qpos0)  # a <key> without qpos holds qpos0
    np.testing.assert_array_equal(key["qvel"], [-2 * math.cos(0.3), 0, 2 * math.sin(0.3), 0, 0, 0, 0, 0, 0])
    assert key["ctrl"].shape == (0,)


def test_the_pushed_keyframe_slows_as_the_closed_form():
    # pushed up the slope at 2 m/s, kinetic friction 0.2 and gravity both against it until it stops
    # (after 0.42 s); measured from 0.1 s, when the soft contact's first bounce has died down
    key = m.keyframes[0]
    times, states, status = m.rollout(np.concatenate([key["qpos"], key["qvel"]]), 400)
    assert status == "ok"
    up = np.array([-math.cos(0.3), 0.0, math.sin(0.3)])
    speed = states[:, m.nq:m.nq + 3] @ up
    assert speed[0] == pytest.approx(2.0) and speed[400] > 0
    expected = 9.81 * (math.sin(0.3) + 0.2 * math.cos(0.3))
    assert (speed[100] - speed[400]) / (times[400] - times[100]) == pytest.approx(expected, rel=1e-2)


def test_rollout_slides_and_sticks_as_the_closed_form():
    assert m.timestep == 0.001
    times, states, status = m.rollout(start(), 1000)
    assert status == "ok" and states.shape == (1001, m.nq + m.nv) and times[-1] == pytest.approx(1.0)
    down = np.array([math.cos(0.3), 0.0, -math.sin(0.3)])
    v_half, v_end = states[500, m.nq:m.nq + 3] @ down, states[1000, m.nq:m.nq + 3] @ down
    expected = 9.81 * (math.sin(0.3) - 0.2 * math.cos(0.3))
    assert (v_end - v_half) / 0.5 == pytest.approx(expected, rel=1e-2)  # soft contact: 1.3e-3
    sticker = states[:, m.nq + 6:m.nq + 9] @ down
    assert abs(sticker[1000] - sticker[500]) / 0.5 < 1e-3 * expected  # held (a steady creep)


def test_rollout_is_contact_step_repeated():
    times, states, _ = m.rollout(start(), 20)
    x, t = start(), 0.0
    for k in range(20):
        t, x, status = m.contact_step(x, t=t)
        assert status == "ok"
        # each contact_step starts its solver cold, rollout warm: the same point to rounding
        np.testing.assert_allclose(x, states[k + 1], rtol=1e-12, atol=1e-13)
    assert t == pytest.approx(times[-1])


def test_controls_held_or_per_step_and_bad_arguments():
    assert m.nu == 0
    m.rollout(start(), 3, u=np.zeros((3, 0)))  # one (empty) row per step
    with pytest.raises(ValueError, match="rollout: steps: must be >= 0"):
        m.rollout(start(), -1)
    with pytest.raises(ValueError, match="rollout: x0: expected shape"):
        m.rollout(np.zeros(3), 5)
    with pytest.raises(ValueError, match="rollout: u: expected"):
        m.rollout(start(), 5, u=np.zeros((4, 0)))


def cases():
    """Three starts: the one above, the slider pushed, the slider dropped from 2 cm higher."""
    X = np.tile(start(), (3, 1))
    X[1, m.nq] = 0.4
    X[2, 2] += 0.02
    return X


def test_cases_on_threads_are_each_their_own_rollout():
    X = cases()
    times, states, status = m.rollout(X, 60, threads=2)
    assert states.shape == (3, 61, m.nq + m.nv) and status == ["ok"] * 3
    for c in range(3):
        t1, s1, st1 = m.rollout(X[c], 60)
        assert st1 == "ok"
        np.testing.assert_array_equal(states[c], s1)  # bit for bit
        np.testing.assert_array_equal(times, t1)
    again = m.rollout(X, 60, threads=1)[1]
    np.testing.assert_array_equal(states, again)  # any number of threads
    assert len(set(map(bytes, (states[0], states[1], states[2])))) == 3  # the starts differ


def test_a_failing_case_fails_alone():
    X = cases()
    X[1, m.nq + 2] = np.nan
    times, states, status = m.rollout(X, 10, threads=2)
    assert status == ["ok", "dynamics_failed", "ok"]
    np.testing.assert_array_equal(states[1, 0], X[1])  # the start is kept ...
    assert np.isnan(states[1, 1:]).all()  # ... and nothing after it
    np.testing.assert_array_equal(states[2], m.rollout(X[2], 10)[1])


def test_cases_refuse_bad_shapes():
    X = cases()
    n = m.nq + m.nv
    with pytest.raises(ValueError, match=rf"rollout: x0: expected shape \({n},\) or \(n, {n}\)"):
        m.rollout(np.zeros((3, 5)), 5)
    with pytest.raises(ValueError, match="rollout: x0: .* n >= 1"):
        m.rollout(np.zeros((0, m.nq + m.nv)), 5)
    with pytest.raises(ValueError, match=r"rollout: u: expected shape \(0,\) or \(n, 0\) or \(n, steps, 0\) "
                                         r"with n = 3 cases, given \(2, 0\)"):
        m.rollout(X, 5, u=np.zeros((2, 0)))
    m.rollout(X, 5, u=np.zeros((3, 5, 0)))  # per case and step (nu = 0: empty)
    with pytest.raises(ValueError, match="rollout: steps: must be >= 0"):
        m.rollout(X, -1)


def test_the_module_says_where_its_quaternions_are():
    """The slider's free joint (the first joint): one quaternion, its w at q[3]; nv one fewer."""
    assert m.quaternions == (3,)
    assert m.nv == m.nq - len(m.quaternions)
    assert m.floating_base


def test_step_derivatives_are_the_steps_jacobian():
    """step_derivatives (eom::contact_step_derivatives): the step contact_step takes, and A against
    central differences of contact_step in every v direction and in the first box's position (q
    directions along x, y, z: q's own coordinates there), rows of v and of those positions; at a
    state 50 steps on, the boxes resting on the ramp (start() places them at the touching point,
    where the step has no derivative)."""
    x = m.rollout(start(), 50)[1][-1]
    t, x1, A, B, status = m.step_derivatives(x)
    assert status == "ok" and A.shape == (2 * m.nv, 2 * m.nv) and B.shape == (2 * m.nv, 0)
    t2, x2, _ = m.contact_step(x)
    assert t == t2
    np.testing.assert_array_equal(x1, x2)
    rows = np.r_[0:3, m.nv:2 * m.nv]  # of x⁺ = (δq, v): the position's three and v
    x_rows = np.r_[0:3, m.nq:m.nq + m.nv]
    eps, worst, scale = 1e-6, 0.0, np.abs(A).max()
    for column, coordinate in [(j, j) for j in range(3)] + [(m.nv + j, m.nq + j) for j in range(m.nv)]:
        xp, xm = x.copy(), x.copy()
        xp[coordinate] += eps
        xm[coordinate] -= eps
        difference = (m.contact_step(xp)[1][x_rows] - m.contact_step(xm)[1][x_rows]) / (2 * eps)
        worst = max(worst, np.abs(A[rows, column] - difference).max())
    assert worst <= 1e-6 * scale, (worst, scale)
    _, x3, A3, _, status = m.step_derivatives(np.full(m.nq + m.nv, np.nan))
    assert status == "dynamics_failed" and np.isnan(A3).all()


def test_forward_is_the_steps_acceleration_and_newtons_law_holds():
    """forward (eom::contact_forward, MuJoCo's mj_forward) at a state 50 steps on, the boxes resting
    on the ramp: the acceleration contact_step takes (v⁺ = v + h qacc: nothing is damped here); the
    contacts, box corners on the slope (geom1 the slope, the normal its own); and Newton's second
    law for the sticker (1 kg on three slides along its tilted axes): m R a = m g + the sum of its
    contacts' forces in world axes (frameᵀ f)."""
    assert m.geom_names == ("slope", "slider", "sticker")
    x = m.rollout(start(), 50)[1][-1]
    qacc, contacts, status = m.forward(x)
    assert status == "ok" and qacc.shape == (m.nv,)
    _, x1, _ = m.contact_step(x)
    np.testing.assert_allclose(x1[m.nq:], x[m.nq:] + m.timestep * qacc, rtol=0, atol=1e-15)
    k = len(contacts["dist"])
    assert k >= 6 and contacts["frame"].shape == (k, 3, 3) and contacts["force"].shape == (k, 6)
    assert (contacts["geom1"] == 0).all() and set(contacts["geom2"]) == {1, 2}
    normal = np.array([math.sin(0.3), 0.0, math.cos(0.3)])
    np.testing.assert_allclose(contacts["frame"][:, 0], np.tile(normal, (k, 1)), atol=1e-15)
    assert (contacts["dist"] < 0).all() and contacts["active"].all()  # soft: a little inside
    assert (contacts["force"][:, 0] > 0).all()  # pushing the boxes off the slope
    on_sticker = contacts["geom2"] == 2
    world = np.einsum("kij,ki->j", contacts["frame"][on_sticker], contacts["force"][on_sticker, :3])
    c, s = math.cos(0.3), math.sin(0.3)
    R = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])  # the sticker's axes in world
    gravity = np.array([0.0, 0.0, -9.81])
    np.testing.assert_allclose(R @ qacc[6:9], gravity + world, rtol=0, atol=1e-10)
    assert np.linalg.norm(qacc[6:9]) < 0.01 * 9.81  # held (settling still, 50 ms after the start)


def test_forward_refuses_and_fails_as_the_step():
    with pytest.raises(ValueError, match="forward: x: expected"):
        m.forward(np.zeros(3))
    qacc, contacts, status = m.forward(np.full(m.nq + m.nv, np.nan))
    assert status == "dynamics_failed" and np.isnan(qacc).all()
    assert all(len(a) == 0 for a in contacts.values())


def test_forward_over_n_states_is_each_states_call():
    # three states of a rollout and a failing one: each row bitwise its own call, the failure alone
    X = m.rollout(start(), 60)[1][[0, 20, 60, 60]]
    X[3, 0] = np.nan
    qacc, contacts, status = m.forward(X)
    assert qacc.shape == (4, m.nv) and len(contacts) == 4 and status[:3] == ["ok"] * 3
    assert status[3] == "dynamics_failed" and np.isnan(qacc[3]).all() and len(contacts[3]["dist"]) == 0
    assert len(contacts[2]["dist"]) >= 4  # both boxes resting on the slope
    for i in range(3):
        one_qacc, one_contacts, one_status = m.forward(X[i])
        assert one_status == status[i]
        np.testing.assert_array_equal(qacc[i], one_qacc)
        assert one_contacts.keys() == contacts[i].keys()
        for key in one_contacts:
            np.testing.assert_array_equal(contacts[i][key], one_contacts[key])
    # one x for n parameter rows; rows that disagree are refused, naming both
    assert m.forward(X[2], p=np.tile(m.parameter_values, (2, 1)))[0].shape == (2, m.nv)
    with pytest.raises(ValueError, match="forward: p: has 2 rows, but x has 4"):
        m.forward(X, p=np.tile(m.parameter_values, (2, 1)))
