// A bundled robot standing on the ground with MuJoCo's soft contact (add_eom_model's GROUND on
// models/robots/solo12_feet.urdf: Solo12 with a 0.016 m sphere at each foot, the scene's
// defaults: 2 ms steps, solref 0.02): dropped from 5 mm with its joints held by a PD (20 N·m/rad,
// 0.3 N·m·s/rad, no gravity compensation), it comes to rest level on its four feet within 1 s,
// their normal forces carrying its weight.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <span>

#include <urdf_solo12_feet.hpp>
#include <urdf_solo12_feet_model.hpp>

#include <eom/contact/step.hpp>

namespace {

using Scene = eom::urdf_models::urdf_solo12_feet;
using K = urdf_solo12_feet::Kernels;

TEST(urdf_scene, Solo12StandsOnItsFootSpheres) {
  ASSERT_EQ(Scene::geoms.size(), 5u);  // the ground, then the feet FL, FR, HL, HR
  ASSERT_EQ(Scene::collision_pairs.size(), 4u);
  const double* p = K::parameter_values.data();
  const double radius = Scene::geoms[1].size[0], drop = 0.005;
  EXPECT_EQ(radius, 0.016);
  // legs bent (hip 0.8 rad, knee -1.6 rad, hind mirrored): each foot below its hip
  std::array<double, K::nq> q{}, q_ref{};
  q[3] = 1;
  for (int leg = 0; leg < 4; ++leg) {
    const double side = leg < 2 ? 1.0 : -1.0;
    q[7 + 3 * leg + 1] = 0.8 * side, q[7 + 3 * leg + 2] = -1.6 * side;
  }
  // the base's height puts the feet's spheres `drop` above the ground
  auto stepper = std::make_unique<eom::ContactStepper<K, Scene>>();
  const auto X = eom::tree_placements<double>(stepper->links, std::span<const double>(q));
  const double foot_z = X[Scene::geoms[1].link].translation[2];
  q[2] = radius + drop - foot_z;
  q_ref = q;
  std::array<double, K::nv * K::nv> M;
  K::mass_matrix(q.data(), p, M.data());
  const double weight = M[0] * p[0];  // the free joint's translational block: m·1
  std::array<double, K::nv> v{};
  double t = 0, deepest = 0;
  const int steps = static_cast<int>(std::lround(1.0 / Scene::solver_options.timestep));
  for (int k = 0; k < steps; ++k) {
    std::array<double, K::nu> u;
    for (int j = 0; j < K::nu; ++j) u[j] = 20 * (q_ref[7 + j] - q[7 + j]) - 0.3 * v[6 + j];
    const eom::StepStatus status = eom::contact_step<K, Scene>(*stepper, t, q, v, u.data(), p);
    ASSERT_EQ(status, eom::StepStatus::ok) << k;
    for (int c = 0; c < stepper->rows.ncontacts; ++c) deepest = std::max(deepest, -stepper->rows.contacts[c].dist);
  }
  // at rest on four feet: the last step's forces (at the state it started from) carry the weight
  const auto& rows = stepper->rows;
  ASSERT_EQ(rows.ncontacts, 4);
  double total = 0, speed = 0;
  for (int c = 0; c < 4; ++c) {
    ASSERT_TRUE(rows.contact_active[c]);
    const double normal = eom::contact_force<Scene>(rows, stepper->solution, c)[0];
    EXPECT_GT(normal, 0.2 * weight) << c;  // each foot about a quarter
    EXPECT_LT(normal, 0.3 * weight) << c;
    total += normal;
  }
  for (double x : v) speed = std::max(speed, std::abs(x));
  double resting = 0;  // the feet's depth at rest
  for (int c = 0; c < 4; ++c) resting = std::max(resting, -rows.contacts[c].dist);
  EXPECT_NEAR(total, weight, 1e-3 * weight);
  EXPECT_LT(speed, 1e-3);
  // MuJoCo's default softness (solref 0.02) lets this 3 kg robot's light feet sink a few mm: 3.6 mm
  // at rest, 5.4 mm at the landing when written; the bounds guard against a change
  EXPECT_LT(resting, 0.004);
  EXPECT_LT(deepest, 0.006);
  EXPECT_GT(q[2], q_ref[2] - drop - 0.02);  // the PD holds the legs: the base sags by less than 2 cm
  EXPECT_LT(std::abs(q[4]) + std::abs(q[5]), 0.01);  // level
}

}  // namespace
