// The variational (midpoint, SHAKE/RATTLE) integrator: bounded energy error without secular drift
// over 10⁶ steps, measured order 2 (free and constrained, forced), constraints held at round-off,
// bad input refused before any step. Figures next to the assertions were measured with GCC 12,
// -O2 (Release), on this build's kernels.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include <eom/integration/rk4.hpp>
#include <eom/integration/variational.hpp>
#include <eom/reference/reference.hpp>

#include "record.hpp"

#include <models/cartesian_pendulum.hpp>
#include <models/chain.hpp>
#include <models/spring_pendulum.hpp>
// The generated kernels of the spring pendulum (library target `spring_pendulum`, linked by this
// test): ~50x faster than the reference, used for the 10⁶-step runs.
#include "spring_pendulum.hpp"

namespace {

using SP = eom::Reference<eom::models::SpringPendulum>;
using SPgen = spring_pendulum::Kernels;
using CP = eom::Reference<eom::models::CartesianPendulum>;
using CC = eom::Reference<eom::models::ClosedChain5>;
constexpr eom::StateOf<2> sp_x0{0.55, 0.0, 0.01, 2.5};  // (r, θ, ṙ, θ̇), the paper's start
constexpr auto none = [](auto&&...) {};

template <class K> double energy(const eom::StateOf<K::nq>& x, const double* p) {
  return K::kinetic_energy(x.data(), x.data() + K::nq, p) + K::potential_energy(x.data(), p);
}

template <int n> double max_diff(const eom::StateOf<n>& a, const eom::StateOf<n>& b) {
  double d = 0;
  for (int i = 0; i < 2 * n; ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

eom::StateOf<5> closed_chain_rest() {
  eom::StateOf<5> x{};
  for (int i = 0; i < 5; ++i) x[i] = eom::models::ClosedChain5::initial_q[i];
  return x;
}

// max |E − E0| over the first and the last 10% of the samples, and the least-squares slope of
// E − E0 against time (samples h apart).
struct Drift {
  double first = 0, last = 0, slope = 0;
};
Drift drift_of(const std::vector<double>& err, double h) {
  Drift d;
  const std::size_t tenth = err.size() / 10;
  for (std::size_t i = 0; i < tenth; ++i) d.first = std::max(d.first, std::abs(err[i]));
  for (std::size_t i = err.size() - tenth; i < err.size(); ++i) d.last = std::max(d.last, std::abs(err[i]));
  double st = 0, se = 0, stt = 0, ste = 0;
  const double N = static_cast<double>(err.size());
  for (std::size_t i = 0; i < err.size(); ++i) {
    const double t = h * static_cast<double>(i);
    st += t, se += err[i], stt += t * t, ste += t * err[i];
  }
  d.slope = (N * ste - st * se) / (N * stt - st * st);
  return d;
}

TEST(Variational, GeneratedAndReferenceKernelsTakeTheSameSteps) {
  // 100 steps of 10 ms: the two kernel sets agree to round-off. Measured 5.5e-15.
  const auto p = SP::parameter_values;
  const auto a = eom::variational<SP>(0, 1, 100, sp_x0, nullptr, p.data(), none);
  const auto b = eom::variational<SPgen>(0, 1, 100, sp_x0, nullptr, p.data(), none);
  ASSERT_EQ(a.status, eom::Status::ok);
  ASSERT_EQ(b.status, eom::Status::ok);
  EXPECT_EQ(a.steps, 100);
  EXPECT_EQ(a.t, 1.0);
  EXPECT_LE(max_diff<2>(a.x, b.x), 1e-12);
  // Simplified Newton with a finite-difference Jacobian: measured 2.98 iterations per step on
  // average, at most 3.
  EXPECT_LE(a.max_step_iterations, 4);
  EXPECT_GT(a.evaluations, 0);
}

// The undamped spring pendulum, h = 10 ms (hω ≈ 0.09 for the spring mode), 10⁶ steps = 10⁴ s
// ≈ 14 000 spring periods, generated kernels.
constexpr long long_steps = 1000000;
constexpr double long_h = 1e-2;

TEST(Variational, SpringPendulumEnergyErrorBoundedWithoutDriftOver1e6Steps) {
  const auto p = SPgen::parameter_values;
  const double t1 = long_h * static_cast<double>(long_steps);
  const double E0 = energy<SPgen>(sp_x0, p.data());  // 0.5486 J
  std::vector<double> err;
  err.reserve(long_steps + 1);
  const auto r = eom::variational<SPgen>(0, t1, long_steps, sp_x0, nullptr, p.data(),
                                         [&](double, const eom::StateOf<2>& x) {
                                           err.push_back(energy<SPgen>(x, p.data()) - E0);
                                         });
  ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status) << " at t = " << r.t;
  ASSERT_EQ(err.size(), static_cast<std::size_t>(long_steps + 1));
  const Drift d = drift_of(err, long_h);
  record_figure("energy_error_first_10pct", d.first);
  record_figure("energy_error_last_10pct", d.last);
  record_figure("energy_error_slope_per_s", d.slope);
  // Bounded: the O(h²) oscillation. Measured max |E − E0| = 2.309e-4 J (4.2e-4 of E0) over the
  // first 10% and 2.309e-4 J over the last 10%; bound 5e-4 J (2.2x margin).
  EXPECT_LE(d.first, 5e-4);
  EXPECT_LE(d.last, 5e-4);
  // No secular drift: the last tenth's worst error equals the first's (measured ratio 1.000; RK4
  // at the same step grows 10x, see below), bound 1.05.
  EXPECT_LE(d.last, 1.05 * d.first);
  // Linear-fit slope: measured −6.9e-12 J/s, i.e. −6.9e-8 J over the whole run = 3e-4 of the
  // oscillation's amplitude; bound 1e-2 of the amplitude over the run (33x margin).
  EXPECT_LE(std::abs(d.slope) * t1, 1e-2 * d.first);
  // Newton cost: measured 2.98 iterations and 31.9 kernel calls per step on average.
  EXPECT_LE(r.max_step_iterations, 4);
}

TEST(Variational, Rk4AtTheSameStepDriftsSoTheDriftCheckHasTeeth) {
  // The same run with RK4: its energy error is dissipative and accumulates. Measured max
  // |E − E0| 5.8e-4 J over the first 10% and 5.8e-3 J over the last 10% (10x growth).
  const auto p = SPgen::parameter_values;
  const double t1 = long_h * static_cast<double>(long_steps);
  const double E0 = energy<SPgen>(sp_x0, p.data());
  std::vector<double> err;
  err.reserve(long_steps + 1);
  const auto r = eom::rk4<SPgen>(0, t1, long_steps, sp_x0, nullptr, p.data(),
                                 [&](double, const eom::StateOf<2>& x) {
                                   err.push_back(energy<SPgen>(x, p.data()) - E0);
                                 });
  ASSERT_EQ(r.status, eom::Status::ok);
  const Drift d = drift_of(err, long_h);
  EXPECT_GT(d.last, 5 * d.first);  // fails the variational integrator's 1.05 criterion
}

TEST(Variational, MeasuredConvergenceOrderIsTwo) {
  // Errors in (q, q̇) at t = 2 s for N = 100 … 1600 steps against RK4 with N = 51200 (error
  // ~1e-12). Measured errors 4.72e-2, 1.19e-2, 2.99e-3, 7.49e-4, 1.87e-4; orders 1.983, 1.996,
  // 1.999, 2.000.
  const auto p = SP::parameter_values;
  const double t1 = 2.0;
  const auto ref = eom::rk4<SP>(0, t1, 51200, sp_x0, nullptr, p.data(), none);
  ASSERT_EQ(ref.status, eom::Status::ok);
  double prev = 0;
  for (long n = 100; n <= 1600; n *= 2) {
    const auto r = eom::variational<SP>(0, t1, n, sp_x0, nullptr, p.data(), none);
    ASSERT_EQ(r.status, eom::Status::ok);
    const double e = max_diff<2>(r.x, ref.x);
    if (prev > 0) {
      EXPECT_NEAR(std::log2(prev / e), 2.0, 0.3) << "N = " << n << ", error " << e;
    }
    prev = e;
  }
}

TEST(Variational, ForcedConstrainedClosedChainConvergesWithOrderTwo) {
  // The closed chain with its drive torque and hinge dampers (discrete Lagrange–d'Alembert) and
  // two loop constraints (SHAKE/RATTLE): (q, q̇) at t = 1 s for N = 50 … 400 against RK4 with
  // projection at h = 0.25 ms. Measured errors 5.05e-2, 1.24e-2, 3.07e-3, 7.68e-4; orders 2.031,
  // 2.007, 2.002. (A wrong sign or weight of Q or of the constraint forces would show as order 0.)
  const auto p = CC::parameter_values;
  eom::Stabilization stab;
  stab.method = eom::Stabilization::Method::projection;
  const double t1 = 1.0;
  const auto ref = eom::rk4<CC>(0, t1, 4000, closed_chain_rest(), nullptr, p.data(), none, stab);
  ASSERT_EQ(ref.status, eom::Status::ok);
  double prev = 0;
  for (long n = 50; n <= 400; n *= 2) {
    const auto r = eom::variational<CC>(0, t1, n, closed_chain_rest(), nullptr, p.data(), none);
    ASSERT_EQ(r.status, eom::Status::ok);
    const double e = max_diff<5>(r.x, ref.x);
    if (prev > 0) {
      EXPECT_NEAR(std::log2(prev / e), 2.0, 0.3) << "N = " << n << ", error " << e;
    }
    prev = e;
  }
}

TEST(Variational, CartesianPendulumStaysOnItsConstraintWithBoundedEnergy) {
  // 10⁵ steps of 1 ms (100 s, ~55 swings of ±57°).
  const auto p = CP::parameter_values;
  const double l = p[1], th = 1.0, w = 2.0;
  const eom::StateOf<2> x0{l * std::sin(th), -l * std::cos(th), l * w * std::cos(th), l * w * std::sin(th)};
  const long steps = 100000;
  const double E0 = energy<CP>(x0, p.data());  // −4.440 J
  double worst_phi = 0, worst_v = 0, first = 0, last = 0;
  long k = 0;
  const auto r = eom::variational<CP>(0, 100, steps, x0, nullptr, p.data(), [&](double, const eom::StateOf<2>& x) {
    double phi;
    CP::constraint_residual(x.data(), p.data(), &phi);
    worst_phi = std::max(worst_phi, std::abs(phi));
    worst_v = std::max(worst_v, std::abs(2 * (x[0] * x[2] + x[1] * x[3])));  // C q̇
    const double e = std::abs(energy<CP>(x, p.data()) - E0);
    if (k < steps / 10) first = std::max(first, e);
    if (k > steps - steps / 10) last = std::max(last, e);
    ++k;
  });
  ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status) << " at t = " << r.t;
  record_figure("cartesian_pendulum_max_phi", worst_phi);
  // Measured max |φ| 2.2e-16 m² and max |C q̇| 6.7e-16 (round-off of l² = 0.64); bounds 1e-14.
  EXPECT_LE(worst_phi, 1e-14);
  EXPECT_LE(worst_v, 1e-14);
  // Measured max |E − E0| 2.581e-5 J over both the first and the last 10%; bounds 5e-5 J (1.9x)
  // and last ≤ 1.05 first (measured ratio 1.000).
  EXPECT_LE(first, 5e-5);
  EXPECT_LE(last, 1.05 * first);
  EXPECT_LE(r.max_step_iterations, 3);  // measured 2
}

TEST(Variational, DampedDrivenClosedChainStaysOnItsConstraints) {
  // 10⁴ steps of 5 ms (50 s), driven and damped (energy is not conserved: |φ| only).
  const auto p = CC::parameter_values;
  double worst_phi = 0, worst_v = 0, swing = 0;
  const auto r = eom::variational<CC>(0, 50, 10000, closed_chain_rest(), nullptr, p.data(),
                                      [&](double, const eom::StateOf<5>& x) {
                                        const auto res = eom::constraint_residuals<CC>(x.data(), x.data() + 5, p.data());
                                        worst_phi = std::max(worst_phi, res[0]);
                                        worst_v = std::max(worst_v, res[1]);
                                        swing = std::max(swing, std::abs(x[2]));
                                      });
  ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status) << " at t = " << r.t;
  record_figure("closed_chain_max_phi", worst_phi);
  // Measured max |φ| 1.3e-15 m and max |C q̇| 4.0e-15 m/s; bounds 1e-13 (the projection test's
  // tolerance in test_chain; with RK4 and no stabilization |φ| reaches 1.8e-3 in 10 s).
  EXPECT_LE(worst_phi, 1e-13);
  EXPECT_LE(worst_v, 1e-13);
  EXPECT_GT(swing, 0.05) << "the middle link really moves";  // measured 1.76 rad
  EXPECT_LE(r.max_step_iterations, 5);                        // measured 4
}

// Every refusal happens before any step: no observer call, state and time as given.
template <class K>
void expect_refused(double t0, double t1, long steps, const eom::StateOf<K::nq>& x0, eom::Status expected,
                    const eom::VariationalOptions& opt = {}) {
  const auto p = K::parameter_values;
  int calls = 0;
  const auto r = eom::variational<K>(t0, t1, steps, x0, nullptr, p.data(), [&](auto&&...) { ++calls; }, opt);
  EXPECT_EQ(r.status, expected) << eom::to_string(r.status);
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(r.steps, 0);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(std::memcmp(r.x.data(), x0.data(), sizeof x0), 0);  // bitwise: NaN entries too
  EXPECT_TRUE(r.t == t0 || (std::isnan(r.t) && std::isnan(t0)));
}

TEST(Variational, RefusesBadInputBeforeAnyStep) {
  using S = eom::Status;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  expect_refused<SP>(0, 1, 0, sp_x0, S::invalid_argument);    // no steps
  expect_refused<SP>(0, 1, -5, sp_x0, S::invalid_argument);   // negative count
  expect_refused<SP>(1, 1, 10, sp_x0, S::invalid_argument);   // t1 = t0
  expect_refused<SP>(1, 0, 10, sp_x0, S::invalid_argument);   // t1 < t0 (negative step)
  expect_refused<SP>(nan, 1, 10, sp_x0, S::invalid_argument);
  expect_refused<SP>(0, inf, 10, sp_x0, S::invalid_argument);
  expect_refused<SP>(-std::numeric_limits<double>::max(), std::numeric_limits<double>::max(), 1, sp_x0,
                     S::invalid_argument);  // the step overflows to +Inf
  expect_refused<SP>(1e10, 1e10 + 1, 1000000000, sp_x0, S::invalid_argument);  // t0 + h == t0
  for (int i = 0; i < 4; ++i) {
    auto x = sp_x0;
    x[i] = i % 2 ? inf : nan;
    expect_refused<SP>(0, 1, 10, x, S::invalid_argument);
  }
  eom::VariationalOptions bad;
  bad.tolerance = 0;
  expect_refused<SP>(0, 1, 10, sp_x0, S::invalid_argument, bad);
  bad = {};
  bad.tolerance = nan;
  expect_refused<SP>(0, 1, 10, sp_x0, S::invalid_argument, bad);
  bad = {};
  bad.max_iterations = 0;
  expect_refused<SP>(0, 1, 10, sp_x0, S::invalid_argument, bad);
  bad = {};
  bad.initial_tolerance = -1;
  expect_refused<SP>(0, 1, 10, sp_x0, S::invalid_argument, bad);

  // Constrained models started off their constraints (default tolerance 1e-8).
  const double l = CP::parameter_values[1];
  expect_refused<CP>(0, 1, 10, {l + 1e-6, 0, 0, 0}, S::inconsistent_initial_state);  // φ ≈ 1.6e-6
  expect_refused<CP>(0, 1, 10, {0, -l, 0, 1e-3}, S::inconsistent_initial_state);     // radial q̇
  auto chain = closed_chain_rest();
  chain[0] += 1e-4;
  expect_refused<CC>(0, 1, 10, chain, S::inconsistent_initial_state);
  // ... and the same starts are accepted when on them.
  const auto p = CP::parameter_values;
  EXPECT_EQ(eom::variational<CP>(0, 0.01, 10, {0, -l, 0.1, 0}, nullptr, p.data(), none).status, S::ok);
}

TEST(Variational, ReportsNewtonFailureAndSingularity) {
  // One Newton iteration is never enough to meet the 1e-12 tolerance: the run stops at the first
  // step with the last good state.
  const auto p = SP::parameter_values;
  eom::VariationalOptions one;
  one.max_iterations = 1;
  int calls = 0;
  const auto r = eom::variational<SP>(0, 1, 10, sp_x0, nullptr, p.data(), [&](auto&&...) { ++calls; }, one);
  EXPECT_EQ(r.status, eom::Status::nonlinear_solve_failed);
  EXPECT_EQ(r.failure, eom::VariationalFailure::no_convergence);
  EXPECT_EQ(r.t, 0.0);
  EXPECT_EQ(r.x, sp_x0);
  EXPECT_EQ(calls, 1);  // the initial state only

  // The closed chain stretched straight between pins 5 m apart: C loses rank (dead point), so
  // the Newton matrix [∂G/∂q, Cᵀ; C, 0] is singular.
  auto ps = CC::parameter_values;
  ps[21] = 5.0;
  const eom::StateOf<5> straight{};
  const auto s = eom::variational<CC>(0, 1, 10, straight, nullptr, ps.data(), none);
  EXPECT_EQ(s.status, eom::Status::singular_dynamics);
  EXPECT_EQ(s.failure, eom::VariationalFailure::singular_iteration_matrix);
  EXPECT_EQ(s.steps, 0);
}

}  // namespace
