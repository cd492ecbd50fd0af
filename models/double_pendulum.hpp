// The chaotic double pendulum of the integrator tests: two point masses on massless rigid rods,
// swinging in a vertical plane. a1 and a2 are the absolute angles of the rods from the downward
// vertical.
//   T = ½ (m1 + m2) l1² ȧ1² + ½ m2 l2² ȧ2² + m2 l1 l2 ȧ1 ȧ2 cos(a1 − a2)
//   V = −(m1 + m2) g l1 cos a1 − m2 g l2 cos a2
// Started at rest from a1 = 2.0, a2 = 2.5 (unit masses and lengths, g = 9.81) the motion is
// chaotic: a perturbation grows about a million-fold every 5 time units.
#pragma once

#include <array>
#include <cmath>

#include <eom/model/model.hpp>

namespace eom::models {

struct DoublePendulum {
  static constexpr std::array coordinates{"a1", "a2"};
  static constexpr std::array parameters{"m1", "m2", "l1", "l2", "g"};
  static constexpr std::array parameter_values{1.0, 1.0, 1.0, 1.0, 9.81};
  static constexpr std::array initial_q{2.0, 2.5};
  static constexpr std::array initial_qd{0.0, 0.0};

  template <class S> static S kinetic_energy(In<S> q, In<S> qd, In<S> p) {
    using std::cos;
    const S &m1 = p[0], &m2 = p[1], &l1 = p[2], &l2 = p[3];
    return 0.5 * (m1 + m2) * l1 * l1 * qd[0] * qd[0] + 0.5 * m2 * l2 * l2 * qd[1] * qd[1] +
           m2 * l1 * l2 * qd[0] * qd[1] * cos(q[0] - q[1]);
  }
  template <class S> static S potential_energy(In<S> q, In<S> p) {
    using std::cos;
    const S &m1 = p[0], &m2 = p[1], &l1 = p[2], &l2 = p[3], &g = p[4];
    return -(m1 + m2) * g * l1 * cos(q[0]) - m2 * g * l2 * cos(q[1]);
  }
};

}  // namespace eom::models
