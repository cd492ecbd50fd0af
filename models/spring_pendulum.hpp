// The paper's spring pendulum (AAS 04-242, eqs. 29-30): a point mass on a linear spring swinging
// in a vertical plane. θ is measured from the downward vertical.
//   T = ½ m (ṙ² + r² θ̇²),   V = ½ k (r − r0)² + m g (r0 − r cos θ)
// Initial state used by the demo (the paper's Appendix B orders the state X0 = (r, θ, ṙ, θ̇)):
//   r = 0.55 m, θ = 0, ṙ = 0.01 m/s, θ̇ = 2.5 rad/s.
#pragma once

#include <array>
#include <cmath>

#include <eom/model/model.hpp>

namespace eom::models {

struct SpringPendulum {
  static constexpr std::array coordinates{"r", "theta"};
  static constexpr std::array parameters{"m", "k", "r0", "g"};
  static constexpr std::array parameter_values{1.0, 75.0, 0.5, 9.81};
  static constexpr std::array initial_q{0.55, 0.0};
  static constexpr std::array initial_qd{0.01, 2.5};

  template <class S> static S kinetic_energy(In<S> q, In<S> qd, In<S> p) {
    const S& m = p[0];
    return 0.5 * m * (qd[0] * qd[0] + q[0] * q[0] * qd[1] * qd[1]);
  }
  template <class S> static S potential_energy(In<S> q, In<S> p) {
    using std::cos;
    const S &m = p[0], &k = p[1], &r0 = p[2], &g = p[3];
    const S stretch = q[0] - r0;
    return 0.5 * k * stretch * stretch + m * g * (r0 - q[0] * cos(q[1]));
  }
};

}  // namespace eom::models
