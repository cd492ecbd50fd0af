// The spherical pendulum in polar angles passing near its coordinate singularity θ = 0
// (docs/hard-cases/, section 1), against the same motion in Cartesian coordinates integrated in
// double-double: near the pole the adaptive methods keep the accuracy they reach far from it,
// at a step count that grows with log(1/θ_min); where the pole cannot be resolved, or at the
// pole itself, the run stops with a status, never NaN. 10 s of motion, ~10 pole passages.
// Figures measured with GCC 12, Release.
#include <gtest/gtest.h>

#include <cmath>

#include "hard_cases.hpp"

namespace {

using namespace hard_cases;
constexpr double theta0 = 1.0;

const std::vector<double>& times() {
  static const auto t = uniform_times(0.05, 10.0);
  return t;
}

// Error bound of a run at tolerance tol over 10 s of this integrable motion: the local error per
// step is held to ~tol and accumulates roughly linearly over the ~10 passages. Measured
// position errors 1.1…8.8 × tol for DOP853 and Taylor at 1e-6 and 1e-10, for every θ_min from 0.1
// (far from the pole) to 1e-8, and for the Cartesian form; bound 20·tol.
constexpr double accuracy_factor = 20;

TEST(HardSphericalPendulum, PolarFormKeepsItsAccuracyNearThePole) {
  for (double theta_min : {1e-2, 1e-4, 1e-6, 1e-8}) {
    const auto s = spherical_start(theta0, theta_min);
    const auto ref = spherical_reference(s, times());
    ASSERT_EQ(ref.size(), times().size());
    for (auto method : {eom::Method::dop853, eom::Method::taylor})
      for (double tol : {1e-6, 1e-10}) {
        const auto r = polar_run(method, tol, 0, s, times(), ref);
        SCOPED_TRACE(testing::Message() << eom::to_string(method) << " tol " << tol << " θ_min " << theta_min);
        ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status);
        EXPECT_TRUE(r.finite);
        EXPECT_LE(r.position_error, accuracy_factor * tol);
        // The conserved quantities, to the same order (m = l = 1: L_z in units of m l² √(g/l)
        // ≈ 3.1, E in m g l = 9.81): measured |ΔL_z| ≤ 5 tol, |ΔE| ≤ 52 tol.
        EXPECT_LE(r.lz_error, accuracy_factor * tol * 3.13);
        EXPECT_LE(r.energy_error, accuracy_factor * tol * 9.81);
      }
  }
}

TEST(HardSphericalPendulum, StepsGrowLogarithmicallyInTheDistanceToThePole) {
  // The passage is self-similar on the time scale θ_min/v, so each decade of θ_min costs an
  // adaptive method about the same number of extra steps. DOP853 at 1e-6: measured steps
  // (accepted + rejected) 469, 811, 1112, 1434 at θ_min = 1e-2, 1e-4, 1e-6, 1e-8: increments
  // 342, 301, 322 per two decades.
  std::vector<long> steps;
  for (double theta_min : {1e-2, 1e-4, 1e-6, 1e-8}) {
    const auto s = spherical_start(theta0, theta_min);
    const auto ref = spherical_reference(s, times());
    ASSERT_EQ(ref.size(), times().size());
    const auto r = polar_run(eom::Method::dop853, 1e-6, 0, s, times(), ref);
    ASSERT_EQ(r.status, eom::Status::ok);
    steps.push_back(r.accepted + r.rejected);
  }
  for (int i = 0; i + 1 < 3; ++i) {
    const double d0 = static_cast<double>(steps[i + 1] - steps[i]);
    const double d1 = static_cast<double>(steps[i + 2] - steps[i + 1]);
    EXPECT_GT(d0, 0);
    EXPECT_GT(d1, 0);
    // Equal increments per two decades, within a factor 1.5 (not a power law in 1/θ_min, which
    // would multiply them by 100 each time).
    EXPECT_LE(std::max(d0, d1) / std::min(d0, d1), 1.5) << steps[i] << " " << steps[i + 1] << " " << steps[i + 2];
  }
}

TEST(HardSphericalPendulum, UnresolvablePolePassageEndsWellOrWithStatus) {
  // θ_min = 1e-12 and 1e-20: the swing of φ takes ~θ_min/v, at or below the resolution of t.
  // Measured: DOP853 steps across (ok, errors 4.5e-10, 1.0e-9), Taylor stops with
  // step_size_underflow, RK4 (h = 1 ms) with singular_dynamics (φ̈ overflows at a stage).
  for (double theta_min : {1e-12, 1e-20}) {
    const auto s = spherical_start(theta0, theta_min);
    const auto ref = spherical_reference(s, times());
    ASSERT_EQ(ref.size(), times().size());
    for (auto method : {eom::Method::dop853, eom::Method::taylor, eom::Method::rk4}) {
      const double tol = 1e-10;
      const auto r = polar_run(method, tol, 1e-3, s, times(), ref);
      SCOPED_TRACE(testing::Message() << eom::to_string(method) << " θ_min " << theta_min);
      EXPECT_TRUE(r.finite) << "never NaN";
      if (r.status == eom::Status::ok)
        EXPECT_LE(r.position_error, method == eom::Method::rk4 ? 1e-9 : accuracy_factor * tol);
      else
        EXPECT_TRUE(r.status == eom::Status::step_size_underflow ||
                    r.status == eom::Status::singular_dynamics)
            << eom::to_string(r.status);
    }
  }
}

TEST(HardSphericalPendulum, PlanarSwingThroughThePoleIsIntegrated) {
  // L_z = 0: θ crosses zero between evaluations (sin²θ > 0 wherever M is evaluated), the motion
  // is the planar pendulum's. Measured errors: DOP853 2.8e-10, Taylor 7.1e-13, RK4 1.5e-11.
  const auto s = spherical_start(theta0, 0.0);
  const auto ref = spherical_reference(s, times());
  ASSERT_EQ(ref.size(), times().size());
  for (auto method : {eom::Method::dop853, eom::Method::taylor, eom::Method::rk4}) {
    const auto r = polar_run(method, 1e-10, 1e-3, s, times(), ref);
    ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(method);
    EXPECT_TRUE(r.finite);
    // RK4 at h = 1 ms: O(h⁴) ~ 1e-12 per unit time; bound 1e-9.
    EXPECT_LE(r.position_error, method == eom::Method::rk4 ? 1e-9 : accuracy_factor * 1e-10) << eom::to_string(method);
  }
}

TEST(HardSphericalPendulum, ExactlyAtThePoleMethodsStopWithStatusOrIntegrate) {
  const eom::StateOf<2> at_pole{0.0, 0.0, 1.0, 0.0};  // M = diag(1, 0)
  const auto& p = Polar::parameter_values;
  double qdd[2];
  EXPECT_FALSE(Polar::forward_dynamics(0, at_pole.data(), at_pole.data() + 2, nullptr, p.data(), qdd));
  EXPECT_TRUE(std::isnan(qdd[0]) && std::isnan(qdd[1]));
  // Every method that needs q̈ at the start stops there.
  for (auto method : {eom::Method::rk4, eom::Method::dopri5, eom::Method::dop853, eom::Method::radau5,
                      eom::Method::taylor}) {
    eom::IntegrationOptions opt;
    opt.method = method;
    opt.step = 1e-3;
    const auto r = eom::integrate<Polar>(0.0, 1.0, at_pole, nullptr, p.data(), opt);
    EXPECT_EQ(r.status, eom::Status::singular_dynamics) << eom::to_string(method);
    EXPECT_EQ(r.t, 0.0) << eom::to_string(method);
    EXPECT_TRUE(all_finite(r.x)) << eom::to_string(method);
  }
  // The variational integrator carries p = M q̇ (p_φ = 0) and uses M at step midpoints, off the
  // pole: it integrates the swing. Second order at h = 1 ms over 1 s: measured position error
  // 7.9e-7; bound 1e-5.
  const auto s = spherical_start_from(at_pole);
  const auto t = uniform_times(0.05, 1.0);
  const auto ref = spherical_reference(s, t);
  ASSERT_EQ(ref.size(), t.size());
  const auto r = polar_run(eom::Method::variational, 0, 1e-3, s, t, ref);
  EXPECT_EQ(r.status, eom::Status::ok);
  EXPECT_TRUE(r.finite);
  EXPECT_LE(r.position_error, 1e-5);
}

}  // namespace
