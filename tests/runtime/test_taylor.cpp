// Taylor series integration: the Taylor-coefficient kernel of eom::Reference (order 1 is the
// forward dynamics, closed forms, hand-derived third derivatives, constraint series, the wide
// type), then the integrators of eom/integration/taylor.hpp: measured convergence orders of the fixed-step
// variant, achieved error against tolerance for both adaptive schemes, the chaotic double
// pendulum against the double-double reference, dense output, constraints, bad input and
// failures.
#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <vector>

#include <eom/integration/high_precision.hpp>
#include <eom/integration/taylor.hpp>
#include <eom/numeric/jet.hpp>
#include <eom/reference/reference.hpp>

#include <double_pendulum.hpp>
#include <models/cartesian_pendulum.hpp>
#include <models/double_pendulum.hpp>
#include <models/spring_pendulum.hpp>
#include "record.hpp"

namespace test_models {

// m ẍ + k x = F cos(Ω t): the entire solution x = A cos ωt + B sin ωt + C cos Ωt (ω² = k/m,
// C = F/(m (ω² − Ω²))) gives every Taylor coefficient in closed form, and the time-dependent
// force exercises the advancing t of the Taylor kernel.
struct ForcedOscillator {
  static constexpr std::array coordinates{"x"};
  static constexpr std::array parameters{"m", "k", "F", "Omega"};
  static constexpr std::array parameter_values{2.0, 8.0, 1.5, 1.3};  // ω = 2
  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S> p) {
    return 0.5 * p[0] * qd[0] * qd[0];
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    return 0.5 * p[1] * q[0] * q[0];
  }
  template <class S>
  static void generalized_forces(const S& t, eom::In<S>, eom::In<S>, eom::In<S>, eom::In<S> p,
                                 eom::Out<S> Q) {
    using std::cos;
    Q[0] = p[2] * cos(p[3] * t);
  }
};

// ẍ = 4x³ (V = −x⁴): from x = 1 at rest the solution reaches infinity at a finite time.
struct BlowUp {
  static constexpr std::array coordinates{"x"};
  static constexpr std::array parameters{"m"};
  static constexpr std::array parameter_values{1.0};
  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S> p) {
    return 0.5 * p[0] * qd[0] * qd[0];
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S>) {
    return -(q[0] * q[0]) * (q[0] * q[0]);
  }
};

}  // namespace test_models

namespace {

using SP = eom::Reference<eom::models::SpringPendulum>;
using DPRef = eom::Reference<eom::models::DoublePendulum>;
using CP = eom::Reference<eom::models::CartesianPendulum>;
using Osc = eom::Reference<test_models::ForcedOscillator>;
using Scheme = eom::TaylorOptions::Scheme;

// The generated double pendulum once it offers the Taylor kernel, the reference until then.
using DPKernels = std::conditional_t<eom::TaylorDynamics<double_pendulum::Kernels>,
                                     double_pendulum::Kernels, DPRef>;

constexpr eom::StateOf<2> sp_x0{0.55, 0.0, 0.01, 2.5};
constexpr eom::StateOf<2> dp_x0{2.0, 2.5, 0.0, 0.0};
auto none = [](double, const auto&) {};

double max_difference(const eom::StateOf<2>& a, const eom::StateOf<2>& b) {
  double e = 0;
  for (int i = 0; i < 4; ++i) e = std::max(e, std::abs(a[i] - b[i]));
  return e;
}

// The state of a two-coordinate bundled model at the given times, from the double-double
// Gragg–Bulirsch–Stoer reference (tolerance 1e-28 per step).
template <class Model>
std::vector<eom::StateOf<2>> wide_reference(const eom::StateOf<2>& x0, std::vector<double> times) {
  constexpr int np = eom::ModelInfo<Model>::np;
  std::array<dd_real, 4> xw;
  std::array<dd_real, np> pw;
  for (int i = 0; i < 4; ++i) xw[i] = dd_real(x0[i]);
  for (int i = 0; i < np; ++i) pw[i] = dd_real(Model::parameter_values[i]);
  std::vector<eom::StateOf<2>> out;
  eom::ExtrapolationOptions opt;
  opt.tolerance = 1e-28;
  const auto r = eom::extrapolate<Model, dd_real>(0.0, xw, times, nullptr, pw.data(), opt,
                                                  [&](double, const std::array<dd_real, 4>& x) {
                                                    eom::StateOf<2> v;
                                                    for (int i = 0; i < 4; ++i) v[i] = to_double(x[i]);
                                                    out.push_back(v);
                                                  });
  EXPECT_EQ(r.status, eom::Status::ok);
  return out;
}

// Least-squares slope of log10(err) against log10(tol).
double log_slope(const std::vector<double>& tol, const std::vector<double>& err) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = static_cast<double>(tol.size());
  for (std::size_t i = 0; i < tol.size(); ++i) {
    const double x = std::log10(tol[i]), y = std::log10(err[i]);
    sx += x, sy += y, sxx += x * x, sxy += x * y;
  }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

// ---- the Taylor-coefficient kernel of eom::Reference ----------------------------------------

constexpr int max_order = SP::taylor_max_order;
static_assert(max_order == 32 && SP::taylor_workspace == 0);
static_assert(eom::TaylorDynamics<SP> && eom::TaylorDynamics<CP> && eom::TaylorDynamics<Osc>);

template <class K>
void expect_order_one_is_forward_dynamics(const double* q, const double* qd) {
  constexpr int nq = K::nq;
  std::array<double, 2 * nq> qk, qdk;
  std::array<double, nq> qdd;
  const auto p = K::parameter_values;
  ASSERT_TRUE(K::taylor_coefficients(1, 0.4, q, qd, nullptr, p.data(), qk.data(), qdk.data(), nullptr));
  ASSERT_TRUE(K::forward_dynamics(0.4, q, qd, nullptr, p.data(), qdd.data()));
  for (int i = 0; i < nq; ++i) {
    EXPECT_EQ(qk[i], q[i]);
    EXPECT_EQ(qdk[i], qd[i]);
    EXPECT_EQ(qk[nq + i], qd[i]);
    EXPECT_NEAR(qdk[nq + i], qdd[i], 4 * std::numeric_limits<double>::epsilon() * std::abs(qdd[i]));
  }
}

TEST(TaylorKernel, OrderOneIsTheForwardDynamics) {
  const double q[] = {0.61, 0.7}, qd[] = {0.3, -1.9};
  expect_order_one_is_forward_dynamics<SP>(q, qd);
  expect_order_one_is_forward_dynamics<DPRef>(q, qd);
  const double x[] = {0.8 * std::sin(0.3), -0.8 * std::cos(0.3)};
  const double v[] = {1.2 * std::cos(0.3), 1.2 * std::sin(0.3)};
  expect_order_one_is_forward_dynamics<CP>(x, v);
}

// Spring pendulum: r̈ = r θ̇² − (k/m)(r − r0) + g cos θ, θ̈ = (−2ṙθ̇ − g sin θ)/r, differentiated
// once by hand:
//   r⃛ = ṙ θ̇² + 2 r θ̇ θ̈ − (k/m) ṙ − g θ̇ sin θ
//   θ⃛ = (−2 r̈ θ̇ − 2 ṙ θ̈ − g θ̇ cos θ − θ̈ ṙ) / r
template <class Real> void spring_pendulum_third_derivative(double tol) {
  using K = eom::Reference<eom::models::SpringPendulum, Real>;
  const Real q[] = {Real(0.61), Real(0.7)}, qd[] = {Real(0.3), Real(-1.9)};
  Real p[4];
  for (int i = 0; i < 4; ++i) p[i] = Real(K::parameter_values[i]);
  Real qk[8], qdk[8];
  ASSERT_TRUE(K::taylor_coefficients(3, Real(0), q, qd, nullptr, p, qk, qdk, nullptr));
  const Real m = p[0], k = p[1], r0 = p[2], g = p[3];
  const Real r = q[0], th = q[1], rd = qd[0], thd = qd[1];
  using std::cos, std::sin;
  const Real rdd = r * thd * thd - k / m * (r - r0) + g * cos(th);
  const Real thdd = (-2 * rd * thd - g * sin(th)) / r;
  const Real rddd = rd * thd * thd + 2 * r * thd * thdd - k / m * rd - g * thd * sin(th);
  const Real thddd = (-2 * rdd * thd - 2 * rd * thdd - g * thd * cos(th) - thdd * rd) / r;
  auto near = [&](const Real& got, const Real& want) {
    EXPECT_LT(eom::as_double(abs(got - want)), tol * std::abs(eom::as_double(want)));
  };
  near(qdk[2], rdd), near(qdk[3], thdd);
  near(qk[4], rdd / 2), near(qk[5], thdd / 2);
  near(qdk[4], rddd / 2), near(qdk[5], thddd / 2);
  near(qk[6], rddd / 6), near(qk[7], thddd / 6);
}

TEST(TaylorKernel, SpringPendulumThirdDerivativeMatchesHandDerivation) {
  spring_pendulum_third_derivative<double>(8 * std::numeric_limits<double>::epsilon());
  spring_pendulum_third_derivative<long double>(8 * std::numeric_limits<long double>::epsilon());
  spring_pendulum_third_derivative<dd_real>(1e-29);
}

// The forced oscillator's coefficients to order 32 at t0 = 0.9 (so cos Ωt advances from a
// nonzero phase): kth derivative of cos(ω t + φ) is ω^k cos(ω t + φ + kπ/2).
TEST(TaylorKernel, ForcedOscillatorMatchesTheClosedFormToOrder32) {
  const auto p = Osc::parameter_values;
  const double w = std::sqrt(p[1] / p[0]), W = p[3], C = p[2] / (p[0] * (w * w - W * W));
  const double A = 0.4, B = -0.7, t0 = 0.9, half_pi = std::numbers::pi / 2;
  // derivative k of x at t0, divided by k!, and its scale (to judge round-off)
  auto coefficient = [&](int k, double& scale) {
    double f = 1;
    for (int i = 2; i <= k; ++i) f *= i;
    const double wk = std::pow(w, k) / f, Wk = std::pow(W, k) / f;
    scale = (std::abs(A) + std::abs(B)) * wk + std::abs(C) * Wk;
    return A * wk * std::cos(w * t0 + k * half_pi) + B * wk * std::sin(w * t0 + k * half_pi) +
           C * Wk * std::cos(W * t0 + k * half_pi);
  };
  double s;
  const double q = coefficient(0, s), qd = coefficient(1, s);
  std::array<double, max_order + 1> qk, qdk;
  ASSERT_TRUE(Osc::taylor_coefficients(max_order, t0, &q, &qd, nullptr, p.data(), qk.data(), qdk.data(), nullptr));
  for (int k = 0; k <= max_order; ++k) {
    double scale_q, scale_qd;
    const double want_q = coefficient(k, scale_q);
    const double want_qd = (k + 1) * coefficient(k + 1, scale_qd);
    // Round-off of the recurrences grows mildly with k: 64 ε of the coefficient's scale.
    EXPECT_NEAR(qk[k], want_q, 64 * std::numeric_limits<double>::epsilon() * scale_q) << k;
    EXPECT_NEAR(qdk[k], want_qd, 64 * std::numeric_limits<double>::epsilon() * (k + 1) * scale_qd) << k;
  }
}

// Cartesian pendulum started on the constraint with C q̇ = 0: the index-1 dynamics keep φ̈ = 0,
// so φ(q(τ)) = x² + y² − l² vanishes identically and every one of its coefficients is zero.
TEST(TaylorKernel, ConstrainedCoefficientsKeepTheConstraintSeriesZero) {
  constexpr int order = 20;
  const auto p = CP::parameter_values;
  const double l = p[1];
  const double q[] = {l * std::sin(0.3), -l * std::cos(0.3)}, qd[] = {1.2 * std::cos(0.3), 1.2 * std::sin(0.3)};
  std::array<double, 2 * (order + 1)> qk, qdk;
  ASSERT_TRUE(CP::taylor_coefficients(order, 0.0, q, qd, nullptr, p.data(), qk.data(), qdk.data(), nullptr));
  using J = eom::Jet<double, order + 1>;
  std::array<double, order + 1> xs, ys;
  for (int k = 0; k <= order; ++k) xs[k] = qk[2 * k], ys[k] = qk[2 * k + 1];
  const J x = J::truncated(xs.data(), order + 1), y = J::truncated(ys.data(), order + 1);
  const J phi = x * x + y * y - l * l;
  for (int k = 0; k <= order; ++k) {
    double size = 0;  // Σ |x_j||x_{k−j}| + |y_j||y_{k−j}|: the terms that cancel in φ_k
    for (int j = 0; j <= k; ++j) size += std::abs(xs[j] * xs[k - j]) + std::abs(ys[j] * ys[k - j]);
    EXPECT_LT(std::abs(phi[k]), 64 * std::numeric_limits<double>::epsilon() * std::max(size, l * l)) << k;
  }
}

TEST(TaylorKernel, WideTypeAgreesWithDouble) {
  using W = eom::Reference<eom::models::DoublePendulum, dd_real>;
  constexpr int order = 24;
  std::array<double, 2 * (order + 1)> qk, qdk;
  std::array<dd_real, 2 * (order + 1)> wk, wdk;
  const auto p = DPRef::parameter_values;
  std::array<dd_real, 5> pw;
  for (int i = 0; i < 5; ++i) pw[i] = dd_real(p[i]);
  const std::array<dd_real, 4> xw{dd_real(dp_x0[0]), dd_real(dp_x0[1]), dd_real(0.0), dd_real(0.0)};
  ASSERT_TRUE(DPRef::taylor_coefficients(order, 0.0, dp_x0.data(), dp_x0.data() + 2, nullptr, p.data(),
                                         qk.data(), qdk.data(), nullptr));
  ASSERT_TRUE(W::taylor_coefficients(order, dd_real(0.0), xw.data(), xw.data() + 2, nullptr, pw.data(),
                                     wk.data(), wdk.data(), nullptr));
  double worst = 0;
  for (int k = 0; k <= order; ++k) {
    double size = 0, diff = 0;
    for (int i = 0; i < 2; ++i) {
      size = std::max({size, std::abs(qk[2 * k + i]), std::abs(qdk[2 * k + i])});
      diff = std::max({diff, std::abs(qk[2 * k + i] - to_double(wk[2 * k + i])),
                       std::abs(qdk[2 * k + i] - to_double(wdk[2 * k + i]))});
    }
    worst = std::max(worst, diff / size);
  }
  record_figure("double_vs_dd_coefficients_relative", worst);
  // Measured 2.6e-14 at orders 23–24 (round-off accumulates through the recurrences).
  EXPECT_LT(worst, 1e-13);
}

TEST(TaylorKernel, RefusesBadOrdersAndInputsWithNaN) {
  const auto p = SP::parameter_values;
  std::array<double, 2 * (max_order + 2)> qk, qdk;
  auto all_nan = [&](int count) {
    for (int i = 0; i < count; ++i)
      if (!std::isnan(qk[i]) || !std::isnan(qdk[i])) return false;
    return true;
  };
  const double q[] = {0.6, 0.2}, qd[] = {0.1, 0.3};
  EXPECT_FALSE(SP::taylor_coefficients(0, 0, q, qd, nullptr, p.data(), qk.data(), qdk.data(), nullptr));
  EXPECT_TRUE(all_nan(2));
  EXPECT_FALSE(SP::taylor_coefficients(max_order + 1, 0, q, qd, nullptr, p.data(), qk.data(), qdk.data(), nullptr));
  EXPECT_TRUE(all_nan(2 * (max_order + 2)));
  const double bad[] = {0.6, std::numeric_limits<double>::quiet_NaN()};
  EXPECT_FALSE(SP::taylor_coefficients(5, 0, bad, qd, nullptr, p.data(), qk.data(), qdk.data(), nullptr));
  EXPECT_TRUE(all_nan(12));
  const double singular[] = {0.0, 0.3};  // r = 0: M = diag(m, m r²) is singular
  EXPECT_FALSE(SP::taylor_coefficients(5, 0, singular, qd, nullptr, p.data(), qk.data(), qdk.data(), nullptr));
  EXPECT_TRUE(all_nan(12));
  EXPECT_TRUE(SP::taylor_coefficients(max_order, 0, q, qd, nullptr, p.data(), qk.data(), qdk.data(), nullptr));
}

// The generated Taylor kernel agrees with the reference at every order.
TEST(TaylorKernel, GeneratedDoublePendulumAgreesWithTheReference) {
  static_assert(eom::TaylorDynamics<double_pendulum::Kernels>,
                "the generated double pendulum must have taylor_coefficients (a default kernel)");
  {
    using G = double_pendulum::Kernels;
    constexpr int order = std::min(G::taylor_max_order, max_order);
    const auto p = DPRef::parameter_values;
    const double q[] = {0.4, -1.1}, qd[] = {1.3, 0.6};
    std::array<double, 2 * (order + 1)> rk, rdk, gk, gdk;
    std::vector<double> work(static_cast<std::size_t>(G::taylor_workspace) * (order + 1));
    ASSERT_TRUE(DPRef::taylor_coefficients(order, 0, q, qd, nullptr, p.data(), rk.data(), rdk.data(), nullptr));
    ASSERT_TRUE(G::taylor_coefficients(order, 0, q, qd, nullptr, p.data(), gk.data(), gdk.data(), work.data()));
    for (int k = 0; k <= order; ++k) {
      double size = 0;
      for (int i = 0; i < 2; ++i) size = std::max({size, std::abs(rk[2 * k + i]), std::abs(rdk[2 * k + i])});
      for (int i = 0; i < 2; ++i) {
        EXPECT_NEAR(gk[2 * k + i], rk[2 * k + i], 1e-13 * size) << k;
        EXPECT_NEAR(gdk[2 * k + i], rdk[2 * k + i], 1e-13 * size) << k;
      }
    }
  }
}

// ---- the fixed-step variant: measured orders --------------------------------------------------

// Order from two runs with N and 2N steps: log2(e(N)/e(2N)).
template <class K, class Exact>
double measured_order(int order, double t1, long steps, const eom::StateOf<K::nq>& x0, Exact exact) {
  const auto p = K::parameter_values;
  double e[2];
  for (int j = 0; j < 2; ++j) {
    const auto r = eom::taylor_fixed<K>(0, t1, steps << j, order, x0, nullptr, p.data(), none);
    EXPECT_EQ(r.status, eom::Status::ok);
    EXPECT_EQ(r.accepted, steps << j);
    EXPECT_EQ(r.evaluations, steps << j);
    e[j] = 0;
    for (int i = 0; i < 2 * K::nq; ++i) e[j] = std::max(e[j], std::abs(r.x[i] - exact[i]));
  }
  std::printf("  order %2d, N = %ld: errors %.3e, %.3e: measured order %.3f\n", order, steps, e[0],
              e[1], std::log2(e[0] / e[1]));
  return std::log2(e[0] / e[1]);
}

// Spring pendulum over 2 s. Its coefficients grow like (1/0.2 s)^k (a complex singularity about
// 0.2 s away), so the asymptotic range needs h well below 0.2 s: order 4 is measured at
// h = 2/300 → 2/600 (errors 2.7e-6 → 1.7e-7), order 8 at h = 2/100 → 2/200 (2.5e-9 → 9.7e-12).
// Order 12 is not measurable there in double: at errors above round-off (≥ 1e-12) the steps are
// still pre-asymptotic (measured 10.6–11.1), so it is measured on the forced oscillator, whose
// entire solution puts the asymptotic range at large steps.
TEST(TaylorFixed, MeasuredOrdersOnTheSpringPendulum) {
  const auto ref = wide_reference<eom::models::SpringPendulum>(sp_x0, {2.0});
  ASSERT_EQ(ref.size(), 1u);
  EXPECT_NEAR((measured_order<SP>(4, 2.0, 300, sp_x0, ref[0])), 4.0, 0.3);
  EXPECT_NEAR((measured_order<SP>(8, 2.0, 100, sp_x0, ref[0])), 8.0, 0.3);
}

// The forced oscillator over 10 s (ω = 2): measured errors 1.4e-5 → 9.3e-7 (order 4, N = 200),
// 1.7e-7 → 6.2e-10 (order 8, N = 40), 3.8e-8 → 9.2e-12 (order 12, N = 16); the round-off floor is
// ~2e-15. At N = 12 order 12 is still pre-asymptotic (12.7: ωh = 1.7).
TEST(TaylorFixed, MeasuredOrdersOnTheForcedOscillator) {
  const auto p = Osc::parameter_values;
  const double w = std::sqrt(p[1] / p[0]), W = p[3], C = p[2] / (p[0] * (w * w - W * W));
  const double A = 0.4, B = -0.7, t1 = 10;
  const eom::StateOf<1> x0{A + C, B * w};
  const eom::StateOf<1> exact{A * std::cos(w * t1) + B * std::sin(w * t1) + C * std::cos(W * t1),
                              -A * w * std::sin(w * t1) + B * w * std::cos(w * t1) - C * W * std::sin(W * t1)};
  const std::pair<int, long> cases[] = {{4, 200}, {8, 40}, {12, 16}};
  for (auto [order, steps] : cases) {
    const double measured = measured_order<Osc>(order, t1, steps, x0, exact);
    EXPECT_NEAR(measured, order, 0.3) << "order " << order;
  }
}

// ---- adaptive schemes: achieved error against tolerance ---------------------------------------

struct ToleranceRun {
  std::vector<double> tol, err;
};

ToleranceRun tolerance_sweep(Scheme scheme) {
  const auto ref = wide_reference<eom::models::SpringPendulum>(sp_x0, {2.0});
  ToleranceRun run;
  const auto p = SP::parameter_values;
  for (int k = 4; k <= 12; ++k) {
    eom::AdaptiveOptions opt;
    opt.rtol = opt.atol = std::pow(10.0, -k);
    eom::TaylorOptions taylor_opt;
    taylor_opt.scheme = scheme;
    const auto r = eom::taylor<SP>(0, 2, sp_x0, nullptr, p.data(), opt, taylor_opt, none);
    EXPECT_EQ(r.status, eom::Status::ok);
    EXPECT_EQ(r.t, 2.0);
    // Both schemes choose h from coefficients already known, so nothing is rejected here, and
    // each accepted step but the last computes the next point's coefficients: one call each.
    EXPECT_EQ(r.rejected, 0);
    EXPECT_EQ(r.evaluations, r.accepted);
    run.tol.push_back(opt.rtol);
    run.err.push_back(max_difference(r.x, ref[0]));
    std::printf("  tol %.0e: error %.3e (error/tol %.3g), %ld steps\n", opt.rtol, run.err.back(),
                run.err.back() / opt.rtol, r.accepted);
  }
  return run;
}

// The paper's scheme keeps the local error of each 4th-order step at the tolerance, so over
// N ∝ tol^(−1/5) steps the global error goes as tol^(4/5). Measured on the spring pendulum over
// 2 s: slope 0.79, error/tol^(4/5) between 12 (1e-4) and 15 (1e-12), error/tol from 76 to 3800.
TEST(TaylorAdaptive, PaperSchemeErrorScalesWithToleranceOverEightDecades) {
  const auto run = tolerance_sweep(Scheme::paper);
  const double slope = log_slope(run.tol, run.err);
  record_figure("paper_scheme_slope", slope);
  EXPECT_NEAR(slope, 0.8, 0.05);
  for (std::size_t i = 0; i < run.tol.size(); ++i) {
    EXPECT_LT(run.err[i], 30 * std::pow(run.tol[i], 0.8)) << run.tol[i];
    EXPECT_GT(run.err[i], 6 * std::pow(run.tol[i], 0.8)) << run.tol[i];
  }
}

// Jorba–Zou picks the order so that the truncated terms are ~ε per step at a step size fixed
// by the coefficients' radius of convergence: the achieved error stays below the tolerance and
// follows it (measured error/tol between 0.005 and 0.08 from 1e-4 to 1e-12, slope 0.92).
TEST(TaylorAdaptive, JorbaZouErrorScalesWithToleranceOverEightDecades) {
  const auto run = tolerance_sweep(Scheme::jorba_zou);
  const double slope = log_slope(run.tol, run.err);
  record_figure("jorba_zou_slope", slope);
  EXPECT_NEAR(slope, 1.0, 0.15);
  for (std::size_t i = 0; i < run.tol.size(); ++i) {
    EXPECT_LT(run.err[i], run.tol[i]) << run.tol[i];
    EXPECT_GT(run.err[i], 1e-3 * run.tol[i]) << run.tol[i];
  }
}

// A given order keeps the Jorba–Zou step rule but aims each of the last two terms at the
// tolerance: higher orders take fewer steps, and the error follows the tolerance (measured on the
// spring pendulum: error/tol from 0.03 to 0.9; each step's truncation is ~ε, so the bound is a
// small multiple of tol, not the fraction the order-from-tolerance rule achieves).
TEST(TaylorAdaptive, JorbaZouAtAGivenOrderFollowsTheTolerance) {
  const auto ref = wide_reference<eom::models::SpringPendulum>(sp_x0, {2.0});
  const auto p = SP::parameter_values;
  long previous_steps = 1L << 40;
  for (int order : {6, 10, 16}) {
    for (double tol : {1e-6, 1e-10}) {
      eom::AdaptiveOptions opt;
      opt.rtol = opt.atol = tol;
      const auto r = eom::taylor<SP>(0, 2, sp_x0, nullptr, p.data(), opt, {Scheme::jorba_zou, order}, none);
      ASSERT_EQ(r.status, eom::Status::ok);
      const double err = max_difference(r.x, ref[0]);
      std::printf("  order %2d, tol %.0e: error %.3e, %ld steps\n", order, tol, err, r.accepted);
      EXPECT_LT(err, 2 * tol) << order;
      EXPECT_GT(err, 1e-3 * tol) << order;
      if (tol == 1e-10) {
        EXPECT_LT(r.accepted, previous_steps) << order;
        previous_steps = r.accepted;
      }
    }
  }
}

// The chaotic double pendulum (a1 = 2.0, a2 = 2.5 at rest) at rtol = atol = 1e-14 with the default
// scheme (Jorba–Zou) against the double-double reference.
TEST(TaylorAdaptive, ChaoticDoublePendulumMatchesTheHighPrecisionReference) {
  const std::vector<double> times{5.0, 10.0};
  const auto ref = wide_reference<eom::models::DoublePendulum>(dp_x0, times);
  ASSERT_EQ(ref.size(), 2u);
  eom::AdaptiveOptions opt;
  opt.rtol = opt.atol = 1e-14;
  opt.output_times = times;
  std::vector<eom::StateOf<2>> got;
  const auto p = DPRef::parameter_values;
  const auto r = eom::taylor<DPKernels>(0, 10, dp_x0, nullptr, p.data(), opt, {},
                                        [&](double, const eom::StateOf<2>& x) { got.push_back(x); });
  ASSERT_EQ(r.status, eom::Status::ok);
  ASSERT_EQ(got.size(), 2u);
  const double e5 = max_difference(got[0], ref[0]), e10 = max_difference(got[1], ref[1]);
  std::printf("  %s kernels: error %.3e at t = 5, %.3e at t = 10, %ld steps\n",
              std::is_same_v<DPKernels, DPRef> ? "reference" : "generated", e5, e10, r.accepted);
  record_figure("double_pendulum_error_t5", e5);
  record_figure("double_pendulum_error_t10", e10);
  // Measured with the reference kernels: 2.3e-12 and 1.3e-6 (perturbations grow ~1e6-fold per 5 s).
  EXPECT_LT(e5, 1e-11);
  EXPECT_LT(e10, 1e-5);
}

// Dense output is each step's own Taylor polynomial. The steps do not depend on the end time
// except for the last, shortened one, so an integration that ends at a requested time takes the
// same steps and evaluates the same polynomial there: the two agree to round-off (measured: bit
// for bit). Both are as accurate as the steps: against the double-double reference within the
// tolerance (Jorba–Zou) or the global error bound of the tolerance sweep above (paper).
TEST(TaylorAdaptive, DenseOutputMatchesDirectIntegrationAndTheTrueSolution) {
  const auto p = SP::parameter_values;
  const std::vector<double> times{0.0, 0.1234, 0.55, 1.3, 1.3, 1.99, 2.0};
  const auto ref = wide_reference<eom::models::SpringPendulum>(sp_x0, {0.1234, 0.55, 1.3, 1.99, 2.0});
  ASSERT_EQ(ref.size(), 5u);
  const eom::StateOf<2> truth[] = {sp_x0, ref[0], ref[1], ref[2], ref[2], ref[3], ref[4]};
  for (Scheme scheme : {Scheme::jorba_zou, Scheme::paper}) {
    eom::AdaptiveOptions opt;
    opt.rtol = opt.atol = 1e-10;
    eom::TaylorOptions taylor_opt;
    taylor_opt.scheme = scheme;
    const double accuracy = scheme == Scheme::paper ? 30 * std::pow(opt.rtol, 0.8) : opt.rtol;
    std::vector<double> seen_t;
    std::vector<eom::StateOf<2>> seen_x;
    double worst_direct = 0, worst_truth = 0;
    opt.output_times = times;
    const auto r = eom::taylor<SP>(0, 2, sp_x0, nullptr, p.data(), opt, taylor_opt,
                                   [&](double t, const eom::StateOf<2>& x) {
                                     seen_t.push_back(t);
                                     seen_x.push_back(x);
                                   });
    ASSERT_EQ(r.status, eom::Status::ok);
    ASSERT_EQ(seen_t, times);
    EXPECT_EQ(seen_x[0], sp_x0);
    opt.output_times = {};
    for (std::size_t j = 1; j < times.size(); ++j) {
      const auto direct = eom::taylor<SP>(0, times[j], sp_x0, nullptr, p.data(), opt, taylor_opt, none);
      ASSERT_EQ(direct.status, eom::Status::ok);
      const double to_direct = max_difference(seen_x[j], direct.x);
      const double to_truth = max_difference(seen_x[j], truth[j]);
      worst_direct = std::max(worst_direct, to_direct);
      worst_truth = std::max(worst_truth, to_truth);
      EXPECT_LT(to_direct, 1e-14) << "t = " << times[j];
      EXPECT_LT(to_truth, accuracy) << "t = " << times[j];
    }
    std::printf("  %s, tol %.0e: dense output vs direct %.3e, vs reference %.3e\n",
                scheme == Scheme::paper ? "paper" : "jorba_zou", opt.rtol, worst_direct, worst_truth);
  }
}

// ---- constraints, bad input, failures -------------------------------------------------------

TEST(TaylorAdaptive, ProjectionKeepsTheCartesianPendulumOnItsConstraint) {
  const auto p = CP::parameter_values;
  const double l = p[1];
  const eom::StateOf<2> x0{l * std::sin(0.3), -l * std::cos(0.3), 1.2 * std::cos(0.3), 1.2 * std::sin(0.3)};
  eom::AdaptiveOptions opt;
  opt.rtol = opt.atol = 1e-8;
  eom::Stabilization stab;
  stab.method = eom::Stabilization::Method::projection;
  double worst = 0;
  for (Scheme scheme : {Scheme::jorba_zou, Scheme::paper}) {
    eom::TaylorOptions taylor_opt;
    taylor_opt.scheme = scheme;
    const auto r = eom::taylor<CP>(0, 5, x0, nullptr, p.data(), opt, taylor_opt,
                                   [&](double, const eom::StateOf<2>& x) {
                                     const auto res = eom::constraint_residuals<CP>(x.data(), x.data() + 2, p.data());
                                     worst = std::max({worst, res[0], res[1]});
                                   }, stab);
    ASSERT_EQ(r.status, eom::Status::ok);
  }
  std::printf("  max constraint residual with projection: %.3e\n", worst);
  EXPECT_LT(worst, 1e-12);
  // Baumgarte terms cannot enter Taylor coefficients: refused.
  stab.method = eom::Stabilization::Method::baumgarte;
  EXPECT_EQ((eom::taylor<CP>(0, 1, x0, nullptr, p.data(), opt, {}, none, stab).status), eom::Status::invalid_argument);
  EXPECT_EQ((eom::taylor_fixed<CP>(0, 1, 10, 6, x0, nullptr, p.data(), none, stab).status),
            eom::Status::invalid_argument);
}

TEST(TaylorAdaptive, RefusesBadInputBeforeAnyStep) {
  const auto p = SP::parameter_values;
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  auto status = [&](double t0, double t1, eom::StateOf<2> x, eom::AdaptiveOptions opt,
                    eom::TaylorOptions taylor_opt, eom::Stabilization stab = {}) {
    int calls = 0;
    const auto r = eom::taylor<SP>(t0, t1, x, nullptr, p.data(), opt, taylor_opt,
                                   [&](double, const auto&) { ++calls; }, stab);
    EXPECT_EQ(r.evaluations, 0);
    EXPECT_EQ(r.accepted + r.rejected, 0);
    EXPECT_EQ(calls, 0);
    return r.status;
  };
  const eom::AdaptiveOptions good;
  const eom::TaylorOptions jz, paper{Scheme::paper, 0};
  using eom::Status;
  for (double bad : {0.0, -1e-8, nan, inf}) {
    eom::AdaptiveOptions o = good;
    o.rtol = bad;
    EXPECT_EQ(status(0, 1, sp_x0, o, jz), Status::invalid_argument) << "rtol " << bad;
    EXPECT_EQ(status(0, 1, sp_x0, o, paper), Status::invalid_argument) << "rtol " << bad;
    o = good;
    o.atol = bad;
    EXPECT_EQ(status(0, 1, sp_x0, o, jz), Status::invalid_argument) << "atol " << bad;
  }
  for (int order : {-1, 1, max_order + 1}) {  // Jorba–Zou needs 2 <= p <= max
    EXPECT_EQ(status(0, 1, sp_x0, good, {Scheme::jorba_zou, order}), Status::invalid_argument) << order;
  }
  for (int order : {-1, max_order}) {  // the paper's scheme also computes term p + 1
    EXPECT_EQ(status(0, 1, sp_x0, good, {Scheme::paper, order}), Status::invalid_argument) << order;
  }
  EXPECT_EQ(status(1, 1, sp_x0, good, jz), Status::invalid_argument);
  EXPECT_EQ(status(1, 0, sp_x0, good, jz), Status::invalid_argument);
  EXPECT_EQ(status(0, inf, sp_x0, good, jz), Status::invalid_argument);
  EXPECT_EQ(status(nan, 1, sp_x0, good, jz), Status::invalid_argument);
  for (int i = 0; i < 4; ++i) {
    eom::StateOf<2> x = sp_x0;
    x[i] = nan;
    EXPECT_EQ(status(0, 1, x, good, jz), Status::invalid_argument) << i;
    x[i] = inf;
    EXPECT_EQ(status(0, 1, x, good, paper), Status::invalid_argument) << i;
  }
  const std::vector<double> unsorted{0.5, 0.2};
  eom::AdaptiveOptions o = good;
  o.output_times = unsorted;
  EXPECT_EQ(status(0, 1, sp_x0, o, jz), Status::invalid_argument);
  eom::Stabilization stab;  // stabilization of a model without constraints
  stab.method = eom::Stabilization::Method::projection;
  EXPECT_EQ(status(0, 1, sp_x0, good, jz, stab), Status::invalid_argument);

  // The fixed-step variant: steps, order, span, state.
  auto fixed = [&](double t0, double t1, long steps, int order, eom::StateOf<2> x) {
    int calls = 0;
    const auto r = eom::taylor_fixed<SP>(t0, t1, steps, order, x, nullptr, p.data(),
                                         [&](double, const auto&) { ++calls; });
    EXPECT_EQ(r.evaluations, 0);
    EXPECT_EQ(calls, 0);
    return r.status;
  };
  EXPECT_EQ(fixed(0, 1, 0, 4, sp_x0), Status::invalid_argument);
  EXPECT_EQ(fixed(0, 1, 10, 0, sp_x0), Status::invalid_argument);
  EXPECT_EQ(fixed(0, 1, 10, max_order + 1, sp_x0), Status::invalid_argument);
  EXPECT_EQ(fixed(1, 0, 10, 4, sp_x0), Status::invalid_argument);
  eom::StateOf<2> x = sp_x0;
  x[2] = nan;
  EXPECT_EQ(fixed(0, 1, 10, 4, x), Status::invalid_argument);
}

TEST(TaylorAdaptive, FailuresStopWithAStatusAndAFiniteState) {
  const auto p = SP::parameter_values;
  const eom::AdaptiveOptions opt;
  // A singular start: r = 0.
  const auto singular = eom::taylor<SP>(0, 1, {0.0, 0.3, 0.1, 0.1}, nullptr, p.data(), opt, {}, none);
  EXPECT_EQ(singular.status, eom::Status::singular_dynamics);
  EXPECT_EQ(singular.evaluations, 1);
  // The step limit.
  eom::AdaptiveOptions few = opt;
  few.max_steps = 3;
  const auto limited = eom::taylor<SP>(0, 2, sp_x0, nullptr, p.data(), few, {}, none);
  EXPECT_EQ(limited.status, eom::Status::step_limit);
  EXPECT_EQ(limited.accepted, 3);
  // A solution that reaches infinity at t* = ∫₁^∞ dx/√(2(x⁴ − 1)) ≈ 0.927: the steps shrink with
  // the radius of convergence until they underflow (or the step limit is hit); never a NaN.
  using Blow = eom::Reference<test_models::BlowUp>;
  for (Scheme scheme : {Scheme::jorba_zou, Scheme::paper}) {
    eom::TaylorOptions taylor_opt;
    taylor_opt.scheme = scheme;
    eom::AdaptiveOptions o = opt;
    o.max_steps = 100000;
    const auto r = eom::taylor<Blow>(0, 2, {1.0, 0.0}, nullptr, Blow::parameter_values.data(), o,
                                     taylor_opt, none);
    EXPECT_TRUE(r.status == eom::Status::step_size_underflow || r.status == eom::Status::step_limit)
        << eom::to_string(r.status);
    EXPECT_LT(r.t, 0.93);
    EXPECT_GT(r.t, 0.9);
    EXPECT_TRUE(std::isfinite(r.x[0]) && std::isfinite(r.x[1]));
  }
}

}  // namespace
