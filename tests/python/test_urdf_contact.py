"""A URDF robot's module with a scene (add_eom_model's GROUND and COLLISION_PAIRS): tests/urdf's
drop_box (a box with an arm, on a free root) dropped on the ground by rollout and contact_step, as
an MJCF model's module steps (test_contact.py); tests/urdf/test_urdf_scene.cpp checks the same
steps against MuJoCo."""
import numpy as np

import urdf_drop_box as m


def start():
    x0 = np.zeros(m.nq + m.nv)
    x0[2], x0[3] = 0.3, 1.0  # 0.3 m up, level, at rest
    return x0


def test_it_falls_and_rests_on_the_ground():
    assert m.timestep == 0.002  # MuJoCo's default, as the scene states it
    times, states, status = m.rollout(start(), 1500)
    assert status == "ok"
    assert times.shape == (1501,) and states.shape == (1501, m.nq + m.nv)
    assert abs(times[-1] - 3.0) < 1e-12
    # it fell: 0.3 m then, resting on the ground with the arm on it now (the box's origin below
    # its half-height 0.05 m plus the hinge's 0.05 m above it)
    z = states[:, 2]
    assert z.min() < 0.1 < z[0]
    assert 0.0 < z[-1] < 0.1
    assert np.abs(states[-1, m.nq:]).max() < 1e-3  # at rest
    # the same as contact_step repeated
    x = start()
    for _ in range(20):
        t, x, step_status = m.contact_step(x)
        assert step_status == "ok"
    np.testing.assert_array_equal(x, states[20])
