// ∂q̈/∂p, the kernel forward_dynamics_parameter_derivatives (generated only when KERNELS names it).
//
// 1. eom::Reference<Model> against central differences of forward_dynamics in p, computed in
//    double-double (eom::Reference<Model, dd_real>) so that neither the difference's rounding
//    (~1e-32 / h) nor its truncation (h² |∂³q̈/∂p³| / 6 with h = 1e-8 |p|) reaches 1e-15.
// 2. The generated kernels (tests/parameter_derivatives/CMakeLists.txt) against eom::Reference at
//    200 random states, with the error norm of tests/kernels:
//        e = max_i |generated_i − reference_i| / max(1, max_i |reference_i|) ≤ 1e-12.
// 3. False with every output NaN exactly when forward_dynamics fails.
// 4. FIXED_PARAMETERS: np counts the free parameters only, and the columns are theirs.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <bundled_models.hpp>  // the cases: sampling, singular configurations

#include <pd_cartesian_pendulum.hpp>
#include <pd_closed_chain5.hpp>
#include <pd_double_pendulum.hpp>
#include <pd_double_pendulum_fixed.hpp>

#include <eom/model/kernels.hpp>
#include <eom/reference/reference.hpp>

#include "kernel_error.hpp"

namespace {

using namespace eom_cases;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

static_assert(eom::HasForwardDynamicsParameterDerivatives<pd_double_pendulum::Kernels>);
static_assert(eom::HasForwardDynamicsParameterDerivatives<eom::Reference<eom::models::ClosedChain5>>);
static_assert(eom::has_kernel<pd_cartesian_pendulum::Kernels,
                              eom::Kernel::forward_dynamics_parameter_derivatives>);
// Not in the default set: the bundled models' kernels do not have it.
static_assert(!eom::HasForwardDynamicsParameterDerivatives<double_pendulum::Kernels>);
static_assert(!eom::HasForwardDynamicsParameterDerivatives<closed_chain5::Kernels>);
static_assert(std::is_same_v<eom::RequireKernels<pd_closed_chain5::Kernels,
                                                 eom::Kernel::forward_dynamics_parameter_derivatives>,
                             pd_closed_chain5::Kernels>);


using eomtest::kernel_error;

bool all_nan(const double* x, int n) {
  return std::all_of(x, x + n, [](double v) { return std::isnan(v); });
}

// ---- 1. Reference against double-double central differences ---------------------------------

template <class Case> void reference_against_differences(int states, double& worst) {
  using Ref = typename Case::Ref;
  using Wide = eom::Reference<typename Ref::model_type, dd_real>;
  constexpr int nq = Ref::nq, np = Ref::np, nu = Ref::nu;
  for (const auto& s : random_samples<Case>(states, 7717)) {
    std::array<double, nq * np> ad;
    ASSERT_TRUE(Ref::forward_dynamics_parameter_derivatives(s.t, s.q.data(), s.qd.data(), s.up(),
                                                            s.p.data(), ad.data()));
    std::array<dd_real, nq> qw, qdw, plus, minus;
    std::array<dd_real, nu> uw;
    std::array<dd_real, np> pw;
    for (int i = 0; i < nq; ++i) qw[i] = dd_real(s.q[i]), qdw[i] = dd_real(s.qd[i]);
    for (int i = 0; i < nu; ++i) uw[i] = dd_real(s.u[i]);
    std::array<double, nq * np> fd;
    for (int k = 0; k < np; ++k) {
      for (int i = 0; i < np; ++i) pw[i] = dd_real(s.p[i]);
      const dd_real h = dd_real(1e-8 * std::max(1.0, std::abs(s.p[k])));
      pw[k] = dd_real(s.p[k]) + h;
      ASSERT_TRUE(Wide::forward_dynamics(dd_real(s.t), qw.data(), qdw.data(),
                                         nu ? uw.data() : nullptr, pw.data(), plus.data()));
      pw[k] = dd_real(s.p[k]) - h;
      ASSERT_TRUE(Wide::forward_dynamics(dd_real(s.t), qw.data(), qdw.data(),
                                         nu ? uw.data() : nullptr, pw.data(), minus.data()));
      for (int i = 0; i < nq; ++i) fd[i + nq * k] = to_double((plus[i] - minus[i]) / (2.0 * h));
    }
    worst = std::max(worst, kernel_error(ad.data(), fd.data(), nq * np));
  }
}

// Bound: the AD derivative is a double evaluation of the differentiated solve; its round-off is
// a few eps times the condition number of M (and of C M⁻¹Cᵀ) at the sampled states, which is
// modest for these samplers (measured worst 7.7e-15, printed). 1e-12, the bound of tests/kernels,
// is far above that and far below what a wrong term in the differentiated solve would give.
constexpr double kReferenceTolerance = 1e-12;

template <class Case> void check_reference(int states) {
  double worst = 0;
  reference_against_differences<Case>(states, worst);
  std::printf("%s: Reference dqdd/dp vs dd_real central differences, max e = %.2e\n", Case::name,
              worst);
  EXPECT_LE(worst, kReferenceTolerance) << Case::name;
}

TEST(ReferenceParameterDerivatives, SpringPendulum) { check_reference<SpringPendulumCase>(40); }
TEST(ReferenceParameterDerivatives, DoublePendulum) { check_reference<DoublePendulumCase>(40); }
TEST(ReferenceParameterDerivatives, CartesianPendulum) {
  check_reference<CartesianPendulumCase>(40);
}
TEST(ReferenceParameterDerivatives, ClosedChain5) { check_reference<ClosedChain5Case>(10); }

// ---- 2. generated against Reference ----------------------------------------------------------

constexpr int kSamples = 200;
constexpr double kTolerance = 1e-12;  // as tests/kernels

template <class Case, class Gen> void check_generated() {
  using Ref = typename Case::Ref;
  constexpr int nq = Ref::nq, np = Ref::np;
  static_assert(Gen::nq == nq && Gen::np == np && Gen::nu == Ref::nu && Gen::nc == Ref::nc);
  double worst = 0;
  {
    for (const auto& s : random_samples<Case>(kSamples, 20041)) {
      std::array<double, nq * np> g, r;
      std::array<double, nq> qdd;
      const bool ok_g = Gen::forward_dynamics_parameter_derivatives(
          s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), g.data());
      const bool ok_r = Ref::forward_dynamics_parameter_derivatives(
          s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), r.data());
      const bool ok_f = Gen::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(),
                                              qdd.data());
      ASSERT_TRUE(ok_g && ok_r && ok_f);
      worst = std::max(worst, kernel_error(g.data(), r.data(), nq * np));
    }
  }
  std::printf("%s: generated dqdd/dp vs Reference, max e = %.2e over %d states\n", Case::name,
              worst, kSamples);
  EXPECT_LE(worst, kTolerance) << Case::name;
}

TEST(GeneratedParameterDerivatives, DoublePendulum) {
  check_generated<DoublePendulumCase, pd_double_pendulum::Kernels>();
}
TEST(GeneratedParameterDerivatives, CartesianPendulum) {
  check_generated<CartesianPendulumCase, pd_cartesian_pendulum::Kernels>();
}
TEST(GeneratedParameterDerivatives, ClosedChain5) {
  check_generated<ClosedChain5Case, pd_closed_chain5::Kernels>();
}

// ---- 3. failure: false and NaN exactly when forward_dynamics fails ----------------------------

template <class K, int nq, int np>
void expect_failure(const double* q, const double* qd, const double* u, const double* p) {
  std::array<double, nq * np> d;
  std::array<double, nq> qdd;
  d.fill(0.0);
  EXPECT_FALSE(K::forward_dynamics(0.0, q, qd, u, p, qdd.data()));
  EXPECT_FALSE(K::forward_dynamics_parameter_derivatives(0.0, q, qd, u, p, d.data()));
  EXPECT_TRUE(all_nan(d.data(), nq * np));
}

TEST(ParameterDerivativesFailure, SingularConfigurations) {
  using CP = CartesianPendulumCase;  // C = 0 at the origin
  const std::array<double, 2> v{0.3, -0.2};
  const auto p_cp = CP::Ref::parameter_values;
  expect_failure<pd_cartesian_pendulum::Kernels, 2, 3>(CP::singular_q.data(), v.data(), nullptr,
                                                       p_cp.data());
  expect_failure<CP::Ref, 2, 3>(CP::singular_q.data(), v.data(), nullptr, p_cp.data());

  // Double pendulum without mass: M = 0.
  auto p_dp = DoublePendulumCase::Ref::parameter_values;
  p_dp[0] = p_dp[1] = 0.0;
  const std::array<double, 2> q{0.4, 1.0};
  expect_failure<pd_double_pendulum::Kernels, 2, 5>(q.data(), v.data(), nullptr, p_dp.data());
  expect_failure<DoublePendulumCase::Ref, 2, 5>(q.data(), v.data(), nullptr, p_dp.data());

  // Closed chain, all links horizontal: C M⁻¹Cᵀ singular.
  using CC = ClosedChain5Case;
  const std::array<double, 5> w{0.1, -0.2, 0.3, 0.0, 0.5};
  const auto p_cc = CC::Ref::parameter_values;
  {
    expect_failure<pd_closed_chain5::Kernels, 5, 26>(CC::singular_q.data(), w.data(), nullptr,
                                                     p_cc.data());
    expect_failure<CC::Ref, 5, 26>(CC::singular_q.data(), w.data(), nullptr, p_cc.data());
  }
}

TEST(ParameterDerivativesFailure, NonFiniteInputs) {
  const std::array<double, 2> q{0.4, 1.0}, v{0.3, -0.2};
  for (double bad : {kNaN, kInf}) {
    auto p = DoublePendulumCase::Ref::parameter_values;
    p[2] = bad;
    expect_failure<pd_double_pendulum::Kernels, 2, 5>(q.data(), v.data(), nullptr, p.data());
    expect_failure<DoublePendulumCase::Ref, 2, 5>(q.data(), v.data(), nullptr, p.data());
    const auto p_ok = DoublePendulumCase::Ref::parameter_values;
    const std::array<double, 2> q_bad{bad, 1.0};
    expect_failure<pd_double_pendulum::Kernels, 2, 5>(q_bad.data(), v.data(), nullptr, p_ok.data());
    expect_failure<DoublePendulumCase::Ref, 2, 5>(q_bad.data(), v.data(), nullptr, p_ok.data());
  }
}

// ---- 4. FIXED_PARAMETERS removes columns ------------------------------------------------------

TEST(ParameterDerivativesFixed, ColumnsOfTheFreeParametersOnly) {
  using Fixed = pd_double_pendulum_fixed::Kernels;
  using Ref = DoublePendulumCase::Ref;
  static_assert(Fixed::np == 3);
  ASSERT_EQ(Fixed::parameter_names[0], "m1");
  ASSERT_EQ(Fixed::parameter_names[1], "m2");
  ASSERT_EQ(Fixed::parameter_names[2], "l2");
  constexpr int free_index[3] = {0, 1, 3};  // m1, m2, l2 in the model's p; l1 = 1, g = 9.81 fixed
  double worst = 0;
  for (const auto& s : random_samples<DoublePendulumCase>(kSamples, 99)) {
    std::array<double, 5> p_all = s.p;
    p_all[2] = 1.0;
    p_all[4] = 9.81;
    const std::array<double, 3> p_free{p_all[0], p_all[1], p_all[3]};
    std::array<double, 2 * 3> g;
    std::array<double, 2 * 5> r;
    ASSERT_TRUE(Fixed::forward_dynamics_parameter_derivatives(s.t, s.q.data(), s.qd.data(),
                                                              nullptr, p_free.data(), g.data()));
    ASSERT_TRUE(Ref::forward_dynamics_parameter_derivatives(s.t, s.q.data(), s.qd.data(), nullptr,
                                                            p_all.data(), r.data()));
    std::array<double, 2 * 3> r_free;
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 2; ++i) r_free[i + 2 * k] = r[i + 2 * free_index[k]];
    worst = std::max(worst, kernel_error(g.data(), r_free.data(), 6));
  }
  std::printf("double_pendulum (l1, g fixed): generated dqdd/dp vs Reference columns, max e = "
              "%.2e\n", worst);
  EXPECT_LE(worst, kTolerance);
}

}  // namespace
