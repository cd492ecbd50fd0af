// The spherical pendulum (a point mass on a massless rod of length l, free to swing in 3D), in
// two formulations of the same motion, for the hard cases of docs/hard-cases/:
//
//   SphericalPendulum           polar angles: θ from the downward vertical, φ the azimuth.
//                                 T = ½ m l² (θ̇² + sin²θ φ̇²),   V = −m g l cos θ
//                               M = diag(m l², m l² sin²θ) is singular at the poles θ = 0, π:
//                               the azimuth is not defined there (a coordinate singularity, not
//                               a physical one). L_z = m l² sin²θ φ̇ and E are conserved.
//   CartesianSphericalPendulum  Cartesian (x, y, z), z up, with the constraint x²+y²+z² = l²:
//                                 T = ½ m (ẋ² + ẏ² + ż²),        V = m g z
//                               no singularity anywhere; the reference for the polar form
//                               (x = l sin θ cos φ, y = l sin θ sin φ, z = −l cos θ).
#pragma once

#include <array>
#include <cmath>

#include <eom/model/model.hpp>

namespace eom::models {

struct SphericalPendulum {
  static constexpr std::array coordinates{"theta", "phi"};
  static constexpr std::array parameters{"m", "l", "g"};
  static constexpr std::array parameter_values{1.0, 1.0, 9.81};

  template <class S> static S kinetic_energy(In<S> q, In<S> qd, In<S> p) {
    using std::sin;
    const S &m = p[0], &l = p[1];
    const S s = sin(q[0]);
    return 0.5 * m * l * l * (qd[0] * qd[0] + s * s * qd[1] * qd[1]);
  }
  template <class S> static S potential_energy(In<S> q, In<S> p) {
    using std::cos;
    const S &m = p[0], &l = p[1], &g = p[2];
    return -m * g * l * cos(q[0]);
  }
};

struct CartesianSphericalPendulum {
  static constexpr std::array coordinates{"x", "y", "z"};
  static constexpr std::array parameters{"m", "l", "g"};
  static constexpr std::array parameter_values{1.0, 1.0, 9.81};
  static constexpr std::array constraint_names{"length"};

  template <class S> static S kinetic_energy(In<S>, In<S> qd, In<S> p) {
    return 0.5 * p[0] * (qd[0] * qd[0] + qd[1] * qd[1] + qd[2] * qd[2]);
  }
  template <class S> static S potential_energy(In<S> q, In<S> p) { return p[0] * p[2] * q[2]; }
  template <class S> static void constraints(In<S> q, In<S> p, Out<S> phi) {
    phi[0] = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] - p[1] * p[1];
  }
};

}  // namespace eom::models
