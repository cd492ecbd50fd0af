// Dormand–Prince 5(4): achieved error scales with the tolerance, bookkeeping is exact, bad input
// is refused before any step, and failures stop with a status.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <eom/dopri5.hpp>
#include <eom/reference.hpp>

#include <models/chain.hpp>
#include "record.hpp"
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
