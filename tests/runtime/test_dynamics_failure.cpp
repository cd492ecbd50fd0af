// Why the dynamics failed (eom/model/diagnosis.hpp): eom::integrate reports an indefinite mass matrix
// apart from a singular one (Status::singular_dynamics with IntegrationResult::failure and the
// failing pivot's velocity), and diagnose_dynamics classifies each failure of forward_dynamics.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <span>

#include <eom/ensemble/ensemble.hpp>
#include <eom/integration/integrate.hpp>
#include <eom/model/diagnosis.hpp>
#include <eom/reference/reference.hpp>

#include "not_positive_definite.hpp"  // tests/consumer/bad: Degenerate

namespace {

// T = ½ ẋ² + ½ (a − x) ẏ², V = 0: from (x, y) = (0, 0), (ẋ, ẏ) = (1, 0) the motion is x = t,
// y = 0 exactly (ÿ = 0 as ẏ = 0, and ∂T/∂x = −½ ẏ² = 0), so M = diag(1, a − t) is positive
// definite until t = a, then indefinite: a parameter (a length, a mass) that a state makes
// negative. The second pivot, velocity 1 (y), is the one that fails.
struct Shrinking {
  static constexpr std::array coordinates{"x", "y"};
  static constexpr std::array parameters{"a"};
  static constexpr std::array parameter_values{0.53};
  template <class S> static S kinetic_energy(eom::In<S> q, eom::In<S> qd, eom::In<S> p) {
    return 0.5 * qd[0] * qd[0] + 0.5 * (p[0] - q[0]) * qd[1] * qd[1];
  }
  template <class S> static S potential_energy(eom::In<S>, eom::In<S>) { return S(0); }
};
using K = eom::Reference<Shrinking>;

TEST(DynamicsFailure, IntegrateReportsAnIndefiniteMassMatrix) {
  const double a = 0.53;
  const eom::StateOf<2> x0{0.0, 0.0, 1.0, 0.0};
  for (eom::Method method : {eom::Method::rk4, eom::Method::dopri5, eom::Method::dop853}) {
    eom::IntegrationOptions opt;
    opt.method = method;
    opt.step = 0.1;  // rk4: the step from t = 0.5 evaluates at x = 0.55 > a
    const auto r = eom::integrate<K>(0.0, 2.0, x0, nullptr, &a, opt);
    // rk4 stops at the failing stage; the adaptive methods retry smaller down to underflow.
    EXPECT_EQ(r.status, method == eom::Method::rk4 ? eom::Status::singular_dynamics
                                                   : eom::Status::step_size_underflow)
        << eom::to_string(r.status);
    EXPECT_EQ(r.failure, eom::DynamicsFailure::indefinite_mass_matrix) << eom::to_string(r.failure);
    EXPECT_EQ(r.failure_velocity, 1);
    EXPECT_LE(r.t, a);  // the last good state is before M fails
    EXPECT_GT(r.t, 0.3);
  }
}

// An ensemble's cases carry the diagnosis too, with inputs held (each case one eom::integrate)
// and from a callback (each input period its own eom::integrate, the results joined).
TEST(DynamicsFailure, EnsembleCasesCarryTheDiagnosis) {
  const std::array<double, 2> a{0.53, 10.0};  // case 0 fails at t = 0.53, case 1 never
  const std::array<eom::StateOf<2>, 2> x0{{{0.0, 0.0, 1.0, 0.0}, {0.0, 0.0, 1.0, 0.0}}};
  eom::EnsembleOptions opt;
  opt.t0 = 0.0, opt.t1 = 2.0;
  opt.integration.method = eom::Method::rk4;
  opt.integration.step = 0.1;
  const eom::EnsembleCasesFor<K> cases{x0, a, {}};
  opt.input_period = 0.25;  // the callback's periods: the failure falls in the third
  const auto held = eom::ensemble<K>(cases, opt);
  const auto called = eom::ensemble_with_inputs<K>(
      cases, opt, [](std::size_t, double, const eom::StateOf<2>&, std::span<double>) {});
  for (const auto* r : {&held, &called}) {
    ASSERT_EQ(r->status, eom::Status::ok);
    ASSERT_EQ(r->cases.size(), 2u);
    EXPECT_EQ(r->cases[0].status, eom::Status::singular_dynamics);
    EXPECT_EQ(r->cases[0].failure, eom::DynamicsFailure::indefinite_mass_matrix)
        << eom::to_string(r->cases[0].failure);
    EXPECT_EQ(r->cases[0].failure_velocity, 1);
    EXPECT_EQ(r->cases[1].status, eom::Status::ok);
    EXPECT_EQ(r->cases[1].failure, eom::DynamicsFailure::none);
  }
}

TEST(DynamicsFailure, NoFailureNoDiagnosis) {
  const double a = 10.0;  // M stays positive definite on [0, 2]
  const eom::StateOf<2> x0{0.0, 0.0, 1.0, 0.0};
  eom::IntegrationOptions opt;
  const auto r = eom::integrate<K>(0.0, 2.0, x0, nullptr, &a, opt);
  EXPECT_EQ(r.status, eom::Status::ok);
  EXPECT_EQ(r.failure, eom::DynamicsFailure::none);
  EXPECT_EQ(r.failure_velocity, -1);
}

// Degenerate: T = ½ m (ẋ + ẏ)² + ½ b ẏ², singular at b = 0 (and to rounding at b = 1e-17, where
// m + b rounds to m), indefinite at b < 0; the first pivot m is fine, the second is b.
TEST(DynamicsFailure, DiagnosisTellsSingularFromIndefinite) {
  using C = eom::Reference<Degenerate>;
  const double q[] = {0.1, 0.2}, qd[] = {0.3, -0.4};
  double qdd[2];
  for (double b : {0.0, 1e-17, -0.5}) {
    const double p[] = {1.0, b};
    ASSERT_FALSE(C::forward_dynamics(0, q, qd, nullptr, p, qdd)) << b;
    const auto d = eom::diagnose_dynamics<C>(0.0, q, qd, nullptr, p);
    EXPECT_EQ(d.failure, b < 0 ? eom::DynamicsFailure::indefinite_mass_matrix
                               : eom::DynamicsFailure::singular_mass_matrix)
        << "b = " << b << ": " << eom::to_string(d.failure);
    EXPECT_EQ(d.velocity, 1);
  }
  const double nan = std::numeric_limits<double>::quiet_NaN(), p[] = {1.0, 1.0};
  const double qn[] = {nan, 0.2};
  EXPECT_EQ(eom::diagnose_dynamics<C>(0.0, qn, qd, nullptr, p).failure,
            eom::DynamicsFailure::non_finite_input);
}

}  // namespace
