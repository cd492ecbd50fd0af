"""The contact step from Python (python/eom_python_contact.hpp) on tests/mjcf's boxes on an incline
(models/mjcf/incline.xml): rollout against the closed form (the slider's acceleration, the sticker
held), rollout against contact_step repeated (the same bits), controls held or per step, and the
arguments it refuses."""

import math

import numpy as np
import pytest

import mjcf_incline as m


def start():
    x = np.zeros(m.nq + m.nv)
    x[:m.nq] = [0.014776, -0.5, 0.047767, math.cos(0.15), 0.0, math.sin(0.15), 0.0, 0.0, 0.0, 0.0]
    return x


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


def test_the_module_says_where_its_quaternions_are():
    """The slider's free joint (the first joint): one quaternion, its w at q[3]; nv one fewer."""
    assert m.quaternions == (3,)
    assert m.nv == m.nq - len(m.quaternions)
    assert m.floating_base
