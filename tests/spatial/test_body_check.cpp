// eom::body_problem on hand-made bodies (eom/multibody/body_check.hpp): what passes (a slender rod, a point
// mass, rotated tensors, the triangle inequality's equality case, rotations off by 1e-12) and what
// is named (negative mass, non-orthonormal or reflecting rotation, non-PSD inertia, triangle
// violation, NaN), and body_problem<Model>(q, p) naming the body by index.
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <eom/multibody/body_check.hpp>
#include <eom/multibody/spatial.hpp>

#include "universal_pendulum.hpp"

namespace {

using Body = eom::SpatialBody<double>;
using ::testing::HasSubstr;

Body body(double mass, std::array<double, 6> inertia, eom::Rot3<double> R = eom::identity_rotation<double>()) {
  return {mass, inertia, {0.1, 0.2, 0.3}, R};
}

// J in body axes turned by R: R J Rᵀ, as (Ixx, Iyy, Izz, Ixy, Ixz, Iyz).
std::array<double, 6> rotated(const std::array<double, 6>& J, const eom::Rot3<double>& R) {
  const eom::Rot3<double> m{J[0], J[3], J[4], J[3], J[1], J[5], J[4], J[5], J[2]};
  const auto r = eom::multiply(eom::multiply(R, m), eom::transpose(R));
  return {r[0], r[4], r[8], r[3], r[6], r[7]};
}

TEST(BodyCheck, PhysicalBodiesPass) {
  const auto R = eom::rpy(0.4, -1.1, 2.3);
  EXPECT_EQ(eom::body_problem(body(2.0, {1, 2, 2.5, 0, 0, 0})), "");
  EXPECT_EQ(eom::body_problem(body(2.0, {0, 0.3, 0.3, 0, 0, 0}, R)), "") << "slender rod";
  EXPECT_EQ(eom::body_problem(body(2.0, rotated({0, 0.3, 0.3, 0, 0, 0}, R))), "") << "rod, off-axis";
  EXPECT_EQ(eom::body_problem(body(2.0, {0, 0, 0, 0, 0, 0})), "") << "point mass";
  EXPECT_EQ(eom::body_problem(body(0.0, {0, 0, 0, 0, 0, 0})), "") << "massless";
  EXPECT_EQ(eom::body_problem(body(1.0, {1, 1, 2, 0, 0, 0})), "") << "flat plate: λ3 = λ1 + λ2";
  EXPECT_EQ(eom::body_problem(body(1.0, rotated({1, 2, 2.5, 0, 0, 0}, R))), "") << "full tensor";
  // Off orthonormal by 1e-12 (< 1e-9): accepted.
  auto nearly = R;
  for (double& x : nearly) x *= 1 + 1e-12;
  EXPECT_EQ(eom::body_problem(body(1.0, {1, 1, 1, 0, 0, 0}, nearly)), "");
}

TEST(BodyCheck, ProblemsAreNamed) {
  EXPECT_THAT(eom::body_problem(body(-0.5, {1, 1, 1, 0, 0, 0})), HasSubstr("negative mass -0.5"));
  auto stretched = eom::rpy(0.4, -1.1, 2.3);
  for (double& x : stretched) x *= 1 + 1e-6;
  EXPECT_THAT(eom::body_problem(body(1.0, {1, 1, 1, 0, 0, 0}, stretched)),
              HasSubstr("rotation is not orthonormal: max |R^T R - 1| = 2e-06"));
  auto mirrored = eom::rot_z(0.3);
  for (int i = 6; i < 9; ++i) mirrored[i] = -mirrored[i];  // third column flipped: det −1
  EXPECT_THAT(eom::body_problem(body(1.0, {1, 1, 1, 0, 0, 0}, mirrored)), HasSubstr("reflection"));
  // [[1 2] [2 1]] block: moments −1, 1, 3.
  EXPECT_THAT(eom::body_problem(body(1.0, {1, 1, 1, 2, 0, 0})),
              HasSubstr("not positive definite (principal moments -1, 1, 3)"));
  EXPECT_THAT(eom::body_problem(body(1.0, {-0.1, 1, 1, 0, 0, 0})), HasSubstr("not positive definite"));
  EXPECT_THAT(eom::body_problem(body(1.0, {1, 1, 3, 0, 0, 0})), HasSubstr("triangle inequality"));
  // The same violation, hidden in a rotated tensor.
  EXPECT_THAT(eom::body_problem(body(1.0, rotated({1, 1, 3, 0, 0, 0}, eom::rpy(0.4, -1.1, 2.3)))),
              HasSubstr("triangle inequality"));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(eom::body_problem(body(nan, {1, 1, 1, 0, 0, 0})), HasSubstr("not finite"));
  auto broken = eom::identity_rotation<double>();
  broken[4] = nan;
  EXPECT_THAT(eom::body_problem(body(1.0, {1, 1, 1, 0, 0, 0}, broken)), HasSubstr("not finite"));
  // The planar body: negative inertia.
  EXPECT_THAT(eom::body_problem(eom::PlanarBody<double>{1.0, -1.0, 0, 0, 0}), HasSubstr("negative inertia"));
  EXPECT_EQ(eom::body_problem(eom::PlanarBody<double>{1.0, 0.0, 0, 0, 0}), "");
}

TEST(BodyCheck, PrincipalMomentsOfARotatedTensor) {
  const auto J = rotated({1, 2, 3, 0, 0, 0}, eom::axis_angle<double>({1, -2, 0.7}, 1.3));
  const auto m = eom::detail::symmetric_eigenvalues(J[0], J[1], J[2], J[3], J[4], J[5]);
  EXPECT_NEAR(m[0], 1.0, 1e-14);
  EXPECT_NEAR(m[1], 2.0, 1e-14);
  EXPECT_NEAR(m[2], 3.0, 1e-14);
}

TEST(BodyCheck, ModelBodiesNamedByIndex) {
  using spatial_test::UniversalPendulum;
  auto p = UniversalPendulum::parameter_values;
  const std::array<double, 4> q{0.3, -0.2, 1.0, 0.5};
  EXPECT_EQ(eom::body_problem<UniversalPendulum>(q, p), "");
  p[1] = -1.0;  // m2
  EXPECT_EQ(eom::body_problem<UniversalPendulum>(q, p), "body 1: negative mass -1");
  p = UniversalPendulum::parameter_values;
  p[12] = 0.2;  // J1xy: J1 no longer positive definite
  EXPECT_THAT(eom::body_problem<UniversalPendulum>(q, p), HasSubstr("body 0: inertia tensor is not positive definite"));
  // A model in the energy form has no bodies to check.
  EXPECT_EQ(eom::body_problem<spatial_test::UniversalPendulumEnergy>(q, p), "");
}

}  // namespace
