// The high-precision reference trajectories (eom/integration/high_precision.hpp): the chaotic double pendulum
// in double-double, checked for self-consistency (two tolerances), conservation of energy to
// ~1e-28, and agreement with double-precision integration where that is reliable.
#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include <eom/integration/high_precision.hpp>

#include <models/double_pendulum.hpp>
#include <models/spring_pendulum.hpp>

namespace {

using DP = eom::models::DoublePendulum;
using Wide = eom::Reference<DP, dd_real>;
using WideState = std::array<dd_real, 4>;

std::array<dd_real, 5> wide_parameters() {
  std::array<dd_real, 5> p;
  for (int i = 0; i < 5; ++i) p[i] = dd_real(DP::parameter_values[i]);
  return p;
}

// States of the chaotic start (a1 = 2.0, a2 = 2.5, at rest) at the given times.
std::vector<WideState> chaotic_run(const std::vector<double>& times, double tolerance, long* steps) {
  const auto p = wide_parameters();
  const WideState x0{dd_real(2.0), dd_real(2.5), dd_real(0.0), dd_real(0.0)};
  std::vector<WideState> out;
  eom::ExtrapolationOptions opt;
  opt.tolerance = tolerance;
  const auto r = eom::extrapolate<DP, dd_real>(0.0, x0, times, nullptr, p.data(), opt,
                                               [&](double, const WideState& x) { out.push_back(x); });
  EXPECT_EQ(r.status, eom::Status::ok);
  if (steps) *steps = r.accepted;
  return out;
}

double max_difference(const WideState& a, const WideState& b) {
  double e = 0;
  for (int i = 0; i < 4; ++i) e = std::max(e, to_double(abs(a[i] - b[i])));
  return e;
}

TEST(HighPrecision, ChaoticDoublePendulumIsSelfConsistentAcrossTolerances) {
  const std::vector<double> times{5.0, 10.0};
  long loose_steps = 0, tight_steps = 0;
  const auto loose = chaotic_run(times, 1e-26, &loose_steps);
  const auto tight = chaotic_run(times, 1e-30, &tight_steps);
  ASSERT_EQ(loose.size(), 2u);
  ASSERT_EQ(tight.size(), 2u);
  const double d5 = max_difference(loose[0], tight[0]), d10 = max_difference(loose[1], tight[1]);
  std::printf("  tol 1e-26 (%ld steps) vs 1e-30 (%ld steps): |dx| = %.2e at t = 5, %.2e at t = 10\n",
              loose_steps, tight_steps, d5, d10);
  // Local errors of 1e-26 grow ~1e6-fold every 5 time units; far below what double can resolve.
  EXPECT_LT(d5, 1e-17);
  EXPECT_LT(d10, 1e-11);
  EXPECT_GT(d10, 0.0);  // the tolerance does something: the runs are not identical
}

TEST(HighPrecision, ChaoticDoublePendulumConservesEnergy) {
  const auto p = wide_parameters();
  const WideState x0{dd_real(2.0), dd_real(2.5), dd_real(0.0), dd_real(0.0)};
  auto energy = [&](const WideState& x) {
    return Wide::kinetic_energy(x.data(), x.data() + 2, p.data()) +
           Wide::potential_energy(x.data(), p.data());
  };
  const dd_real e0 = energy(x0);
  std::vector<double> times;
  for (int i = 1; i <= 20; ++i) times.push_back(0.5 * i);
  double worst = 0;
  eom::ExtrapolationOptions opt;
  opt.tolerance = 1e-30;
  const auto r = eom::extrapolate<DP, dd_real>(
      0.0, x0, times, nullptr, p.data(), opt,
      [&](double, const WideState& x) { worst = std::max(worst, to_double(abs(energy(x) - e0))); });
  ASSERT_EQ(r.status, eom::Status::ok);
  std::printf("  max |E - E0| over 10 s: %.2e J (E0 = %.3f J), %ld evaluations\n", worst,
              to_double(e0), r.evaluations);
  // Relative: 671 steps of local error ≤ 1e-30 (relative to 1 + |x|) give ~1e-27 of E0.
  EXPECT_LT(worst / to_double(e0), 1e-26);
}

// Where double precision is reliable (the non-chaotic spring pendulum over 2 s): the dd_real
// trajectory agrees with the same extrapolation run in double at tolerance 1e-14.
TEST(HighPrecision, AgreesWithDoublePrecisionExtrapolation) {
  using SP = eom::models::SpringPendulum;
  std::array<dd_real, 4> pw;
  std::array<double, 4> pd;
  for (int i = 0; i < 4; ++i) pd[i] = SP::parameter_values[i], pw[i] = dd_real(pd[i]);
  const std::array<dd_real, 4> xw{dd_real(0.55), dd_real(0.0), dd_real(0.01), dd_real(2.5)};
  const std::array<double, 4> xd{0.55, 0.0, 0.01, 2.5};
  const std::vector<double> times{2.0};
  std::array<dd_real, 4> wide{};
  std::array<double, 4> narrow{};
  eom::ExtrapolationOptions wide_opt, narrow_opt;
  wide_opt.tolerance = 1e-28;
  narrow_opt.tolerance = 1e-14;
  narrow_opt.columns = 6;
  eom::extrapolate<SP, dd_real>(0.0, xw, times, nullptr, pw.data(), wide_opt,
                                [&](double, const auto& x) { wide = x; });
  const auto r = eom::extrapolate<SP, double>(0.0, xd, times, nullptr, pd.data(), narrow_opt,
                                              [&](double, const auto& x) { narrow = x; });
  ASSERT_EQ(r.status, eom::Status::ok);
  double e = 0;
  for (int i = 0; i < 4; ++i) e = std::max(e, std::abs(narrow[i] - to_double(wide[i])));
  std::printf("  double vs double-double at t = 2: %.2e\n", e);
  EXPECT_LT(e, 1e-11);
}

// A first step far too long for a stiff model (the midpoint chain blows up to non-finite
// states) is rejected and retried shorter, not reported as a failure; a state where the dynamics
// are singular stops at once.
TEST(HighPrecision, RecoversFromWildTrialStepsAndStopsWhereSingular) {
  using SP = eom::models::SpringPendulum;
  const std::array<dd_real, 4> p{dd_real(1e-3), dd_real(1e6), dd_real(0.5), dd_real(9.81)};
  const std::array<dd_real, 4> x0{dd_real(0.5 + 9.81e-9), dd_real(0.0), dd_real(0.0), dd_real(2.5)};
  eom::ExtrapolationOptions opt;
  opt.tolerance = 1e-26;
  const std::vector<double> times{0.01};
  const auto r = eom::extrapolate<SP, dd_real>(0.0, x0, times, nullptr, p.data(), opt,
                                               [](double, const auto&) {});
  EXPECT_EQ(r.status, eom::Status::ok);
  EXPECT_GT(r.rejected, 0);
  std::printf("  stiff start: %ld accepted, %ld rejected\n", r.accepted, r.rejected);

  const std::array<dd_real, 4> singular{dd_real(0.0), dd_real(0.3), dd_real(0.0), dd_real(1.0)};
  const auto s = eom::extrapolate<SP, dd_real>(0.0, singular, times, nullptr, p.data(), opt,
                                               [](double, const auto&) {});
  EXPECT_EQ(s.status, eom::Status::singular_dynamics);  // r = 0: M = diag(m, m r²) singular
  EXPECT_EQ(s.accepted + s.rejected, 0);
}

TEST(HighPrecision, RefusesBadInput) {
  const auto p = wide_parameters();
  const WideState x0{dd_real(2.0), dd_real(2.5), dd_real(0.0), dd_real(0.0)};
  auto status = [&](std::vector<double> times, eom::ExtrapolationOptions opt, WideState x) {
    long calls = 0;
    const auto r = eom::extrapolate<DP, dd_real>(0.0, x, times, nullptr, p.data(), opt,
                                                 [&](double, const WideState&) { ++calls; });
    EXPECT_EQ(r.evaluations, 0);
    EXPECT_EQ(calls, 0);
    return r.status;
  };
  const eom::ExtrapolationOptions good;
  EXPECT_EQ(status({1.0, 0.5}, good, x0), eom::Status::invalid_argument);  // not ascending
  EXPECT_EQ(status({0.0}, good, x0), eom::Status::invalid_argument);       // not after t0
  EXPECT_EQ(status({NAN}, good, x0), eom::Status::invalid_argument);
  auto bad = good;
  bad.tolerance = 0;
  EXPECT_EQ(status({1.0}, bad, x0), eom::Status::invalid_argument);
  bad = good;
  bad.columns = 1;
  EXPECT_EQ(status({1.0}, bad, x0), eom::Status::invalid_argument);
  WideState nan_state = x0;
  nan_state[1] = dd_real(NAN);
  EXPECT_EQ(status({1.0}, good, nan_state), eom::Status::invalid_argument);
}

}  // namespace
