// Unit masses driven by the sines and cosines of four coordinates, q̈ = (sin q0..3, cos q0..3)/m:
// with m = 1 the generated forward dynamics returns the kernel's own sines and cosines (the
// sincos_n of the generated source), which test_compiled compares with double-double ones.
#pragma once

#include <array>
#include <cmath>

#include <eom/model/model.hpp>

namespace eomtest {

struct AnglesModel {
  static constexpr std::array coordinates{"a", "b", "c", "d", "e", "f", "g", "h"};
  static constexpr std::array parameters{"m"};
  static constexpr std::array parameter_values{1.0};

  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S> p) {
    S sum = qd[0] * qd[0];
    for (int i = 1; i < 8; ++i) sum = sum + qd[i] * qd[i];
    return 0.5 * p[0] * sum;
  }
  template <class S> static S potential_energy(eom::In<S>, eom::In<S>) { return S(0.0); }
  template <class S>
  static void generalized_forces(const S&, eom::In<S> q, eom::In<S>, eom::In<S>, eom::In<S>,
                                 eom::Out<S> Q) {
    using std::cos, std::sin;
    for (int i = 0; i < 4; ++i) {
      Q[i] = sin(q[i]);
      Q[4 + i] = cos(q[i]);
    }
  }
};

}  // namespace eomtest
