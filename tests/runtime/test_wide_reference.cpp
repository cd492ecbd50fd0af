// The same model source in double-double (qd's dd_real, ~32 digits): the reference that
// high-precision trajectories are built on. It must agree with double to round-off and with
// the hand-derived equations to ~1e-30.
#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <cmath>

#include <eom/reference/reference.hpp>

#include <models/spring_pendulum.hpp>

namespace {

using SPd = eom::Reference<eom::models::SpringPendulum>;
using SPw = eom::Reference<eom::models::SpringPendulum, dd_real>;

TEST(WideReference, DoubleDoubleSpringPendulumMatchesHandAndDouble) {
  const dd_real q[2] = {dd_real(0.61), dd_real(0.7)}, qd[2] = {dd_real(0.3), dd_real(-1.9)};
  dd_real p[4];
  for (int i = 0; i < 4; ++i) p[i] = dd_real(SPw::parameter_values[i]);
  dd_real qdd[2];
  ASSERT_TRUE(SPw::forward_dynamics(dd_real(0), q, qd, nullptr, p, qdd));
  const dd_real r = q[0], th = q[1], rd = qd[0], thd = qd[1];
  const dd_real want0 = r * thd * thd - p[1] / p[0] * (r - p[2]) + p[3] * cos(th);
  const dd_real want1 = (-2 * rd * thd - p[3] * sin(th)) / r;
  EXPECT_LT(to_double(abs(qdd[0] - want0)), 1e-29);
  EXPECT_LT(to_double(abs(qdd[1] - want1)), 1e-29);

  const double qn[2] = {0.61, 0.7}, qdn[2] = {0.3, -1.9};
  double qddn[2];
  ASSERT_TRUE(SPd::forward_dynamics(0, qn, qdn, nullptr, SPd::parameter_values.data(), qddn));
  EXPECT_NEAR(qddn[0], to_double(qdd[0]), 1e-14 * std::abs(qddn[0]));
  EXPECT_NEAR(qddn[1], to_double(qdd[1]), 1e-14 * std::abs(qddn[1]));
}

}  // namespace
