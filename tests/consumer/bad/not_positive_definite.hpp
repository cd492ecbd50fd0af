// Models whose kinetic energy is not positive definite, which generation must refuse (naming the
// coordinate of the first pivot of M that fails):
//   SignError   a double pendulum with a sign error: −½ m2 l2² θ̇2² instead of +, so M is
//               indefinite (its second pivot is negative);
//   Degenerate  T = ½ m (ẋ + ẏ)² + ½ b ẏ², with b = 0 by default: x and y only ever move
//               together, M is singular (its second pivot is b); b < 0 makes it indefinite.
#pragma once

#include <array>
#include <cmath>

#include <eom/model/model.hpp>

struct SignError {
  static constexpr std::array coordinates{"theta1", "theta2"};
  static constexpr std::array parameters{"m1", "m2", "l1", "l2", "g"};
  static constexpr std::array parameter_values{1.0, 1.0, 1.0, 1.0, 9.81};

  template <class S> static S kinetic_energy(eom::In<S> q, eom::In<S> qd, eom::In<S> p) {
    using std::cos;
    return 0.5 * (p[0] + p[1]) * p[2] * p[2] * qd[0] * qd[0]
           - 0.5 * p[1] * p[3] * p[3] * qd[1] * qd[1]  // the sign error: + is right
           + p[1] * p[2] * p[3] * cos(q[0] - q[1]) * qd[0] * qd[1];
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    using std::cos;
    return -(p[0] + p[1]) * p[4] * p[2] * cos(q[0]) - p[1] * p[4] * p[3] * cos(q[1]);
  }
};

struct Degenerate {
  static constexpr std::array coordinates{"x", "y"};
  static constexpr std::array parameters{"m", "b"};
  static constexpr std::array parameter_values{2.0, 0.0};

  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S> p) {
    const S v = qd[0] + qd[1];
    return 0.5 * p[0] * v * v + 0.5 * p[1] * qd[1] * qd[1];
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S>) {
    return 0.5 * (q[0] * q[0] + q[1] * q[1]);
  }
};
