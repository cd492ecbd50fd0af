// eom::Reference against hand-derived equations of motion, physical identities and finite
// differences. Error norm throughout: max-abs error over a kernel's output divided by the
// max-abs of the expected output ("relative error" below).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <span>

#include <eom/reference/reference.hpp>

#include "record.hpp"

#include <models/cartesian_pendulum.hpp>
#include <models/spring_pendulum.hpp>

namespace {

using eom::models::CartesianPendulum;
using eom::models::SpringPendulum;
using SP = eom::Reference<SpringPendulum>;
using CP = eom::Reference<CartesianPendulum>;

double relative_error(std::span<const double> got, std::span<const double> want) {
  double err = 0, scale = 0;
  for (std::size_t i = 0; i < want.size(); ++i) {
    err = std::max(err, std::abs(got[i] - want[i]));
    scale = std::max(scale, std::abs(want[i]));
  }
  return scale > 0 ? err / scale : err;
}

// Hand-derived spring pendulum (eqs. 29-30), state (r, θ, ṙ, θ̇), parameters (m, k, r0, g).
struct SpringPendulumByHand {
  double r, th, rd, thd, m, k, r0, g;
  std::array<double, 4> M() const { return {m, 0, 0, m * r * r}; }
  std::array<double, 4> Mdot() const { return {0, 0, 0, 2 * m * r * rd}; }
  std::array<double, 2> c() const { return {-m * r * thd * thd, 2 * m * r * rd * thd}; }
  std::array<double, 2> dVdq() const { return {k * (r - r0) - m * g * std::cos(th), m * g * r * std::sin(th)}; }
  std::array<double, 2> qdd() const {
    return {r * thd * thd - k / m * (r - r0) + g * std::cos(th), (-2 * rd * thd - g * std::sin(th)) / r};
  }
  double T() const { return 0.5 * m * (rd * rd + r * r * thd * thd); }
  double V() const { return 0.5 * k * (r - r0) * (r - r0) + m * g * (r0 - r * std::cos(th)); }
};

TEST(ReferenceSpringPendulum, MatchesHandDerivedEquationsAtRandomStates) {
  std::mt19937_64 rng(20261121);
  std::uniform_real_distribution<double> U(-1, 1);
  double worst = 0;
  for (int n = 0; n < 200; ++n) {
    const SpringPendulumByHand h{0.3 + 0.5 * (U(rng) + 1), 3.0 * U(rng), 2.0 * U(rng), 4.0 * U(rng),
                                1.0 + 0.5 * U(rng), 75.0 + 20 * U(rng), 0.5 + 0.1 * U(rng), 9.81};
    const double q[2] = {h.r, h.th}, qd[2] = {h.rd, h.thd}, p[4] = {h.m, h.k, h.r0, h.g};
    std::array<double, 4> M, Md;
    std::array<double, 2> c, dV, qdd, Q;
    SP::mass_matrix(q, p, M.data());
    SP::mass_matrix_dot(q, qd, p, Md.data());
    SP::coriolis(q, qd, p, c.data());
    SP::potential_gradient(q, p, dV.data());
    SP::generalized_forces(0.0, q, qd, nullptr, p, Q.data());
    ASSERT_TRUE(SP::forward_dynamics(0.0, q, qd, nullptr, p, qdd.data()));
    const double errs[] = {relative_error(M, h.M()),        relative_error(Md, h.Mdot()),
                           relative_error(c, h.c()),        relative_error(dV, h.dVdq()),
                           relative_error(qdd, h.qdd()),
                           std::abs(SP::kinetic_energy(q, qd, p) - h.T()) / h.T(),
                           std::abs(SP::potential_energy(q, p) - h.V()) / std::abs(h.V())};
    for (double e : errs) {
      EXPECT_LE(e, 1e-13);
      worst = std::max(worst, e);
    }
    EXPECT_EQ(Q[0], 0.0);
    EXPECT_EQ(Q[1], 0.0);
  }
  record_figure("worst_relative_error", worst);
}

// Physics, not only numbers (docs/CONTRACT.md §2 and the physics checks): M symmetric positive definite, q̇ᵀc = ½ q̇ᵀṀq̇ for a
// natural system, and inverse_dynamics(forward_dynamics(x)) = 0 without applied forces.
TEST(ReferenceSpringPendulum, PhysicalIdentities) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  const auto p = SP::parameter_values;
  for (int n = 0; n < 100; ++n) {
    const double q[2] = {0.6 + 0.3 * U(rng), 3 * U(rng)}, qd[2] = {U(rng), 3 * U(rng)};
    double M[4], Md[4], c[2], qdd[2], tau[2];
    SP::mass_matrix(q, p.data(), M);
    SP::mass_matrix_dot(q, qd, p.data(), Md);
    SP::coriolis(q, qd, p.data(), c);
    EXPECT_EQ(M[1], M[2]);
    EXPECT_GT(M[0], 0);
    EXPECT_GT(M[0] * M[3] - M[1] * M[2], 0);
    const double qc = qd[0] * c[0] + qd[1] * c[1];
    double qMq = 0;
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) qMq += qd[i] * Md[i + 2 * j] * qd[j];
    EXPECT_NEAR(qc, 0.5 * qMq, 1e-13 * (1 + std::abs(qc)));
    ASSERT_TRUE(SP::forward_dynamics(0, q, qd, nullptr, p.data(), qdd));
    SP::inverse_dynamics(0, q, qd, qdd, nullptr, p.data(), tau);
    EXPECT_NEAR(tau[0], 0, 1e-12);
    EXPECT_NEAR(tau[1], 0, 1e-12);
  }
}

TEST(ReferenceSpringPendulum, DynamicsDerivativesMatchCentralDifferences) {
  const auto p = SP::parameter_values;
  const double q[2] = {0.61, 0.7}, qd[2] = {0.3, -1.9};
  double Aq[4], Aqd[4];
  ASSERT_TRUE(SP::forward_dynamics_derivatives(0, q, qd, nullptr, p.data(), Aq, Aqd, nullptr));
  const double h = 1e-5;
  for (int j = 0; j < 2; ++j) {
    for (int which = 0; which < 2; ++which) {
      double qp[2] = {q[0], q[1]}, qm[2] = {q[0], q[1]}, vp[2] = {qd[0], qd[1]}, vm[2] = {qd[0], qd[1]};
      (which == 0 ? qp : vp)[j] += h;
      (which == 0 ? qm : vm)[j] -= h;
      double ap[2], am[2];
      ASSERT_TRUE(SP::forward_dynamics(0, qp, vp, nullptr, p.data(), ap));
      ASSERT_TRUE(SP::forward_dynamics(0, qm, vm, nullptr, p.data(), am));
      for (int i = 0; i < 2; ++i) {
        const double fd = (ap[i] - am[i]) / (2 * h);
        const double ad = (which == 0 ? Aq : Aqd)[i + 2 * j];
        EXPECT_NEAR(ad, fd, 1e-8 * (1 + std::abs(fd))) << "i=" << i << " j=" << j << " wrt " << which;
      }
    }
  }
}

TEST(ReferenceSpringPendulum, RejectsNonFiniteInputAndSingularMass) {
  const auto p = SP::parameter_values;
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  double qdd[2];
  const double good_q[2] = {0.55, 0.1}, good_qd[2] = {0.01, 2.5};
  const double bad_values[] = {nan, inf, -inf};
  for (double bad : bad_values) {
    for (int slot = 0; slot < 5; ++slot) {
      double q[2] = {good_q[0], good_q[1]}, qd[2] = {good_qd[0], good_qd[1]};
      std::array<double, 4> pp = p;
      double t = 0;
      if (slot == 0) q[1] = bad;
      if (slot == 1) qd[0] = bad;
      if (slot == 2) pp[1] = bad;
      if (slot == 3) t = bad;
      if (slot == 4) q[0] = bad;
      qdd[0] = qdd[1] = 123.0;
      EXPECT_FALSE(SP::forward_dynamics(t, q, qd, nullptr, pp.data(), qdd)) << "slot " << slot;
      EXPECT_TRUE(std::isnan(qdd[0]) && std::isnan(qdd[1])) << "no result-like garbage";
    }
  }
  // r = 0: M = diag(m, 0) is singular.
  const double q0[2] = {0.0, 0.3};
  EXPECT_FALSE(SP::forward_dynamics(0, q0, good_qd, nullptr, p.data(), qdd));
  EXPECT_TRUE(std::isnan(qdd[0]) && std::isnan(qdd[1]));
}

// Cartesian pendulum: at angle θ from the downward vertical with angular rate ω, the mass moves
// on the circle with acceleration −lω² r̂ − g sin θ t̂ (r̂ = (sin θ, −cos θ), t̂ = (cos θ, sin θ))
// and the rod tension is m (l ω² + g cos θ). With φ = x² + y² − l², C = (2x, 2y) and the
// constraint force −Cᵀμ, the tension is 2 μ l.
TEST(ReferenceCartesianPendulum, MatchesClosedFormAccelerationAndTension) {
  const auto p = CP::parameter_values;
  const double m = p[0], l = p[1], g = p[2];
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int n = 0; n < 200; ++n) {
    const double th = 3.1 * U(rng), w = 4 * U(rng);
    const double s = std::sin(th), c = std::cos(th);
    const double q[2] = {l * s, -l * c}, qd[2] = {l * w * c, l * w * s};
    double qdd[2];
    ASSERT_TRUE(CP::forward_dynamics(0, q, qd, nullptr, p.data(), qdd));
    const double want[2] = {-l * w * w * s - g * s * c, l * w * w * c - g * s * s};
    EXPECT_LE(relative_error(qdd, want), 1e-13) << "theta=" << th << " omega=" << w;

    // C and γ by hand, then μ from the range-space solve: tension = 2 μ l.
    double C[2], gamma[1], phi[1];
    CP::constraint_residual(q, p.data(), phi);
    CP::constraint_jacobian(q, p.data(), C);
    CP::constraint_bias(q, qd, p.data(), gamma);
    EXPECT_NEAR(phi[0], 0, 1e-15);
    EXPECT_LE(relative_error(C, std::array{2 * q[0], 2 * q[1]}), 1e-15);
    EXPECT_NEAR(gamma[0], 2 * (qd[0] * qd[0] + qd[1] * qd[1]), 1e-13 * (1 + gamma[0]));
    std::array<double, 4> M;
    std::array<double, 2> cvec, dV, f;
    CP::mass_matrix(q, p.data(), M.data());
    CP::coriolis(q, qd, p.data(), cvec.data());
    CP::potential_gradient(q, p.data(), dV.data());
    for (int i = 0; i < 2; ++i) f[i] = -cvec[i] - dV[i];
    double qdd2[2], mu[1];
    ASSERT_TRUE((eom::linalg::solve_constrained<double, 2, 1>(M, f, std::array{C[0], C[1]},
                                                             std::array{gamma[0]}, qdd2, mu)));
    const double tension = m * (l * w * w + g * c);
    EXPECT_NEAR(2 * mu[0] * l, tension, 1e-13 * (1 + std::abs(tension)));
    EXPECT_NEAR(C[0] * qdd[0] + C[1] * qdd[1], -gamma[0], 1e-12 * (1 + gamma[0]));
  }
}

TEST(ReferenceCartesianPendulum, SingularSchurComplementReturnsFalse) {
  // At the origin C = 0, so C M⁻¹ Cᵀ = 0: no constraint force can be found.
  const auto p = CP::parameter_values;
  const double q[2] = {0, 0}, qd[2] = {0, 0};
  double qdd[2] = {1, 1};
  EXPECT_FALSE(CP::forward_dynamics(0, q, qd, nullptr, p.data(), qdd));
  EXPECT_TRUE(std::isnan(qdd[0]) && std::isnan(qdd[1]));
}

TEST(ReferenceModelInfo, SizesAndNames) {
  static_assert(SP::nq == 2 && SP::np == 4 && SP::nu == 0 && SP::nc == 0);
  static_assert(CP::nq == 2 && CP::np == 3 && CP::nu == 0 && CP::nc == 1);
  static_assert(SP::parameter_names[2] == "r0");
  static_assert(SP::parameter_values[1] == 75.0);
  static_assert(eom::Dynamics<SP> && eom::Dynamics<CP>);
}

}  // namespace
