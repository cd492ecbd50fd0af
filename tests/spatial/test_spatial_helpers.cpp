// The rotation and transform helpers of <eom/multibody/spatial.hpp> against closed forms written out here,
// and against each other: rpy = Rz·Ry·Rx, axis_angle about coordinate axes = rot_x/y/z, about a
// general axis = the quaternion of the same rotation, every result a rotation (orthonormal,
// det +1), Transform composition associative and equal to applying in sequence, and
// origin/revolute/prismatic/rigid_body/gravity_potential as documented.
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include <eom/multibody/spatial.hpp>

namespace {

using R3 = eom::Rot3<double>;
using V3 = eom::Vec3<double>;

double max_difference(const R3& a, const R3& b) {
  double d = 0;
  for (int i = 0; i < 9; ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}
double max_difference(const V3& a, const V3& b) {
  double d = 0;
  for (int i = 0; i < 3; ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}
// Column-major from rows.
R3 from_rows(const std::array<std::array<double, 3>, 3>& r) {
  return {r[0][0], r[1][0], r[2][0], r[0][1], r[1][1], r[2][1], r[0][2], r[1][2], r[2][2]};
}
// max |RᵀR − 1| and det R.
double orthonormality_error(const R3& R) {
  double worst = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double d = R[3 * i] * R[3 * j] + R[3 * i + 1] * R[3 * j + 1] + R[3 * i + 2] * R[3 * j + 2];
      worst = std::max(worst, std::abs(d - (i == j ? 1.0 : 0.0)));
    }
  return worst;
}
double det(const R3& R) {
  return R[0] * (R[4] * R[8] - R[7] * R[5]) - R[3] * (R[1] * R[8] - R[7] * R[2]) +
         R[6] * (R[1] * R[5] - R[4] * R[2]);
}
// A rotation to a few ulps (measured ≤ 6.7e-16 for max |RᵀR − 1| and |det R − 1| ≤ 4.4e-16).
void expect_rotation(const R3& R) {
  EXPECT_LE(orthonormality_error(R), 1.5e-15);
  EXPECT_NEAR(det(R), 1.0, 1.5e-15);
}

TEST(SpatialHelpers, ElementaryRotationsTurnCounterClockwise) {
  const double a = 0.7, c = std::cos(a), s = std::sin(a);
  // rot_x maps e_y to (0, c, s), rot_y maps e_z to (s, 0, c), rot_z maps e_x to (c, s, 0).
  EXPECT_EQ(max_difference(eom::rotate(eom::rot_x(a), V3{0, 1, 0}), V3{0, c, s}), 0.0);
  EXPECT_EQ(max_difference(eom::rotate(eom::rot_y(a), V3{0, 0, 1}), V3{s, 0, c}), 0.0);
  EXPECT_EQ(max_difference(eom::rotate(eom::rot_z(a), V3{1, 0, 0}), V3{c, s, 0}), 0.0);
  EXPECT_EQ(max_difference(eom::rot_z(0.0), eom::identity_rotation<double>()), 0.0);
}

TEST(SpatialHelpers, RpyIsRzRyRx) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> U(-std::numbers::pi, std::numbers::pi);
  double worst = 0;
  for (int k = 0; k < 100; ++k) {
    const double r = U(rng), p = U(rng), y = U(rng);
    const double cr = std::cos(r), sr = std::sin(r), cp = std::cos(p), sp = std::sin(p);
    const double cy = std::cos(y), sy = std::sin(y);
    // Rz(y)·Ry(p)·Rx(r) multiplied out by hand.
    const R3 want = from_rows({{{cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr},
                                {sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr},
                                {-sp, cp * sr, cp * cr}}});
    const R3 got = eom::rpy(r, p, y);
    worst = std::max(worst, max_difference(got, want));
    expect_rotation(got);
  }
  std::printf("rpy: %.2e\n", worst);
  EXPECT_LE(worst, 1e-15);  // measured 2.2e-16
}

TEST(SpatialHelpers, AxisAngleAboutCoordinateAxesIsTheElementaryRotation) {
  for (double a : {-2.5, -0.3, 0.0, 1.1, 3.0}) {
    // The coordinate branch: exactly rot_x/y/z, also for a non-unit length and a negative axis.
    EXPECT_EQ(eom::axis_angle<double>({1, 0, 0}, a), eom::rot_x(a));
    EXPECT_EQ(eom::axis_angle<double>({0, 2.5, 0}, a), eom::rot_y(a));
    EXPECT_EQ(eom::axis_angle<double>({0, 0, 1}, a), eom::rot_z(a));
    EXPECT_EQ(eom::axis_angle<double>({-1, 0, 0}, a), eom::rot_x(-a));
    EXPECT_EQ(eom::axis_angle<double>({0, -1, 0}, a), eom::rot_y(-a));
    EXPECT_EQ(eom::axis_angle<double>({0, 0, -3}, a), eom::rot_z(-a));
  }
}

TEST(SpatialHelpers, AxisAngleAboutAGeneralAxisIsTheQuaternion) {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> N;
  std::uniform_real_distribution<double> U(-std::numbers::pi, std::numbers::pi);
  double worst = 0, worst_axis = 0, worst_perpendicular = 0;
  for (int k = 0; k < 200; ++k) {
    const std::array<double, 3> axis{N(rng), N(rng), N(rng)};
    const double a = U(rng), n = std::hypot(axis[0], axis[1], axis[2]);
    const V3 u{axis[0] / n, axis[1] / n, axis[2] / n};
    const double h = std::sin(a / 2);
    const R3 R = eom::axis_angle<double>(axis, a);
    worst = std::max(worst, max_difference(R, eom::quaternion(std::cos(a / 2), h * u[0], h * u[1], h * u[2])));
    expect_rotation(R);
    // The axis is fixed; a perpendicular v turns to cos a·v + sin a·(u × v).
    worst_axis = std::max(worst_axis, max_difference(eom::rotate(R, u), u));
    const V3 v{u[1], -u[0], 0.0};  // ⟂ u (not unit: the map is linear)
    const V3 uxv{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    const V3 want{std::cos(a) * v[0] + std::sin(a) * uxv[0], std::cos(a) * v[1] + std::sin(a) * uxv[1],
                  std::cos(a) * v[2] + std::sin(a) * uxv[2]};
    worst_perpendicular = std::max(worst_perpendicular, max_difference(eom::rotate(R, v), want));
  }
  std::printf("axis_angle: %.2e %.2e %.2e\n", worst, worst_axis, worst_perpendicular);
  // Measured 8.9e-16, 5.6e-16, 3.3e-16.
  EXPECT_LE(worst, 2e-15);
  EXPECT_LE(worst_axis, 2e-15);
  EXPECT_LE(worst_perpendicular, 2e-15);
}

TEST(SpatialHelpers, QuaternionOfTheTiltIsItsLiteral) {
  // The universal pendulum's tilt (tests/spatial/universal_pendulum.hpp): (w, x, y, z) =
  // (0.4, 0.2, 0.4, 0.8), 2·acos(0.4) about (1, 2, 4).
  const R3 literal{-0.6, 0.8, 0.0, -0.48, -0.36, 0.8, 0.64, 0.48, 0.6};
  EXPECT_LE(max_difference(eom::quaternion(0.4, 0.2, 0.4, 0.8), literal), 1e-15);  // measured 3.3e-16
  EXPECT_LE(max_difference(eom::axis_angle<double>({1, 2, 4}, 2 * std::acos(0.4)), literal), 1e-15);
  expect_rotation(eom::quaternion(0.4, 0.2, 0.4, 0.8));
  // q and −q are the same rotation.
  EXPECT_LE(max_difference(eom::quaternion(-0.4, -0.2, -0.4, -0.8), literal), 1e-15);  // measured 3.3e-16
}

TEST(SpatialHelpers, MultiplyTransposeRotate) {
  const R3 a = eom::rpy(0.3, -1.2, 2.0), b = eom::axis_angle<double>({1, -2, 0.5}, 0.9);
  const V3 x{0.3, -0.7, 1.9};
  // (AB)x = A(Bx), AᵀA x = x.
  EXPECT_LE(max_difference(eom::rotate(eom::multiply(a, b), x), eom::rotate(a, eom::rotate(b, x))), 1e-15);
  EXPECT_LE(max_difference(eom::rotate(eom::transpose(a), eom::rotate(a, x)), x), 1e-15);
  EXPECT_LE(max_difference(eom::multiply(eom::transpose(b), b), eom::identity_rotation<double>()), 1e-15);
  expect_rotation(eom::multiply(a, b));
}

eom::Transform<double> random_transform(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(-2, 2);
  return {eom::rpy(U(rng), U(rng), U(rng)), {U(rng), U(rng), U(rng)}};
}

TEST(SpatialHelpers, TransformCompositionIsAssociativeAndAppliesInSequence) {
  std::mt19937_64 rng(3);
  double associative = 0, sequence = 0;
  for (int k = 0; k < 100; ++k) {
    const auto a = random_transform(rng), b = random_transform(rng), c = random_transform(rng);
    const V3 x{0.5, -1.0, 2.0};
    const auto left = (a * b) * c, right = a * (b * c);
    associative = std::max({associative, max_difference(left.rotation, right.rotation),
                            max_difference(left.translation, right.translation)});
    // a * b applies b first.
    sequence = std::max(sequence, max_difference((a * b).apply(x), a.apply(b.apply(x))));
  }
  std::printf("transform: %.2e %.2e\n", associative, sequence);
  EXPECT_LE(associative, 4e-15);  // measured 8.9e-16
  EXPECT_LE(sequence, 4e-15);     // measured 8.9e-16
  // Not commutative: the order matters.
  const auto a = eom::origin<double>({1, 0, 0}, {0, 0, 0}), b = eom::revolute<double>({0, 0, 1}, 1.0);
  EXPECT_GT(max_difference((a * b).apply({1, 0, 0}), (b * a).apply({1, 0, 0})), 0.1);
}

TEST(SpatialHelpers, JointsAndOriginsAsDocumented) {
  // prismatic: translation by q along the normalized axis, no rotation.
  const auto slide = eom::prismatic<double>({0, 3, 4}, 2.0);
  EXPECT_EQ(slide.rotation, eom::identity_rotation<double>());
  EXPECT_LE(max_difference(slide.translation, V3{0, 1.2, 1.6}), 1e-15);
  // revolute: rotation by q about the axis, no translation.
  const auto hinge = eom::revolute<double>({1, 1, 0}, 0.8);
  EXPECT_EQ(hinge.rotation, (eom::axis_angle<double>({1, 1, 0}, 0.8)));
  EXPECT_EQ(hinge.translation, (V3{0, 0, 0}));
  // origin: translation xyz, rotation rpy; identity rotation (exactly) when rpy = 0.
  const auto o = eom::origin<double>({1, 2, 3}, {0.1, 0.2, 0.3});
  EXPECT_EQ(o.translation, (V3{1, 2, 3}));
  EXPECT_EQ(o.rotation, eom::rpy(0.1, 0.2, 0.3));
  EXPECT_EQ(eom::origin<double>({1, 2, 3}, {0, 0, 0}).rotation, eom::identity_rotation<double>());
  // A URDF-like chain: frame = origin · revolute; the point (1, 0, 0) of the child frame of a
  // hinge about z at (1, 0, 0) turned by 90° is at (1, 1, 0).
  const auto frame = eom::origin<double>({1, 0, 0}, {0, 0, 0}) * eom::revolute<double>({0, 0, 1}, std::numbers::pi / 2);
  EXPECT_LE(max_difference(frame.apply({1, 0, 0}), V3{1, 1, 0}), 1e-15);
}

// origin() takes an angle within 1e-15 of a multiple of π/2 as exactly that multiple, and any
// other angle as it is: the file value 1.570796326794897 gives cos = 0, not 2e-16.
TEST(SpatialHelpers, OriginTakesQuarterTurnsAsExact) {
  const double quarter = 1.570796326794897;  // as URDF files print π/2
  EXPECT_EQ(eom::origin<double>({0, 0, 0}, {quarter, 0, 0}).rotation, (R3{1, 0, 0, 0, 0, 1, 0, -1, 0}));
  EXPECT_EQ(eom::origin<double>({0, 0, 0}, {-quarter, 0, 0}).rotation, (R3{1, 0, 0, 0, 0, -1, 0, 1, 0}));
  EXPECT_EQ(eom::origin<double>({0, 0, 0}, {0, 0, 2 * quarter}).rotation, (R3{-1, 0, 0, 0, -1, 0, 0, 0, 1}));
  EXPECT_EQ(eom::origin<double>({0, 0, 0}, {0, -3 * quarter, 0}).rotation, (R3{0, 0, -1, 0, 1, 0, 1, 0, 0}));
  // 1e-9 off a quarter turn is an angle of its own.
  const double off = std::numbers::pi / 2 + 1e-9;
  EXPECT_EQ(eom::origin<double>({0, 0, 0}, {off, 0, 0}).rotation[4], std::cos(off));
}

TEST(SpatialHelpers, RigidBodyAndGravityPotential) {
  const eom::Transform<double> frame{eom::rot_z(0.5), {1, 2, 3}};
  const eom::Transform<double> inertial{eom::rot_x(0.25), {0.1, 0.0, -0.2}};
  const std::array<double, 6> J{1, 2, 2.5, 0.1, 0, 0};
  const auto b = eom::rigid_body<double>(frame, 3.0, J, inertial);
  EXPECT_EQ(b.mass, 3.0);
  EXPECT_EQ(b.inertia, J);
  EXPECT_LE(max_difference(b.position, frame.apply(inertial.translation)), 1e-15);
  EXPECT_LE(max_difference(b.rotation, eom::multiply(frame.rotation, inertial.rotation)), 1e-15);
  // Without `inertial` the body sits at the frame.
  const auto at_frame = eom::rigid_body<double>(frame, 1.0, J);
  EXPECT_EQ(at_frame.position, frame.translation);
  EXPECT_EQ(at_frame.rotation, frame.rotation);
  // V = g Σ m z.
  const std::array<eom::SpatialBody<double>, 2> bodies{b, at_frame};
  EXPECT_NEAR(eom::gravity_potential<double>(bodies, 9.81), 9.81 * (3.0 * b.position[2] + 1.0 * 3.0), 1e-13);
}

}  // namespace
