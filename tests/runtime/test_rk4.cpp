// RK4 (paper eq. 27): measured convergence order, energy behaviour and failure statuses.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>

#include <eom/reference/reference.hpp>

#include "record.hpp"
#include <eom/integration/rk4.hpp>

#include <models/cartesian_pendulum.hpp>
#include <models/spring_pendulum.hpp>

namespace {

using SP = eom::Reference<eom::models::SpringPendulum>;
constexpr eom::StateOf<2> x0{0.55, 0.0, 0.01, 2.5};  // (r, θ, ṙ, θ̇), the paper's start

eom::StateOf<2> solve(long steps, double t1) {
  const auto p = SP::parameter_values;
  const auto r = eom::rk4<SP>(0.0, t1, steps, x0, nullptr, p.data(), [](double, const auto&) {});
  EXPECT_EQ(r.status, eom::Status::ok);
  EXPECT_EQ(r.steps, steps);
  EXPECT_EQ(r.t, t1);
  return r.x;
}

double max_diff(const eom::StateOf<2>& a, const eom::StateOf<2>& b) {
  double d = 0;
  for (int i = 0; i < 4; ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

TEST(Rk4, MeasuredConvergenceOrderIsFour) {
  // Errors at h = T/N for N = 200 ... 1600 against N = 51200 (whose own error is ~(1/32)^4 of the
  // finest one's); the observed order is log2(e(h) / e(h/2)).
  const double t1 = 2.0;
  const auto ref = solve(51200, t1);
  double prev = 0;
  for (long n = 200; n <= 1600; n *= 2) {
    const double e = max_diff(solve(n, t1), ref);
    if (prev > 0) {
      const double order = std::log2(prev / e);
      EXPECT_NEAR(order, 4.0, 0.2) << "N = " << n << ", error " << e;
    }
    prev = e;
  }
}

TEST(Rk4, SpringPendulumEnergyErrorStaysSmall) {
  // h = 1e-3 over the paper's 10 s: RK4's energy error is O(h^4). Measured: 1.5e-10 relative to
  // E0 = 0.5486 J; the bound 1e-9 leaves a margin of about 7x.
  const auto p = SP::parameter_values;
  const double E0 = SP::kinetic_energy(x0.data(), x0.data() + 2, p.data()) +
                    SP::potential_energy(x0.data(), p.data());
  double worst = 0;
  const auto r = eom::rk4<SP>(0.0, 10.0, 10000, x0, nullptr, p.data(), [&](double, const eom::StateOf<2>& x) {
    const double E = SP::kinetic_energy(x.data(), x.data() + 2, p.data()) + SP::potential_energy(x.data(), p.data());
    worst = std::max(worst, std::abs(E - E0) / std::abs(E0));
  });
  ASSERT_EQ(r.status, eom::Status::ok);
  EXPECT_LT(worst, 1e-9);
  record_figure("relative_energy_error", worst);
}

TEST(Rk4, RejectsInvalidArguments) {
  const auto p = SP::parameter_values;
  auto none = [](double, const auto&) {};
  EXPECT_EQ((eom::rk4<SP>(0, 1, 0, x0, nullptr, p.data(), none).status), eom::Status::invalid_argument);
  EXPECT_EQ((eom::rk4<SP>(1, 0, 10, x0, nullptr, p.data(), none).status), eom::Status::invalid_argument);
  auto bad = x0;
  bad[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ((eom::rk4<SP>(0, 1, 10, bad, nullptr, p.data(), none).status), eom::Status::invalid_argument);
}

TEST(Rk4, RefusesAStartOffTheConstraints) {
  // The Cartesian pendulum at the origin violates x² + y² = l²: refused before any step.
  using CP = eom::Reference<eom::models::CartesianPendulum>;
  const auto p = CP::parameter_values;
  const eom::StateOf<2> origin{0, 0, 0, 0};
  int calls = 0;
  const auto r = eom::rk4<CP>(0, 1, 10, origin, nullptr, p.data(), [&](double, const auto&) { ++calls; });
  EXPECT_EQ(r.status, eom::Status::inconsistent_initial_state);
  EXPECT_EQ(r.steps, 0);
  EXPECT_EQ(calls, 0);
}

}  // namespace
