// Dormand–Prince 5(4): the coefficients satisfy the order conditions (5 for the step, 4 for the
// error estimate and the dense output), the measured orders match, achieved error scales with the
// tolerance, the dense output agrees with steps that end at the requested times, bookkeeping is
// exact, bad input is refused before any step, and failures stop with a status.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <eom/integration/dopri5.hpp>
#include <eom/integration/rk4.hpp>
#include <eom/reference/reference.hpp>

#include <models/chain.hpp>
#include "record.hpp"
#include "runge_kutta_checks.hpp"
#include <models/spring_pendulum.hpp>

namespace {

using SP = eom::Reference<eom::models::SpringPendulum>;
constexpr eom::StateOf<2> x0{0.55, 0.0, 0.01, 2.5};
auto none = [](double, const auto&) {};

TEST(Dopri5, AchievedErrorScalesWithToleranceOverSevenDecades) {
  // Reference: RK4 with 51200 steps over 2 s (differs from 102400 steps by 1.2e-13).
  // Measured with rtol = atol = tol: max-abs state error / tol between 24 and 36 for every tol
  // from 1e-3 to 1e-12 (the global error of ~100-900 steps is ~35 local tolerances).
  const auto p = SP::parameter_values;
  const auto ref = eom::rk4<SP>(0, 2, 51200, x0, nullptr, p.data(), none).x;
  double first_log_ratio = 0, last_log_ratio = 0;
  for (int k = 4; k <= 11; ++k) {
    const double tol = std::pow(10.0, -k);
    eom::AdaptiveOptions opt;
    opt.rtol = opt.atol = tol;
    const auto r = eom::dopri5<SP>(0, 2, x0, nullptr, p.data(), opt, none);
    ASSERT_EQ(r.status, eom::Status::ok);
    EXPECT_EQ(r.t, 2.0);
    double err = 0;
    for (int i = 0; i < 4; ++i) err = std::max(err, std::abs(r.x[i] - ref[i]));
    EXPECT_GT(err / tol, 5.0) << "tol " << tol;
    EXPECT_LT(err / tol, 100.0) << "tol " << tol;
    // Six evaluations per attempted step, plus the first derivative and the starting-step probe.
    EXPECT_EQ(r.evaluations, 6 * (r.accepted + r.rejected) + 2);
    (k == 4 ? first_log_ratio : last_log_ratio) = std::log10(err / tol);
  }
  // Proportionality: err/tol drifts by less than a factor 3 across seven decades.
  EXPECT_LT(std::abs(last_log_ratio - first_log_ratio), std::log10(3.0));
}

using T = eom::detail::Dopri5Tableau;
using rk_checks::Real;
using rk_checks::Vector;

eom::AdaptiveOptions tolerance(double tol) {
  eom::AdaptiveOptions o;
  o.rtol = o.atol = tol;
  return o;
}

// The continuous extension's weights bᵢ(θ) from the nested form the integrator evaluates; with
// `absolute`, the same form over |coefficients| (θ ∈ [0, 1]), which bounds their rounding.
Vector dense_weights(Real theta, bool absolute) {
  constexpr int S = 7;
  auto v = [&](double x) { return absolute ? std::abs(Real(x)) : Real(x); };
  const Real minus = absolute ? 1 : -1, rest = 1 - theta;
  Vector w(S);
  for (int i = 0; i < S; ++i) {
    const Real r2 = v(T::b[i]);                                      // (x_new − x)/h
    const Real r3 = (i == 0 ? 1 : 0) + minus * r2;                   // k₁ − r₂
    const Real r4 = r2 + minus * (i == 6 ? 1 : 0) + minus * r3;      // r₂ − k₇ − r₃
    w[i] = theta * (r2 + rest * (r3 + theta * (r4 + rest * v(T::d[i]))));
  }
  return w;
}

TEST(Dopri5, CoefficientsSatisfyTheOrderConditions) {
  const auto trees = rk_checks::rooted_trees(6);
  const double eps = std::numeric_limits<double>::epsilon();
  for (int i = 0; i < 7; ++i) {  // row sums = nodes
    Real sum = 0, sum_abs = 0;
    for (int j = 0; j < 7; ++j) sum += T::a[i][j], sum_abs += std::abs(T::a[i][j]);
    EXPECT_LE(std::abs(sum - T::c[i]), eps * (sum_abs + T::c[i])) << "row " << i + 1;
  }
  const rk_checks::Conditions cond(trees, rk_checks::to_matrix(T::a), rk_checks::to_matrix(T::a, true));
  auto check = [&](const Vector& w, const Vector& w_abs, int order, double next_residual, Real theta,
                   const char* what) {
    // Every condition up to `order` holds to rounding; the next order's do not.
    EXPECT_LE(cond.worst_relative(w, w_abs, 1, order, theta), 1.0) << what;
    EXPECT_GT(cond.worst_residual(w, order + 1, order + 1, theta), next_residual) << what;
  };
  const Vector b = rk_checks::to_vector(T::b, 7);
  check(b, rk_checks::absolute(b), 5, 1e-4, 1, "b, order 5");
  Vector b4 = b;  // the embedded weights b̂ = b − e
  for (int i = 0; i < 7; ++i) b4[i] -= T::e[i];
  check(b4, rk_checks::absolute(b4), 4, 1e-4, 1, "embedded weights, order 4");
  for (Real theta : {0.1L, 0.37L, 0.5L, 0.9L})  // 5th-order defects measured 4e-4 … 2e-3
    check(dense_weights(theta, false), dense_weights(theta, true), 4, 1e-4, theta, "dense output, order 4");
}

// Measured orders from errors at step sizes h₀ > h₁ > …: log(eᵢ/eᵢ₊₁) / log(hᵢ/hᵢ₊₁).
std::vector<double> orders(const std::vector<double>& errors, const std::vector<double>& steps) {
  std::vector<double> out;
  for (std::size_t i = 1; i < errors.size(); ++i)
    out.push_back(std::log(errors[i - 1] / errors[i]) / std::log(steps[i - 1] / steps[i]));
  return out;
}

TEST(Dopri5, FixedStepOrderIsFive) {
  using Step = eom::detail::Dopri5Step<4>;
  const auto p = SP::parameter_values;
  // The spring pendulum over 1 s against the double-double reference.
  const double end[] = {1.0};
  const auto ref = rk_checks::spring_pendulum_reference(end);
  ASSERT_EQ(ref.size(), 1u);
  auto f = [&](double t, const eom::StateOf<2>& x, eom::StateOf<2>& dx) {
    return eom::state_derivative<SP>(t, x, nullptr, p.data(), dx);
  };
  std::vector<double> errors, steps;
  for (long n : {100, 200, 400, 800}) {
    auto x = x0;
    ASSERT_TRUE(rk_checks::fixed_steps<Step>(f, 0, 1, n, x));
    errors.push_back(rk_checks::max_abs_difference(x, ref[0]));
    steps.push_back(1.0 / static_cast<double>(n));
  }
  // A non-autonomous problem (the nodes cᵢ enter through t): y' = y cos t, y = exp(sin t).
  auto g = [](double t, const std::array<double, 1>& y, std::array<double, 1>& dy) {
    dy[0] = y[0] * std::cos(t);
    return true;
  };
  std::vector<double> errors_t, steps_t;
  for (long n : {16, 32, 64, 128}) {
    std::array<double, 1> y{1.0};
    ASSERT_TRUE(rk_checks::fixed_steps<eom::detail::Dopri5Step<1>>(g, 0, 2, n, y));
    errors_t.push_back(std::abs(y[0] - std::exp(std::sin(2.0))));
    steps_t.push_back(2.0 / static_cast<double>(n));
  }
  for (const auto& [e, h] : {std::pair{errors, steps}, std::pair{errors_t, steps_t}}) {
    const auto q = orders(e, h);
    for (std::size_t i = 0; i < q.size(); ++i) {
      std::printf("error %.3e -> %.3e: order %.3f\n", e[i], e[i + 1], q[i]);
      EXPECT_NEAR(q[i], 5.0, 0.3);
    }
  }
  record_figure("order_spring_pendulum", orders(errors, steps).back());
}

// The dense output's local error: one step of size h of the harmonic oscillator x'' = −x,
// interpolated at θ = 1/4, 1/2, 3/4. A continuous extension of order 4 errs by O(h⁵); on the
// oscillator the next term is in quadrature with it, so the measured order is clean.
TEST(Dopri5, DenseOutputOrderIsFour) {
  auto f = [](double, const std::array<double, 2>& x, std::array<double, 2>& dx) {
    dx[0] = x[1];
    dx[1] = -x[0];
    return true;
  };
  const double ta = 0.5;
  const std::vector<double> steps{0.1, 0.05, 0.025};  // errors 3e-9 … 8e-13
  for (double theta : {0.25, 0.5, 0.75}) {
    std::vector<double> errors;
    for (double h : steps) {
      eom::detail::Dopri5Step<2> s;
      const std::array<double, 2> xa{std::cos(ta), -std::sin(ta)};
      ASSERT_TRUE(f(ta, xa, s.k[0]) && std::isfinite(s.attempt(f, ta, h, xa, eom::AdaptiveOptions{})));
      s.prepare_dense(xa, h);
      std::array<double, 2> x;
      s.interpolate(theta, x);
      const double t = ta + theta * h;
      errors.push_back(std::hypot(x[0] - std::cos(t), x[1] + std::sin(t)));
    }
    const auto q = orders(errors, steps);
    for (std::size_t i = 0; i < q.size(); ++i) {
      std::printf("θ %.2f, h %.3f: dense error %.3e -> %.3e: order %.3f\n", theta, steps[i], errors[i],
                  errors[i + 1], q[i]);
      EXPECT_NEAR(q[i], 5.0, 0.3);
    }
  }
}

// With output times, the observer gets the continuous extension's states; each agrees with a run
// that steps exactly to that time, and both are about as close to the reference as step ends.
// The interpolant's local error is O(h⁵), the order of the error estimate, so it adds a multiple
// of tol. Measured over 40 times in [0.05, 2]: |dense − stepped|/tol 1.2, 4.4, 2.8 and dense
// error/tol 34, 36, 34 (= the step ends': the global error dominates) at tol 1e-5, 1e-8, 1e-11.
// Asserted: the gap ≤ 10·tol, both errors within the step-end band of
// AchievedErrorScalesWithToleranceOverSevenDecades (≤ 100·tol).
TEST(Dopri5, DenseOutputMatchesStepsThatEndThere) {
  const auto p = SP::parameter_values;
  std::vector<double> times;
  for (int i = 1; i <= 40; ++i) times.push_back(0.05 * i);
  const auto ref = rk_checks::spring_pendulum_reference(times);
  ASSERT_EQ(ref.size(), times.size());
  for (double tol : {1e-5, 1e-8, 1e-11}) {
    eom::AdaptiveOptions o = tolerance(tol);
    o.output_times = times;
    std::vector<eom::StateOf<2>> dense;
    const auto r = eom::dopri5<SP>(0, 2, x0, nullptr, p.data(), o,
                                   [&](double, const eom::StateOf<2>& x) { dense.push_back(x); });
    ASSERT_EQ(r.status, eom::Status::ok);
    ASSERT_EQ(dense.size(), times.size());
    double worst_gap = 0, worst_dense = 0, worst_stepped = 0;
    for (std::size_t i = 0; i < times.size(); ++i) {
      const auto stepped = eom::dopri5<SP>(0, times[i], x0, nullptr, p.data(), tolerance(tol), none);
      ASSERT_EQ(stepped.status, eom::Status::ok);
      worst_gap = std::max(worst_gap, rk_checks::max_abs_difference(dense[i], stepped.x));
      worst_dense = std::max(worst_dense, rk_checks::max_abs_difference(dense[i], ref[i]));
      worst_stepped = std::max(worst_stepped, rk_checks::max_abs_difference(stepped.x, ref[i]));
    }
    std::printf("tol %.0e: |dense − stepped|/tol %.3f, dense error/tol %.3f, stepped error/tol %.3f\n", tol,
                worst_gap / tol, worst_dense / tol, worst_stepped / tol);
    EXPECT_LE(worst_gap, 10 * tol);
    EXPECT_LE(worst_dense, 100 * tol);
    EXPECT_LE(worst_stepped, 100 * tol);
  }
}

TEST(Dopri5, OutputTimes) {
  const auto p = SP::parameter_values;
  std::vector<std::pair<double, eom::StateOf<2>>> seen;
  auto run = [&](double t1, std::vector<double> times) {
    eom::AdaptiveOptions o = tolerance(1e-9);
    o.output_times = times;
    seen.clear();
    return eom::dopri5<SP>(0, t1, x0, nullptr, p.data(), o,
                           [&](double t, const eom::StateOf<2>& x) { seen.emplace_back(t, x); });
  };
  // Refused before any evaluation or output: descending, before t0, after t1, not finite.
  for (const auto& bad : std::vector<std::vector<double>>{
           {0.5, 0.4}, {-0.1, 0.5}, {0.5, 2.0001}, {std::numeric_limits<double>::quiet_NaN()}}) {
    const auto r = run(2, bad);
    EXPECT_EQ(r.status, eom::Status::invalid_argument);
    EXPECT_EQ(r.evaluations, 0);
    EXPECT_TRUE(seen.empty());
  }
  int step_ends = 0;
  const auto plain = eom::dopri5<SP>(0, 2, x0, nullptr, p.data(), tolerance(1e-9),
                                     [&](double, const auto&) { ++step_ends; });
  EXPECT_EQ(step_ends, plain.accepted + 1);
  // t0, interior times, a repeated time and the end time: exactly these, in order, never a step
  // end; t0 and t1 give the exact start and end states.
  const std::vector<double> times{0.0, 0.3, 0.3, 1.234, 2.0};
  const auto r = run(2, times);
  ASSERT_EQ(r.status, eom::Status::ok);
  ASSERT_EQ(seen.size(), times.size());
  for (std::size_t i = 0; i < times.size(); ++i) EXPECT_EQ(seen[i].first, times[i]);
  EXPECT_EQ(seen.front().second, x0);
  EXPECT_EQ(seen.back().second, r.x);
  EXPECT_EQ(seen[1].second, seen[2].second);
  // Stepping is not affected, and the dense output costs no evaluation.
  EXPECT_EQ(r.x, plain.x);
  EXPECT_EQ(r.accepted, plain.accepted);
  EXPECT_EQ(r.rejected, plain.rejected);
  EXPECT_EQ(r.evaluations, plain.evaluations);
}

TEST(Dopri5, RefusesBadInputBeforeAnyStep) {
  const auto p = SP::parameter_values;
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  auto run = [&](double t0, double t1, eom::StateOf<2> x, eom::AdaptiveOptions opt) {
    int calls = 0;
    const auto r = eom::dopri5<SP>(t0, t1, x, nullptr, p.data(), opt, [&](double, const auto&) { ++calls; });
    EXPECT_EQ(r.evaluations, 0);
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
  EXPECT_EQ(run(1, 0, x0, good), eom::Status::invalid_argument) << "end before start";
  EXPECT_EQ(run(0, nan, x0, good), eom::Status::invalid_argument);
  auto x = x0;
  x[1] = inf;
  EXPECT_EQ(run(0, 1, x, good), eom::Status::invalid_argument) << "non-finite initial state";
}

TEST(Dopri5, StopsAtTheStepLimit) {
  const auto p = SP::parameter_values;
  eom::AdaptiveOptions o;
  o.rtol = o.atol = 1e-12;
  o.max_steps = 10;
  const auto r = eom::dopri5<SP>(0, 10, x0, nullptr, p.data(), o, none);
  EXPECT_EQ(r.status, eom::Status::step_limit);
  EXPECT_EQ(r.accepted + r.rejected, 10);
  EXPECT_LT(r.t, 10.0);
  for (double v : r.x) EXPECT_TRUE(std::isfinite(v));
}

TEST(Dopri5, SingularDynamicsStopWithStatus) {
  using CC = eom::Reference<eom::models::ClosedChain5>;
  auto p = CC::parameter_values;
  p[21] = 5.0;  // dead point: stretched straight between pins 5 m apart
  const eom::StateOf<5> straight{};
  const auto r = eom::dopri5<CC>(0, 1, straight, nullptr, p.data(), eom::AdaptiveOptions{}, none);
  EXPECT_EQ(r.status, eom::Status::singular_dynamics);
  EXPECT_EQ(r.t, 0.0);
}

TEST(Dopri5, ProjectionKeepsTheClosedChainOnItsConstraints) {
  using CC = eom::Reference<eom::models::ClosedChain5>;
  const auto p = CC::parameter_values;
  eom::StateOf<5> x{};
  for (int i = 0; i < 5; ++i) x[i] = eom::models::ClosedChain5::initial_q[i];
  eom::Stabilization stab;
  stab.method = eom::Stabilization::Method::projection;
  eom::AdaptiveOptions o;
  o.rtol = o.atol = 1e-8;
  double worst = 0;
  const auto r = eom::dopri5<CC>(0, 5, x, nullptr, p.data(), o, [&](double, const eom::StateOf<5>& s) {
    worst = std::max(worst, eom::constraint_residuals<CC>(s.data(), s.data() + 5, p.data())[0]);
  }, stab);
  ASSERT_EQ(r.status, eom::Status::ok);
  EXPECT_LE(worst, 1e-12);
  record_figure("max_abs_phi", worst);
}

}  // namespace
