// Robots imported from URDF through add_eom_model(... URDF ...): the conventions against closed
// forms (a pendulum, and one whose joint frame is turned by roll-pitch-yaw), and every kernel of a
// two-link robot with a fixed joint against eom::Reference of the written model header.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <urdf_pendulum.hpp>
#include <urdf_pendulum_model.hpp>
#include <urdf_rpy_pendulum.hpp>
#include <urdf_rpy_pendulum_model.hpp>
#include <urdf_two_link.hpp>
#include <urdf_two_link_model.hpp>

#include <eom/reference/reference.hpp>

namespace {

TEST(UrdfKernels, PendulumMatchesItsClosedForm) {
  // m = 2, l = 0.5, Iyy = 0.1, pivot 2 m up, axis y: M = Iyy + m l², V = m g (2 − l cos q).
  const auto& p = urdf_pendulum::parameter_values;
  for (double q : {-2.0, -0.3, 0.0, 0.7, 2.9}) {
    double M = 0, dV = 0;
    urdf_pendulum::mass_matrix(&q, p.data(), &M);
    urdf_pendulum::potential_gradient(&q, p.data(), &dV);
    EXPECT_NEAR(M, 0.1 + 2 * 0.25, 1e-15);
    EXPECT_NEAR(dV, 2 * 9.81 * 0.5 * std::sin(q), 1e-14);
    EXPECT_NEAR(urdf_pendulum::potential_energy(&q, p.data()), 2 * 9.81 * (2 - 0.5 * std::cos(q)), 1e-13);
  }
  EXPECT_EQ(urdf_pendulum::nu, 1);
  EXPECT_EQ(urdf_pendulum::parameter_names[0], "g");
}

TEST(UrdfKernels, RollPitchYawIsZYXAboutFixedAxes) {
  // rpy = (π/2, 0, π/2): the joint axis is world x, the bob (l = 0.4, m = 1.5) stands above the
  // pivot: M = Izz + m l², V = m g (1 + l cos q); damping 0.25: Q = u − 0.25 q̇.
  const auto& p = urdf_rpy_pendulum::parameter_values;
  for (double q : {-1.0, 0.0, 0.4, 2.0}) {
    double M = 0, dV = 0, Q = 0;
    const double qd = 0.7, u = 0.3;
    urdf_rpy_pendulum::mass_matrix(&q, p.data(), &M);
    urdf_rpy_pendulum::potential_gradient(&q, p.data(), &dV);
    urdf_rpy_pendulum::generalized_forces(0.0, &q, &qd, &u, p.data(), &Q);
    EXPECT_NEAR(M, 0.05 + 1.5 * 0.16, 1e-15);
    EXPECT_NEAR(dV, -1.5 * 9.81 * 0.4 * std::sin(q), 1e-14);
    EXPECT_NEAR(Q, u - 0.25 * qd, 1e-16);
  }
}

TEST(UrdfKernels, TwoLinkKernelsMatchTheReferenceOfTheWrittenModel) {
  namespace gen = urdf_two_link;
  using Ref = eom::Reference<eom::urdf_models::urdf_two_link>;
  static_assert(gen::nq == 2 && gen::nu == 2 && gen::np == Ref::np);
  const auto& p = gen::parameter_values;
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> angle(-3, 3), rate(-2, 2);
  double worst = 0;  // max |generated − reference| / (1 + |reference|)
  auto compare = [&worst](const double* a, const double* b, int n) {
    for (int i = 0; i < n; ++i) worst = std::max(worst, std::abs(a[i] - b[i]) / (1 + std::abs(b[i])));
  };
  for (int k = 0; k < 200; ++k) {
    const double q[2] = {angle(rng), angle(rng)}, qd[2] = {rate(rng), rate(rng)};
    const double u[2] = {rate(rng), rate(rng)}, qdd_in[2] = {rate(rng), rate(rng)};
    double a[8], b[8], da[12], db[12];
    gen::mass_matrix(q, p.data(), a), Ref::mass_matrix(q, p.data(), b), compare(a, b, 4);
    gen::mass_matrix_dot(q, qd, p.data(), a), Ref::mass_matrix_dot(q, qd, p.data(), b), compare(a, b, 4);
    gen::coriolis(q, qd, p.data(), a), Ref::coriolis(q, qd, p.data(), b), compare(a, b, 2);
    gen::potential_gradient(q, p.data(), a), Ref::potential_gradient(q, p.data(), b), compare(a, b, 2);
    gen::generalized_forces(0, q, qd, u, p.data(), a), Ref::generalized_forces(0, q, qd, u, p.data(), b);
    compare(a, b, 2);
    ASSERT_TRUE(gen::forward_dynamics(0, q, qd, u, p.data(), a));
    ASSERT_TRUE(Ref::forward_dynamics(0, q, qd, u, p.data(), b));
    compare(a, b, 2);
    gen::inverse_dynamics(0, q, qd, qdd_in, u, p.data(), a);
    Ref::inverse_dynamics(0, q, qd, qdd_in, u, p.data(), b);
    compare(a, b, 2);
    ASSERT_TRUE(gen::forward_dynamics_derivatives(0, q, qd, u, p.data(), da, da + 4, da + 8));
    ASSERT_TRUE(Ref::forward_dynamics_derivatives(0, q, qd, u, p.data(), db, db + 4, db + 8));
    compare(da, db, 12);
    a[0] = gen::kinetic_energy(q, qd, p.data()), b[0] = Ref::kinetic_energy(q, qd, p.data());
    compare(a, b, 1);
  }
  EXPECT_LT(worst, 1e-12);
  std::printf("two-link URDF robot, generated vs Reference over 200 states: %.1e\n", worst);
}

}  // namespace
