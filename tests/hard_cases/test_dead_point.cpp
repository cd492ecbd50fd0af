// The closed chain at and near its dead point (docs/hard-cases/, section 4): exactly there every
// method stops at once with Status::singular_dynamics and a finite state; approaching it,
// C M⁻¹Cᵀ becomes ill-conditioned (κ ~ 1/a²) only by a row scaling of C, so q̈ and the
// constraint forces stay accurate to round-off. Figures measured with GCC 12, Release.
#include <gtest/gtest.h>

#include <cmath>

#include "hard_cases.hpp"

namespace {

using namespace hard_cases;

TEST(HardDeadPoint, EveryMethodStopsWithStatusAtTheDeadPoint) {
  const auto stops = dead_point_stops();
  ASSERT_EQ(stops.size(), 6u);
  for (const auto& s : stops) {
    EXPECT_EQ(s.status, eom::Status::singular_dynamics) << eom::to_string(s.method);
    EXPECT_EQ(s.t, 0.0) << eom::to_string(s.method);
    EXPECT_TRUE(s.finite) << eom::to_string(s.method) << ": the start state, not NaN";
  }
}

TEST(HardDeadPoint, NearTheDeadPointTheSolveStaysAccurate) {
  for (double a : {1e-2, 1e-4, 1e-6, 1e-8}) {
    const auto c = near_dead_point(a);
    ASSERT_TRUE(c.ok) << "a = " << a;
    ASSERT_TRUE(c.ok_wide) << "a = " << a;
    // Ill-conditioned indeed: the x-row of C is O(a), so κ(S) ~ 1/a². Measured κ(S)·a² = 0.076.
    EXPECT_GE(c.schur_cond * a * a, 0.01) << "a = " << a;
    // ... by scaling only: measured κ_s(S) = 2.70 for every a ≤ 1e-2.
    EXPECT_LE(c.schur_scaled_cond, 10.0) << "a = " << a;
    // The horizontal constraint force grows like 1/a (measured ‖μ‖∞·a = 2.1 N).
    EXPECT_GE(c.mu_norm * a, 1.0) << "a = " << a;
    // Range-space solve: Cholesky of M then of S, each accurate to n·κ_s·ε on its scaled form
    // (κ_s(M) ≤ κ(M) = 112 here); bound nq·κ(M)·κ_s(S)·ε ≈ 4.6e-13. Measured q̈ errors
    // 3e-16…2.6e-15 and μ errors 1e-16…6e-15 for a = 1e-1…1e-8.
    const double bound = 5 * c.mass_cond * c.schur_scaled_cond * eps;
    EXPECT_LE(c.qdd_error, bound) << "a = " << a;
    EXPECT_LE(c.mu_error, bound) << "a = " << a;
  }
}

}  // namespace
