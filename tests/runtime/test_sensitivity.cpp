// The state transition matrix Φ(t, t0) = ∂x(t)/∂x(t0) integrated by eom::Sensitivity through
// the integration API: against central differences of whole trajectories, and its determinant
// against Liouville's formula, over generated kernels and eom::Reference alike; the Taylor method
// over the reference against dop853. (∂x/∂p, eom::with_parameters, is tested in
// tests/parameter_derivatives/test_parameter_sensitivity.cpp, which has a generated model with
// the parameter kernel.)
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>

#include <eom/integration/integrate.hpp>
#include <eom/integration/sensitivity.hpp>
#include <eom/reference/reference.hpp>

#include <double_pendulum.hpp>
#include <spring_pendulum.hpp>

#include <models/double_pendulum.hpp>
#include <models/spring_pendulum.hpp>

namespace {

// Determinant by Gaussian elimination with partial pivoting (the test's own, small and plain).
template <std::size_t N> double determinant(std::array<double, N> a, int n) {
  double det = 1;
  for (int k = 0; k < n; ++k) {
    int piv = k;
    for (int i = k + 1; i < n; ++i)
      if (std::abs(a[i + n * k]) > std::abs(a[piv + n * k])) piv = i;
    if (piv != k) {
      det = -det;
      for (int j = 0; j < n; ++j) std::swap(a[k + n * j], a[piv + n * j]);
    }
    det *= a[k + n * k];
    for (int i = k + 1; i < n; ++i) {
      const double f = a[i + n * k] / a[k + n * k];
      for (int j = k; j < n; ++j) a[i + n * j] -= f * a[k + n * j];
    }
  }
  return det;
}

template <class K> eom::IntegrationResult<K::nq> run(double t1, const eom::StateOf<K::nq>& x0,
                                                     const double* p, double tol) {
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dopri5;
  opt.rtol = opt.atol = tol;
  return eom::integrate<K>(0, t1, x0, nullptr, p, opt);
}

// Φ against central differences: column j ≈ (x(t; x0 + δeⱼ) − x(t; x0 − δeⱼ)) / 2δ. With
// tolerance 1e-13 and δ = 1e-5 the difference quotient is good to ~1e-8 (truncation δ²·x''' and
// integration error tol/δ), far below Φ's entries (order 1–100).
template <class K, class Model> void check_against_differences(const eom::StateOf<K::nq>& x0, double t1) {
  using S = eom::Sensitivity<K>;
  constexpr int m = 2 * K::nq;
  const auto p = K::parameter_values;
  const auto r = run<S>(t1, S::start(x0), p.data(), 1e-12);
  ASSERT_EQ(r.status, eom::Status::ok);
  const auto phi = S::transition(r.x);
  double worst = 0, scale = 0;
  const double delta = 1e-5;
  for (int j = 0; j < m; ++j) {
    auto plus = x0, minus = x0;
    plus[j] += delta;
    minus[j] -= delta;
    const auto a = run<K>(t1, plus, p.data(), 1e-13), b = run<K>(t1, minus, p.data(), 1e-13);
    ASSERT_EQ(a.status, eom::Status::ok);
    ASSERT_EQ(b.status, eom::Status::ok);
    for (int i = 0; i < m; ++i) {
      const double fd = (a.x[i] - b.x[i]) / (2 * delta);
      worst = std::max(worst, std::abs(fd - phi[i + m * j]));
      scale = std::max(scale, std::abs(phi[i + m * j]));
    }
  }
  // The state itself is the plain run's.
  const auto plain = run<K>(t1, x0, p.data(), 1e-12);
  std::printf("  max |Φ − FD| = %.2e (max |Φ| = %.2e) at t = %g, %ld steps\n", worst, scale, t1,
              r.accepted);
  EXPECT_LT(worst, 1e-6 * scale);
  for (int i = 0; i < m; ++i) EXPECT_NEAR(S::state(r.x)[i], plain.x[i], 1e-8);
}

TEST(Sensitivity, SpringPendulumTransitionMatrixMatchesTrajectoryDifferences) {
  check_against_differences<spring_pendulum::Kernels, eom::models::SpringPendulum>(
      {0.55, 0.0, 0.01, 2.5}, 2.0);
}

TEST(Sensitivity, DoublePendulumTransitionMatrixMatchesTrajectoryDifferences) {
  // A short span: Φ grows fast on the chaotic start.
  check_against_differences<double_pendulum::Kernels, eom::models::DoublePendulum>(
      {2.0, 2.5, 0.0, 0.0}, 1.0);
}

// Liouville: the flow is volume-preserving in canonical coordinates (q, p = M(q) q̇), so in
// (q, q̇) det Φ(t) = det M(q(t0)) / det M(q(t)). Checked along the run for the undamped double
// pendulum, over generated kernels and over the reference.
template <class K> void check_liouville() {
  using S = eom::Sensitivity<K>;
  constexpr int n = K::nq, m = 2 * n;
  const auto p = K::parameter_values;
  const eom::StateOf<n> x0{2.0, 2.5, 0.0, 0.0};
  auto det_mass = [&](const double* q) {
    std::array<double, n * n> M;
    K::mass_matrix(q, p.data(), M.data());
    return determinant(M, n);
  };
  const double det_m0 = det_mass(x0.data());
  double worst = 0;
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dopri5;
  opt.rtol = opt.atol = 1e-12;
  const auto r = eom::integrate<S>(0, 3, S::start(x0), nullptr, p.data(), opt,
                                   [&](double, const eom::StateOf<S::nq>& y) {
                                     const auto x = S::state(y);
                                     const double want = det_m0 / det_mass(x.data());
                                     const double got = determinant(S::transition(y), m);
                                     worst = std::max(worst, std::abs(got / want - 1));
                                   });
  ASSERT_EQ(r.status, eom::Status::ok);
  std::printf("  max |det Φ · det M(q) / det M(q0) − 1| = %.2e over %ld steps\n", worst, r.accepted);
  // The determinant cancels Φ's growing entries to O(1): allow the tolerance times 1e3.
  EXPECT_LT(worst, 1e-9);
}

TEST(Sensitivity, LiouvilleFormulaHoldsForGeneratedKernels) { check_liouville<double_pendulum::Kernels>(); }
TEST(Sensitivity, LiouvilleFormulaHoldsForTheReference) {
  check_liouville<eom::Reference<eom::models::DoublePendulum>>();
}

// Φ through the Taylor method, offered over eom::Reference (the augmented coefficients come from
// the model run on jets): against dop853 on the same augmented model. Both at tolerance 1e-12 on
// the chaotic start with max |Φ| ~ 10 at t = 1: each within ~1e-11·max|Φ| of the truth, so the
// bound 1e-9·max|Φ| has margin while a wrong Taylor coefficient of Φ (an O(h^k) error per step
// instead of O(tol)) would exceed it. Over generated kernels there is no such kernel: a Status.
TEST(Sensitivity, TaylorOverTheReferenceMatchesDop853) {
  using S = eom::Sensitivity<eom::Reference<eom::models::DoublePendulum>>;
  const auto p = S::Base::parameter_values;
  const eom::StateOf<2> x0{2.0, 2.5, 0.0, 0.0};
  eom::IntegrationOptions opt;
  opt.rtol = opt.atol = 1e-12;
  opt.method = eom::Method::taylor;
  const auto a = eom::integrate<S>(0, 1, S::start(x0), nullptr, p.data(), opt);
  opt.method = eom::Method::dop853;
  const auto b = eom::integrate<S>(0, 1, S::start(x0), nullptr, p.data(), opt);
  ASSERT_EQ(a.status, eom::Status::ok);
  ASSERT_EQ(b.status, eom::Status::ok);
  const auto pa = S::transition(a.x), pb = S::transition(b.x);
  double worst = 0, scale = 0;
  for (std::size_t i = 0; i < pa.size(); ++i) {
    worst = std::max(worst, std::abs(pa[i] - pb[i]));
    scale = std::max(scale, std::abs(pb[i]));
  }
  std::printf("  max |Φ_taylor − Φ_dop853| = %.2e (max |Φ| = %.2e), %ld Taylor steps\n", worst,
              scale, a.accepted);
  EXPECT_LT(worst, 1e-9 * scale);

  using G = eom::Sensitivity<double_pendulum::Kernels>;
  opt.method = eom::Method::taylor;
  const auto g = eom::integrate<G>(0, 1, G::start(x0), nullptr, p.data(), opt);
  EXPECT_EQ(g.status, eom::Status::method_unavailable);
}

// Φ through the fixed-step method too: RK4 on the augmented model is RK4 on the state plus the
// exact linearization of the RK4 map (variational equations commute with Runge–Kutta methods),
// so the state part equals the plain RK4 run to round-off.
TEST(Sensitivity, Rk4StatePartEqualsThePlainRun) {
  using K = spring_pendulum::Kernels;
  using S = eom::Sensitivity<K>;
  const auto p = K::parameter_values;
  const eom::StateOf<2> x0{0.55, 0.0, 0.01, 2.5};
  eom::IntegrationOptions opt;
  opt.method = eom::Method::rk4;
  opt.step = 1e-3;
  const auto a = eom::integrate<S>(0, 1, S::start(x0), nullptr, p.data(), opt);
  const auto b = eom::integrate<K>(0, 1, x0, nullptr, p.data(), opt);
  ASSERT_EQ(a.status, eom::Status::ok);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(S::state(a.x)[i], b.x[i]);
}

}  // namespace
