// Dormand–Prince 8(5,3), Hairer's DOP853: the typed coefficients satisfy every order condition
// (8 for the step, 5 and 3 for the error estimates, 7 for the dense output), the measured orders
// match, the achieved error follows the tolerance, the dense output agrees with steps that end
// at the requested times, and bad input or failing dynamics stop with a status.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <eom/integration/dop853.hpp>
#include <eom/reference/reference.hpp>

#include <models/chain.hpp>
#include <models/spring_pendulum.hpp>
#include "record.hpp"
#include "runge_kutta_checks.hpp"
// The generated kernels of the spring pendulum (library target `spring_pendulum`).
#include "spring_pendulum.hpp"

namespace {

using SP = eom::Reference<eom::models::SpringPendulum>;
using T = eom::detail::Dop853Tableau;
constexpr eom::StateOf<2> x0{0.55, 0.0, 0.01, 2.5};
constexpr auto none = [](double, const auto&) {};
using rk_checks::Real;
using rk_checks::Vector;

eom::AdaptiveOptions tolerance(double tol) {
  eom::AdaptiveOptions o;
  o.rtol = o.atol = tol;
  return o;
}

// The continuous extension's weights bᵢ(θ) (x(t + θh) = x + h Σ bᵢ(θ) kᵢ) from the same nested
// form the integrator evaluates; with `absolute`, the same form over |coefficients| (θ ∈ [0, 1]),
// which bounds the effect of their rounding.
Vector dense_weights(Real theta, bool absolute) {
  constexpr int S = 16;
  auto v = [&](double x) { return absolute ? std::abs(Real(x)) : Real(x); };
  const Real minus = absolute ? 1 : -1;
  Vector r2(S), r3(S), r4(S), w(S);
  std::array<Vector, 4> r{Vector(S), Vector(S), Vector(S), Vector(S)};
  for (int i = 0; i < S; ++i) {
    r2[i] = v(T::b[i]);                                   // (x_new − x)/h
    r3[i] = (i == 0 ? 1 : 0) + minus * r2[i];             // k₁ − (x_new − x)/h
    r4[i] = r2[i] + minus * (i == 12 ? 1 : 0) + minus * r3[i];  // … − k₁₃ − r₃
    for (int row = 0; row < 4; ++row) r[row][i] = v(T::d[row][i]);
  }
  const Real rest = 1 - theta;
  for (int i = 0; i < S; ++i) {
    Real x = r[2][i] + theta * r[3][i];
    x = r[1][i] + rest * x;
    x = r[0][i] + theta * x;
    x = r4[i] + rest * x;
    x = r3[i] + theta * x;
    x = r2[i] + rest * x;
    w[i] = theta * x;
  }
  return w;
}

TEST(Dop853, CoefficientsSatisfyTheOrderConditions) {
  const auto trees = rk_checks::rooted_trees(9);
  // The enumeration itself: the number of rooted trees of each order (OEIS A000081).
  const int expected_count[] = {0, 1, 1, 2, 4, 9, 20, 48, 115, 286};
  for (int n = 1; n <= 9; ++n)
    EXPECT_EQ(std::count_if(trees.begin(), trees.end(), [&](const auto& t) { return t.order == n; }),
              expected_count[n]) << "order " << n;

  // Nodes: c₂…c₅ from (6 ∓ √6)/30, and every row sums to its node (to the coefficients' rounding).
  const Real c4 = (6 - std::sqrt(Real(6))) / 30, c5 = (6 + std::sqrt(Real(6))) / 30;
  const double eps = std::numeric_limits<double>::epsilon();
  EXPECT_LE(std::abs(T::c[1] - c4 * 4 / 9), eps * T::c[1]);
  EXPECT_LE(std::abs(T::c[2] - c4 * 2 / 3), eps * T::c[2]);
  EXPECT_LE(std::abs(T::c[3] - c4), eps * T::c[3]);
  EXPECT_LE(std::abs(T::c[4] - c5), eps * T::c[4]);
  for (int i = 0; i < 16; ++i) {
    Real sum = 0, sum_abs = 0;
    for (int j = 0; j < 16; ++j) sum += T::a[i][j], sum_abs += std::abs(T::a[i][j]);
    EXPECT_LE(std::abs(sum - T::c[i]), eps * (sum_abs + T::c[i])) << "row " << i + 1;
  }

  const rk_checks::Conditions cond(trees, rk_checks::to_matrix(T::a), rk_checks::to_matrix(T::a, true));
  auto check = [&](const Vector& w, int order, double next_residual, const char* what) {
    // All conditions up to `order` hold to rounding (200 trees for order 8); the next order's
    // do not (the smallest next-order residual expected), so the check can tell the orders apart.
    EXPECT_LE(cond.worst_relative(w, rk_checks::absolute(w), 1, order), 1.0) << what;
    EXPECT_GT(cond.worst_residual(w, order + 1, order + 1), next_residual) << what;
  };
  // The step: order 8 (Σ bᵢcᵢ^(k−1) = 1/k for k ≤ 8 are among the trees: the bushy ones).
  const Vector b = rk_checks::to_vector(T::b, 16);
  check(b, 8, 1e-6, "b, order 8");
  // The error estimators' embedded weights: b̂ = b − e₅ of order 5, b₃ of order 3.
  Vector b5 = b;
  for (int i = 0; i < 12; ++i) b5[i] -= T::e5[i];
  check(b5, 5, 1e-5, "5th-order weights");
  check(rk_checks::to_vector(T::b3, 16), 3, 1e-3, "3rd-order weights");
  Vector b3_from_e3 = b;  // e₃ is b − b₃
  for (int i = 0; i < 12; ++i) b3_from_e3[i] -= T::e3[i];
  check(b3_from_e3, 3, 1e-3, "b − e3");
  // The dense output: order 7 at every θ (its 8th-order defect measured 7e-6 … 8e-5).
  for (Real theta : {0.1L, 0.37L, 0.5L, 0.9L}) {
    EXPECT_LE(cond.worst_relative(dense_weights(theta, false), dense_weights(theta, true), 1, 7, theta), 1.0)
        << "dense output at θ = " << static_cast<double>(theta);
    EXPECT_GT(cond.worst_residual(dense_weights(theta, false), 8, 8, theta), 1e-6);
  }
}

// The least-squares slope of y over x.
double slope(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) sx += x[i], sy += y[i], sxx += x[i] * x[i], sxy += x[i] * y[i];
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

// Measured orders from errors at step counts N, 2N, 4N, …: log2(e(N)/e(2N)); or, given the step
// sizes, log(eᵢ/eᵢ₊₁) / log(hᵢ/hᵢ₊₁).
std::vector<double> orders(const std::vector<double>& errors, const std::vector<double>& steps = {}) {
  std::vector<double> out;
  for (std::size_t i = 1; i < errors.size(); ++i)
    out.push_back(std::log(errors[i - 1] / errors[i]) /
                  (steps.empty() ? std::log(2.0) : std::log(steps[i - 1] / steps[i])));
  return out;
}

TEST(Dop853, FixedStepOrderIsEight) {
  using Step = eom::detail::Dop853Step<4>;
  const auto p = SP::parameter_values;
  // The spring pendulum over 1 s (~1.4 spring periods), against the double-double reference.
  const double t1 = 1.0;
  const double end[] = {t1};
  const auto ref = rk_checks::spring_pendulum_reference(end);
  ASSERT_EQ(ref.size(), 1u);
  auto f = [&](double t, const eom::StateOf<2>& x, eom::StateOf<2>& dx) {
    return eom::state_derivative<SP>(t, x, nullptr, p.data(), dx);
  };
  std::vector<double> errors;
  for (long steps : {20, 40, 80}) {  // errors 1.6e-9 … 2.3e-14, above round-off (~1e-15)
    auto x = x0;
    ASSERT_TRUE(rk_checks::fixed_steps<Step>(f, 0, t1, steps, x));
    errors.push_back(rk_checks::max_abs_difference(x, ref[0]));
  }
  // A non-autonomous problem (so the nodes cᵢ enter through t): y' = y cos t, y = exp(sin t).
  std::vector<double> errors_t;
  auto g = [](double t, const std::array<double, 1>& y, std::array<double, 1>& dy) {
    dy[0] = y[0] * std::cos(t);
    return true;
  };
  for (long steps : {4, 8, 16}) {  // over [0, 2]: errors 1e-8 … 2e-13
    std::array<double, 1> y{1.0};
    ASSERT_TRUE(rk_checks::fixed_steps<eom::detail::Dop853Step<1>>(g, 0, 2, steps, y));
    errors_t.push_back(std::abs(y[0] - std::exp(std::sin(2.0))));
  }
  for (const auto* e : {&errors, &errors_t}) {
    const auto q = orders(*e);
    for (std::size_t i = 0; i < q.size(); ++i) {
      std::printf("error %.3e -> %.3e: order %.3f\n", (*e)[i], (*e)[i + 1], q[i]);
      EXPECT_NEAR(q[i], 8.0, 0.3);
    }
  }
  record_figure("order_spring_pendulum", orders(errors).back());
  record_figure("order_nonautonomous", orders(errors_t).back());
}

// Achieved error against the double-double reference, rtol = atol = tol from 1e-3 to 1e-13, over
// 2 s (10–131 steps) and 10 s (43–660 steps). Measured error/tol: 0.54–9.4 over 2 s and 2.1–50
// over 10 s (the global error is the propagated sum of local errors that the control keeps near
// tol, so it grows with the span); the least-squares slope of log(error) against log(tol) is
// 0.89 (2 s) and 0.91 (10 s): error ∝ tol^0.9, i.e. err/tol drifts up by ~1 decade over ten
// decades of tol (less proportional than DOPRI5's 24–36 band). Asserted:
// every error/tol in [0.1, 100] and the slope in [0.8, 1.1].
TEST(Dop853, AchievedErrorScalesWithTolerance) {
  const auto p = SP::parameter_values;
  const double end[] = {2.0, 10.0};
  const auto ref = rk_checks::spring_pendulum_reference(end);
  ASSERT_EQ(ref.size(), 2u);
  for (int span = 0; span < 2; ++span) {
    std::vector<double> log_tol, log_err;
    for (int k = 3; k <= 13; ++k) {
      const double tol = std::pow(10.0, -k);
      const auto r = eom::dop853<SP>(0, end[span], x0, nullptr, p.data(), tolerance(tol), none);
      ASSERT_EQ(r.status, eom::Status::ok);
      EXPECT_EQ(r.t, end[span]);
      // 12 evaluations per accepted step (11 stages + FSAL), 11 per rejected one, plus the first
      // derivative and the starting-step probe.
      EXPECT_EQ(r.evaluations, 12 * r.accepted + 11 * r.rejected + 2);
      const double err = rk_checks::max_abs_difference(r.x, ref[span]);
      std::printf("t1 %4.1f tol %.0e: error %.3e, error/tol %6.3f, %3ld accepted, %2ld rejected\n",
                  end[span], tol, err, err / tol, r.accepted, r.rejected);
      EXPECT_GT(err / tol, 0.1) << "tol " << tol << ", t1 " << end[span];
      EXPECT_LT(err / tol, 100.0) << "tol " << tol << ", t1 " << end[span];
      log_tol.push_back(std::log10(tol));
      log_err.push_back(std::log10(err));
    }
    const double s = slope(log_tol, log_err);
    std::printf("t1 %4.1f: slope of log error over log tol %.3f\n", end[span], s);
    EXPECT_GT(s, 0.8);
    EXPECT_LT(s, 1.1);
    record_figure(span == 0 ? "error_tol_slope_2s" : "error_tol_slope_10s", s);
  }
}

// The dense output's local error: one step of size h of the harmonic oscillator x'' = −x from
// (cos tₐ, −sin tₐ), interpolated at θ = 1/2 and 3/4. A continuous extension of order 7 errs by
// O(h⁸). On the oscillator the error is a complex number z = ih in disguise: its h⁹ term is in
// quadrature with the h⁸ term, so the Euclidean error norm approaches C·h⁸ as 1 + O(h²) and the
// measured order is clean (8.04 and 8.01 measured; a spring pendulum step shows the same order
// but with O(h) pre-asymptotic drift, 7.6–8.3 over usable steps).
TEST(Dop853, DenseOutputOrderIsSeven) {
  auto f = [](double, const std::array<double, 2>& x, std::array<double, 2>& dx) {
    dx[0] = x[1];
    dx[1] = -x[0];
    return true;
  };
  const double ta = 0.5;
  const std::vector<double> steps{0.4, 0.2, 0.1};  // errors 6e-10 … 8e-15, above round-off
  for (double theta : {0.5, 0.75}) {
    std::vector<double> errors;
    for (double h : steps) {
      eom::detail::Dop853Step<2> s;
      const std::array<double, 2> xa{std::cos(ta), -std::sin(ta)};
      ASSERT_TRUE(f(ta, xa, s.k[0]) && std::isfinite(s.attempt(f, ta, h, xa, eom::AdaptiveOptions{})) &&
                  s.complete(f, ta, h, xa, true));
      std::array<double, 2> x;
      s.interpolate(theta, x);
      const double t = ta + theta * h;
      errors.push_back(std::hypot(x[0] - std::cos(t), x[1] + std::sin(t)));
    }
    const auto q = orders(errors, steps);
    for (std::size_t i = 0; i < q.size(); ++i) {
      std::printf("θ %.2f, h %.2f: dense error %.3e -> %.3e: order %.3f\n", theta, steps[i], errors[i],
                  errors[i + 1], q[i]);
      EXPECT_NEAR(q[i], 8.0, 0.3);
    }
    record_figure(theta == 0.5 ? "dense_order_half" : "dense_order_three_quarters", q.back());
  }
}

// With output times, the observer gets the continuous extension's states; each agrees with a run
// that steps exactly to that time, and both are within a fixed multiple of the tolerance of the
// reference. The interpolant's local error is O(h⁸), the order of the controlled error estimate
// (the step's own is O(h⁹)), so it adds a multiple of tol to the step ends' error. Measured over
// 40 times in [0.05, 2]: |dense − stepped|/tol 8.2, 5.2, 13.8 and dense error/tol 7.5, 5.9, 17.1
// (step ends 1.7, 4.5, 7.4) at tol 1e-6, 1e-9, 1e-12. Asserted: both ≤ 30·tol.
TEST(Dop853, DenseOutputMatchesStepsThatEndThere) {
  const auto p = SP::parameter_values;
  std::vector<double> times;
  for (int i = 1; i <= 40; ++i) times.push_back(0.05 * i);  // 0.05 … 2, most of them inside steps
  const auto ref = rk_checks::spring_pendulum_reference(times);
  ASSERT_EQ(ref.size(), times.size());
  for (double tol : {1e-6, 1e-9, 1e-12}) {
    eom::AdaptiveOptions o = tolerance(tol);
    o.output_times = times;
    std::vector<eom::StateOf<2>> dense;
    const auto r = eom::dop853<SP>(0, 2, x0, nullptr, p.data(), o,
                                   [&](double, const eom::StateOf<2>& x) { dense.push_back(x); });
    ASSERT_EQ(r.status, eom::Status::ok);
    ASSERT_EQ(dense.size(), times.size());
    double worst_gap = 0, worst_dense = 0, worst_stepped = 0;
    for (std::size_t i = 0; i < times.size(); ++i) {
      const auto stepped = eom::dop853<SP>(0, times[i], x0, nullptr, p.data(), tolerance(tol), none);
      ASSERT_EQ(stepped.status, eom::Status::ok);
      worst_gap = std::max(worst_gap, rk_checks::max_abs_difference(dense[i], stepped.x));
      worst_dense = std::max(worst_dense, rk_checks::max_abs_difference(dense[i], ref[i]));
      worst_stepped = std::max(worst_stepped, rk_checks::max_abs_difference(stepped.x, ref[i]));
    }
    std::printf("tol %.0e: |dense − stepped|/tol %.3f, dense error/tol %.3f, stepped error/tol %.3f\n", tol,
                worst_gap / tol, worst_dense / tol, worst_stepped / tol);
    EXPECT_LE(worst_gap, 30 * tol);
    EXPECT_LE(worst_dense, 30 * tol);
    EXPECT_LE(worst_stepped, 30 * tol);
  }
}

TEST(Dop853, OutputTimes) {
  const auto p = SP::parameter_values;
  auto run = [&](double t1, std::vector<double> times, std::vector<std::pair<double, eom::StateOf<2>>>& seen) {
    eom::AdaptiveOptions o = tolerance(1e-9);
    o.output_times = times;
    seen.clear();
    return eom::dop853<SP>(0, t1, x0, nullptr, p.data(), o,
                           [&](double t, const eom::StateOf<2>& x) { seen.emplace_back(t, x); });
  };
  std::vector<std::pair<double, eom::StateOf<2>>> seen;
  // Refused before any evaluation or output: descending, before t0, after t1, not finite.
  for (const auto& bad : std::vector<std::vector<double>>{
           {0.5, 0.4}, {-0.1, 0.5}, {0.5, 2.0001}, {std::numeric_limits<double>::quiet_NaN()}}) {
    const auto r = run(2, bad, seen);
    EXPECT_EQ(r.status, eom::Status::invalid_argument);
    EXPECT_EQ(r.evaluations, 0);
    EXPECT_TRUE(seen.empty());
  }
  // Without output times, for comparison: the observer sees t0 and every step end.
  int step_ends = 0;
  const auto plain = eom::dop853<SP>(0, 2, x0, nullptr, p.data(), tolerance(1e-9),
                                     [&](double, const auto&) { ++step_ends; });
  EXPECT_EQ(step_ends, plain.accepted + 1);
  // t0, interior times, a repeated time and the end time: exactly these, in order, never a step end;
  // t0 and t1 give the exact start and end states.
  const std::vector<double> times{0.0, 0.3, 0.3, 1.234, 2.0};
  const auto r = run(2, times, seen);
  ASSERT_EQ(r.status, eom::Status::ok);
  ASSERT_EQ(seen.size(), times.size());
  for (std::size_t i = 0; i < times.size(); ++i) EXPECT_EQ(seen[i].first, times[i]);
  EXPECT_EQ(seen.front().second, x0);
  EXPECT_EQ(seen.back().second, r.x);
  EXPECT_EQ(seen[1].second, seen[2].second);
  // Stepping is not affected: the same steps and end state; only the dense stages are added,
  // three per step that contains an interior time (here 2: 0.3 and 1.234, in different steps).
  EXPECT_EQ(r.x, plain.x);
  EXPECT_EQ(r.accepted, plain.accepted);
  EXPECT_EQ(r.rejected, plain.rejected);
  EXPECT_EQ(r.evaluations, plain.evaluations + 3 * 2);
  // Only t0 and t1: no interpolation, no extra evaluation.
  const auto ends = run(2, {0.0, 2.0}, seen);
  EXPECT_EQ(ends.evaluations, plain.evaluations);
  ASSERT_EQ(seen.size(), 2u);
}

TEST(Dop853, RefusesBadInputBeforeAnyStep) {
  const auto p = SP::parameter_values;
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  auto run = [&](double t0, double t1, eom::StateOf<2> x, eom::AdaptiveOptions opt) {
    int calls = 0;
    const auto r = eom::dop853<SP>(t0, t1, x, nullptr, p.data(), opt, [&](double, const auto&) { ++calls; });
    EXPECT_EQ(r.evaluations, 0);
    EXPECT_EQ(r.accepted + r.rejected, 0);
    EXPECT_EQ(calls, 0);
    return r.status;
  };
  const eom::AdaptiveOptions good;
  for (double bad : {0.0, -1e-8, nan, inf}) {
    eom::AdaptiveOptions o = good;
    o.rtol = bad;
    EXPECT_EQ(run(0, 1, x0, o), eom::Status::invalid_argument) << "rtol " << bad;
    o = good;
    o.atol = bad;
    EXPECT_EQ(run(0, 1, x0, o), eom::Status::invalid_argument) << "atol " << bad;
  }
  eom::AdaptiveOptions o = good;
  o.initial_step = -0.1;
  EXPECT_EQ(run(0, 1, x0, o), eom::Status::invalid_argument);
  o = good;
  o.max_steps = 0;
  EXPECT_EQ(run(0, 1, x0, o), eom::Status::invalid_argument);
  EXPECT_EQ(run(1, 0, x0, good), eom::Status::invalid_argument) << "end before start";
  EXPECT_EQ(run(1, 1, x0, good), eom::Status::invalid_argument) << "empty span";
  EXPECT_EQ(run(0, nan, x0, good), eom::Status::invalid_argument);
  EXPECT_EQ(run(0, inf, x0, good), eom::Status::invalid_argument);
  auto x = x0;
  x[1] = inf;
  EXPECT_EQ(run(0, 1, x, good), eom::Status::invalid_argument) << "non-finite initial state";
  x[1] = nan;
  EXPECT_EQ(run(0, 1, x, good), eom::Status::invalid_argument) << "NaN initial state";
}

TEST(Dop853, StopsAtTheStepLimit) {
  const auto p = SP::parameter_values;
  eom::AdaptiveOptions o = tolerance(1e-12);
  o.max_steps = 10;
  const auto r = eom::dop853<SP>(0, 10, x0, nullptr, p.data(), o, none);
  EXPECT_EQ(r.status, eom::Status::step_limit);
  EXPECT_EQ(r.accepted + r.rejected, 10);
  EXPECT_LT(r.t, 10.0);
  for (double v : r.x) EXPECT_TRUE(std::isfinite(v));
}

TEST(Dop853, SingularDynamicsStopWithStatus) {
  using CC = eom::Reference<eom::models::ClosedChain5>;
  auto p = CC::parameter_values;
  p[21] = 5.0;  // dead point: stretched straight between pins 5 m apart
  const eom::StateOf<5> straight{};
  const auto r = eom::dop853<CC>(0, 1, straight, nullptr, p.data(), eom::AdaptiveOptions{}, none);
  EXPECT_EQ(r.status, eom::Status::singular_dynamics);
  EXPECT_EQ(r.t, 0.0);
  EXPECT_EQ(r.x, straight);
}

TEST(Dop853, ProjectionKeepsTheClosedChainOnItsConstraints) {
  using CC = eom::Reference<eom::models::ClosedChain5>;
  const auto p = CC::parameter_values;
  eom::StateOf<5> x{};
  for (int i = 0; i < 5; ++i) x[i] = eom::models::ClosedChain5::initial_q[i];
  eom::Stabilization stab;
  stab.method = eom::Stabilization::Method::projection;
  double worst = 0;
  const auto r = eom::dop853<CC>(0, 5, x, nullptr, p.data(), tolerance(1e-8), [&](double, const eom::StateOf<5>& s) {
    worst = std::max(worst, eom::constraint_residuals<CC>(s.data(), s.data() + 5, p.data())[0]);
  }, stab);
  ASSERT_EQ(r.status, eom::Status::ok);
  EXPECT_LE(worst, 1e-12);
  record_figure("max_abs_phi", worst);
}

// The generated kernels and the reference run the same integration: the same steps, and end
// states that differ only by the kernels' rounding (they agree to ~1e-15, tests/kernels), far
// below the tolerance (measured 5e-14 after 10 s at tol 1e-10; asserted ≤ 1% of tol).
TEST(Dop853, GeneratedAndReferenceKernelsAgree) {
  const auto p = SP::parameter_values;
  const auto a = eom::dop853<SP>(0, 10, x0, nullptr, p.data(), tolerance(1e-10), none);
  const auto b = eom::dop853<spring_pendulum::Kernels>(0, 10, x0, nullptr, p.data(), tolerance(1e-10), none);
  ASSERT_EQ(a.status, eom::Status::ok);
  ASSERT_EQ(b.status, eom::Status::ok);
  EXPECT_EQ(a.accepted, b.accepted);
  EXPECT_EQ(a.rejected, b.rejected);
  EXPECT_LE(rk_checks::max_abs_difference(a.x, b.x), 1e-12);
}

}  // namespace
