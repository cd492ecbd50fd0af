// A model whose dynamics use every operation the tape records, each Taylor rule variant included
// (both arguments varying, one constant; sin with and without its cos; a^b with variable base,
// exponent or both; select both ways; time and inputs), with a constraint: the generated
// taylor_coefficients of it is compared with the generator's own evaluator (taylor_ode) and with
// eom::Reference, so every emitted rule runs inside real dynamics.
#pragma once

#include <array>
#include <cmath>

#include <eom/model/model.hpp>

namespace eomtest {

struct OpsModel {
  static constexpr std::array coordinates{"x", "y", "z"};
  static constexpr std::array parameters{"m", "k", "c"};
  static constexpr std::array parameter_values{1.3, 0.7, 0.4};
  static constexpr std::array inputs{"drive"};
  static constexpr std::array constraint_names{"link"};

  // M = diag(m, m (1 + 0.2 sin² x), m + 0.1 cos x): depends on q, positive definite.
  template <class S> static S kinetic_energy(eom::In<S> q, eom::In<S> qd, eom::In<S> p) {
    using std::cos, std::sin;
    const S s = sin(q[0]);
    return 0.5 * p[0] * qd[0] * qd[0] + 0.5 * p[0] * (1.0 + 0.2 * s * s) * qd[1] * qd[1] +
           0.5 * (p[0] + 0.1 * cos(q[0])) * qd[2] * qd[2];
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    using std::exp, std::log, std::sqrt, std::tan, std::atan;
    return p[1] * (exp(0.3 * q[0]) + log(2.0 + q[1] * q[1]) + sqrt(1.5 + q[2] * q[2])) +
           0.1 * tan(0.4 * q[1]) + 0.2 * atan(q[0] - q[2]);
  }
  // φ = x + 0.3 sin y + 0.2 z² − 0.5
  template <class S> static void constraints(eom::In<S> q, eom::In<S>, eom::Out<S> phi) {
    using std::sin;
    phi[0] = q[0] + 0.3 * sin(q[1]) + 0.2 * q[2] * q[2] - 0.5;
  }
  template <class S>
  static void generalized_forces(const S& t, eom::In<S> q, eom::In<S> qd, eom::In<S> u,
                                 eom::In<S> p, eom::Out<S> Q) {
    using std::abs, std::acos, std::asin, std::atan, std::atan2, std::cos, std::exp, std::hypot,
        std::log, std::pow, std::sin, std::sqrt, std::tan, std::tanh;
    // (V enters q̈ through its gradient only: the functions themselves appear here.)
    Q[0] = -p[2] * qd[0] + 0.1 * asin(0.4 * sin(q[1])) + 0.1 * acos(0.3 * cos(qd[2])) +
           0.1 * atan(0.5 * qd[0] + q[1]) + 0.05 * log(2.0 + q[0] * q[0]) + 0.05 * exp(0.2 * qd[1]) +
           0.05 * sqrt(1.5 + q[2] * q[2]) + 0.02 * tan(0.3 * q[0]) +
           0.05 * pow(1.5 + sin(q[0]), 2.5) + 0.05 * pow(1.5 + cos(q[1]), 0.5 + 0.1 * qd[0]) +
           0.05 * pow(S(2.0), 0.3 * q[1]) + u[0] * cos(2.0 * t) -
           0.08 * tanh(3.0 * qd[0]);  // smooth Coulomb friction
    Q[1] = -p[2] * qd[1] + 0.1 * atan2(q[0], 2.0 + q[1] * q[1]) + 0.1 * atan2(S(0.5), 2.0 + qd[2]) +
           0.1 * atan2(q[2] + 0.2 * qd[1], S(1.5)) + 0.05 * hypot(q[0], 1.0 + qd[1] * qd[1]) +
           0.05 * hypot(S(1.5), q[2]) + 0.05 * hypot(q[1], S(0.5)) + 0.1 * abs(q[1] - 0.2) +
           0.1 * abs(qd[0] + 3.0);
    Q[2] = -p[2] * qd[2] + 0.1 * eom::select(q[0] < q[1], q[0] * qd[1], sin(qd[0])) +
           0.1 * eom::select(q[2] < q[0], p[1], q[2] / (2.0 + q[0] * q[0])) + 0.05 * pow(q[1] + 2.0, -1.5) +
           0.05 * p[1] / (1.5 + q[0] * q[0]) + 0.02 * sin(t) * qd[2];
  }
};

}  // namespace eomtest
