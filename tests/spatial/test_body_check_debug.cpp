// eom::Reference's debug path: built without NDEBUG (this file only; its own executable, so no
// other translation unit sees Reference with NDEBUG), every call that evaluates T first checks
// the bodies and, like assert, prints what is wrong and aborts.
#undef NDEBUG

#include <array>

#include <gtest/gtest.h>

#include <eom/reference/reference.hpp>

#include "universal_pendulum.hpp"

namespace {

using spatial_test::UniversalPendulum;
using R = eom::Reference<UniversalPendulum>;

const std::array<double, 4> q{0.3, -0.2, 1.0, 0.5}, qd{0.1, 0.2, -0.3, 0.4};

TEST(BodyCheckDebugDeathTest, ConsistentBodiesRunNormally) {
  const auto p = R::parameter_values;
  std::array<double, 16> M;
  R::mass_matrix(q.data(), p.data(), M.data());
  EXPECT_GT(M[0], 0.0);
}

TEST(BodyCheckDebugDeathTest, NegativeMassAborts) {
  auto p = R::parameter_values;
  p[1] = -1.0;  // m2
  std::array<double, 16> M;
  EXPECT_DEATH(R::mass_matrix(q.data(), p.data(), M.data()),
               "eom::Reference<Model>::mass_matrix: bodies: body 1: negative mass -1");
}

TEST(BodyCheckDebugDeathTest, InertiaNotPositiveDefiniteAborts) {
  auto p = R::parameter_values;
  p[12] = 0.2;  // J1xy
  std::array<double, 4> qdd;
  EXPECT_DEATH(R::forward_dynamics(0.0, q.data(), qd.data(), nullptr, p.data(), qdd.data()),
               "eom::Reference<Model>::forward_dynamics: bodies: body 0: inertia tensor is not "
               "positive definite");
}

TEST(BodyCheckDebugDeathTest, TriangleInequalityViolationAborts) {
  auto p = R::parameter_values;
  p[17] = 0.1;  // J2zz > J2xx + J2yy
  EXPECT_DEATH(R::kinetic_energy(q.data(), qd.data(), p.data()),
               "eom::Reference<Model>::kinetic_energy: bodies: body 1: inertia tensor violates the "
               "triangle inequality");
}

}  // namespace
