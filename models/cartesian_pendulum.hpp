// A point-mass pendulum written in Cartesian coordinates (x, y) with the holonomic constraint
// x² + y² − l² = 0: the smallest model that exercises constraint Jacobians, the bias term and
// the range-space solve. y points up; gravity acts along −y.
//   T = ½ m (ẋ² + ẏ²),   V = m g y,   φ = x² + y² − l²
#pragma once

#include <array>

#include <eom/model/model.hpp>

namespace eom::models {

struct CartesianPendulum {
  static constexpr std::array coordinates{"x", "y"};
  static constexpr std::array parameters{"m", "l", "g"};
  static constexpr std::array parameter_values{1.5, 0.8, 9.81};
  static constexpr std::array constraint_names{"length"};

  template <class S> static S kinetic_energy(In<S>, In<S> qd, In<S> p) {
    return 0.5 * p[0] * (qd[0] * qd[0] + qd[1] * qd[1]);
  }
  template <class S> static S potential_energy(In<S> q, In<S> p) { return p[0] * p[2] * q[1]; }
  template <class S> static void constraints(In<S> q, In<S> p, Out<S> phi) {
    phi[0] = q[0] * q[0] + q[1] * q[1] - p[1] * p[1];
  }
};

}  // namespace eom::models
