// A URDF robot stepping with contact (add_eom_model's GROUND and COLLISION_PAIRS, docs/CONTRACT.md
// §1 "URDF: the scene"): robots/drop_box.urdf (a box with a wheel, a cylinder, on a free root, an
// arm on a limited, damped hinge carrying a sphere and a capsule through a fixed joint) dropped on
// the ground by eom::contact_step, side by side with MuJoCo's mj_step on the equivalent MJCF
// written below.
#include <gtest/gtest.h>

#include <mujoco/mujoco.h>

#include "mujoco_peer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <urdf_drop_box.hpp>
#include <urdf_drop_box_model.hpp>

#include <eom/contact/step.hpp>
#include <eom/multibody/tree.hpp>

namespace {

using eom::test::relative;
using Model = eom::urdf_models::urdf_drop_box;
using K = urdf_drop_box::Kernels;

// robots/drop_box.urdf in MJCF, body for link and geom for <collision>: the tip's geoms on the
// arm at the tip's placement (rod: the tip's pitch 0.3 and the capsule's pi/2 summed; position
// (0.2, 0, 0) + Ry(0.3) (-0.1, 0, 0)), the inertials as written, the hinge's <limit> as range and
// its damping; the ground a plane at z = 0, the pairs tip:box as <pair>s (those with the wheel
// left out, as the scene leaves them: MuJoCo would find them by MPR). MuJoCo's defaults for
// every contact parameter and option, as the scene states them.
std::string mjcf() {
  char rod[200];
  std::snprintf(rod, sizeof rod, "%.17g 0 %.17g", 0.2 - 0.1 * std::cos(0.3), 0.1 * std::sin(0.3));
  return std::string(R"(<mujoco model="drop_box">
  <compiler angle="radian" eulerseq="XYZ" inertiafromgeom="false"/>
  <worldbody>
    <geom name="ground" type="plane" size="0 0 1"/>
    <body name="box">
      <freejoint name="root"/>
      <inertial pos="0.01 -0.02 0.005" euler="0.1 -0.2 0.3" mass="2" diaginertia="0.02 0.03 0.04"/>
      <geom name="hull" type="box" size="0.15 0.1 0.05"/>
      <geom name="wheel" type="cylinder" size="0.05 0.1" pos="-0.15 0 0" euler="1.5707963267948966 0 0"/>
      <body name="arm" pos="0.15 0 0.05">
        <joint name="hinge" type="hinge" axis="0 1 0" limited="true" range="-3 1.2" damping="0.05"/>
        <inertial pos="0.1 0 0" mass="0.5" diaginertia="0.001 0.002 0.002"/>
        <geom name="ball" type="sphere" size="0.04" pos="0.2 0 0" euler="0 0.3 0"/>
        <geom name="rod" type="capsule" size="0.02 0.06" pos=")") + rod + R"(" euler="0 1.8707963267948966 0"/>
      </body>
    </body>
  </worldbody>
  <contact>
    <pair geom1="ball" geom2="hull"/>
    <pair geom1="rod" geom2="hull"/>
  </contact>
</mujoco>
)";
}

eom::test::MujocoModel load() {
  char error[1000] = "";
  eom::test::MujocoModel m = eom::test::load_text("drop_box.xml", mjcf(), error, sizeof error);
  EXPECT_TRUE(m) << error;
  return m;
}

// The scene's numbers are MuJoCo's compiled ones: the geoms, placed on the tree as MuJoCo places
// them at a state; the candidate pairs in MuJoCo's order, with its body_invweight0 summed; the
// hinge's limit with its dof_invweight0; the damping; qpos0.
TEST(urdf_scene, SceneIsMuJoCos) {
  const auto m = load();
  ASSERT_TRUE(m);
  ASSERT_EQ(m->nq, K::nq);
  ASSERT_EQ(m->nv, K::nv);
  ASSERT_EQ(m->ngeom, static_cast<int>(Model::geoms.size()));
  {
    std::vector<std::array<int, 2>> ours;
    for (const auto& x : Model::collision_pairs) ours.push_back({x.geom1, x.geom2});
    EXPECT_EQ(ours, eom::test::tested_pairs(m.get()));
  }
  for (const auto& p : Model::collision_pairs) {
    const int b1 = m->geom_bodyid[p.geom1], b2 = m->geom_bodyid[p.geom2];
    const double tran = m->body_invweight0[2 * b1] + m->body_invweight0[2 * b2];
    const double rot = m->body_invweight0[2 * b1 + 1] + m->body_invweight0[2 * b2 + 1];
    EXPECT_NEAR(p.inverse_weight[0], tran, 1e-12 * tran) << p.geom1 << " " << p.geom2;
    EXPECT_NEAR(p.inverse_weight[1], rot, 1e-12 * rot) << p.geom1 << " " << p.geom2;
    EXPECT_EQ(p.condim, m->pair_dim[0]);
  }
  ASSERT_EQ(Model::joint_limits.size(), 1u);
  const auto& limit = Model::joint_limits[0];
  EXPECT_EQ(limit.coordinate, m->jnt_qposadr[1]);
  EXPECT_EQ(limit.velocity, m->jnt_dofadr[1]);
  EXPECT_EQ(limit.lower, m->jnt_range[2]);
  EXPECT_EQ(limit.upper, m->jnt_range[3]);
  EXPECT_NEAR(limit.inverse_weight, m->dof_invweight0[6], 1e-12 * m->dof_invweight0[6]);
  for (int i = 0; i < m->nv; ++i) EXPECT_EQ(Model::damping[i], m->dof_damping[i]) << i;
  for (int i = 0; i < m->nq; ++i) EXPECT_EQ(Model::qpos0[i], m->qpos0[i]) << i;
  for (int g = 0; g < m->ngeom; ++g) {
    EXPECT_EQ(static_cast<int>(Model::geoms[g].shape), m->geom_type[g]) << g;
    EXPECT_LE(relative(Model::geoms[g].size.data(), m->geom_size + 3 * g, 3), 1e-15) << g;
    EXPECT_EQ(Model::geoms[g].rbound, m->geom_rbound[g]) << g;
  }
  // placed at a turned state, as MuJoCo places them
  eom::test::MujocoData d(mj_makeData(m.get()));
  const std::array<double, K::nq> q{0.1, -0.2, 0.3, 0.9, 0.1, -0.3, 0.2, 0.7};
  std::copy(q.begin(), q.end(), d->qpos);
  mj_normalizeQuat(m.get(), d->qpos);
  mj_kinematics(m.get(), d.get());
  const std::vector<double> qn(d->qpos, d->qpos + m->nq);
  const auto X = eom::tree_placements<double>(eom::tree_of<Model, double>(Model::parameter_values), qn);
  for (int g = 0; g < m->ngeom; ++g) {
    const auto& geom = Model::geoms[g];
    const eom::Transform<double> on{geom.rotation, geom.position};
    const auto x = geom.link < 0 ? on : X[geom.link] * on;
    std::array<double, 9> R;  // MuJoCo's xmat is row-major
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) R[i + 3 * j] = d->geom_xmat[9 * g + 3 * i + j];
    EXPECT_LE(relative(x.translation.data(), d->geom_xpos + 3 * g, 3), 1e-14) << g;
    EXPECT_LE(relative(x.rotation.data(), R.data(), 9), 1e-14) << g;
  }
}

// Dropped four ways, q and v after every step against mj_step (the same options: MuJoCo's
// defaults): flat from 0.3 m, the arm swinging down onto the ground (3 s, then at rest); tilted
// and spinning from 0.5 m; high with the arm flung against its upper limit; and with the arm flung
// back over onto the box's top (the tip:box pairs) and its lower limit. At the end of the first
// the box rests on the ground at its half-height (0.05 m) and the ball at its radius, but for the
// soft contact's penetration (0.1 mm here).
TEST(urdf_scene, DropsOntoTheGroundAsMuJoCo) {
  const auto model = load();
  ASSERT_TRUE(model);
  mjModel* m = model.get();
  eom::test::MujocoData data(mj_makeData(m));
  mjData* d = data.get();
  auto stepper = std::make_unique<eom::ContactStepper<K, Model>>();
  struct Run {
    std::array<double, K::nq> q;
    std::array<double, K::nv> v;
    int steps;
  };
  const double s = std::sin(0.15), c = std::cos(0.15);
  const std::array<Run, 4> runs{{
      {{0, 0, 0.3, 1, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0, 0}, 1500},
      {{0.1, 0, 0.5, c, s * 0.6, s * 0.8, 0, -0.3}, {0.5, -0.2, 0, 1, -2, 3, 1}, 600},
      {{0, 0, 1.0, 1, 0, 0, 0, 0.5}, {0, 0, 0, 0, 0, 0, 12}, 600},
      {{0, 0, 0.6, 1, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0, -20}, 600},
  }};
  double worst_q = 0, worst_v = 0;
  int contacts = 0, limits = 0, pair_contacts = 0, wheel = 0;  // wheel: the ground's with it
  const std::array<double, K::nu> u{0};
  for (std::size_t r = 0; r < runs.size(); ++r) {
    mj_resetData(m, d);
    std::array<double, K::nq> q = runs[r].q;
    std::array<double, K::nv> v = runs[r].v;
    std::copy(q.begin(), q.end(), d->qpos);
    std::copy(v.begin(), v.end(), d->qvel);
    stepper->warm = false;
    double t = 0;
    for (int k = 0; k < runs[r].steps; ++k) {
      mj_step(m, d);
      const auto status = eom::contact_step<K, Model>(*stepper, t, q, v, u.data(), K::parameter_values.data());
      ASSERT_EQ(status, eom::StepStatus::ok) << r << " " << k;
      ASSERT_EQ(stepper->rows.ncontacts, d->ncon) << r << " " << k;
      ASSERT_EQ(stepper->rows.rows, d->nefc) << r << " " << k;
      // q against its scale (the quaternion's: 1); v against 1 m/s or rad/s where it is slower
      // (at rest it is ~1e-14, and its rounding there is no error of the step)
      double dv = 0, scale = 1;
      for (int i = 0; i < K::nv; ++i) {
        dv = std::max(dv, std::abs(v[i] - d->qvel[i]));
        scale = std::max(scale, std::abs(d->qvel[i]));
      }
      worst_q = std::max(worst_q, relative(q.data(), d->qpos, K::nq));
      worst_v = std::max(worst_v, dv / scale);
      contacts += d->ncon;
      for (int i = 0; i < d->ncon; ++i) {
        pair_contacts += d->contact[i].geom1 != 0;
        wheel += m->geom_type[d->contact[i].geom2] == mjGEOM_CYLINDER;
      }
      for (int i = 0; i < d->nefc; ++i) limits += d->efc_type[i] == mjCNSTR_LIMIT_JOINT;
    }
    if (r == 0) {  // at rest on the ground
      double speed = 0;
      for (double x : v) speed = std::max(speed, std::abs(x));
      EXPECT_LT(speed, 1e-3);
      // the hull's lowest corner and the ball's lowest point, MuJoCo's placement
      double lowest = 1;
      for (int sx : {-1, 1})
        for (int sy : {-1, 1})
          for (int sz : {-1, 1}) {
            const double corner[3] = {0.15 * sx, 0.1 * sy, 0.05 * sz};
            double z = d->geom_xpos[3 * 1 + 2];
            for (int j = 0; j < 3; ++j) z += d->geom_xmat[9 * 1 + 6 + j] * corner[j];
            lowest = std::min(lowest, z);
          }
      const double ball = d->geom_xpos[3 * 3 + 2] - 0.04;
      std::printf("at rest after %.1f s: the box's lowest corner at z = %.3e m, the ball's lowest "
                  "point at %.3e m, speeds below %.1e\n", t, lowest, ball, speed);
      EXPECT_LT(lowest, 0.0);  // the soft contact holds it a little inside the ground
      EXPECT_GT(lowest, -2e-3);
      EXPECT_LT(ball, 0.0);
      EXPECT_GT(ball, -2e-3);
    }
  }
  std::printf("eom::contact_step against mj_step, 4 drops (%d contacts on the way, %d of them "
              "tip-box pairs, %d of the wheel, %d joint-limit rows): q within %.2e, v within %.2e "
              "(relative; v to at least 1)\n",
              contacts, pair_contacts, wheel, limits, worst_q, worst_v);
  EXPECT_GT(contacts, 1000);
  EXPECT_GT(wheel, 1000);
  EXPECT_GT(limits, 10);
  EXPECT_GT(pair_contacts, 50);
  EXPECT_LE(worst_q, 1e-10);
  EXPECT_LE(worst_v, 1e-10);
}

}  // namespace
