// MuJoCo's RK4 with contact: eom::contact_step on models/mjcf/rk4.xml (<option integrator="RK4">:
// free bodies falling onto a floor, a limited and damped hinge driven by a motor, damped slides
// with friction loss) against mj_step with the same option, MuJoCo's Newton solver run to its
// limit. One step at a time from the states of MuJoCo's own rollouts under random controls: q, v
// and t after the step, the contact set and every contact's force (those of RK4's last stage, as
// mjData holds them after mj_step); and the two stepped side by side from the same start.
#include <gtest/gtest.h>

#include <mujoco/mujoco.h>

#include "contact_peer.hpp"
#include "mujoco_peer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

#include <mjcf_rk4.hpp>
#include <mjcf_rk4_model.hpp>

#include <eom/contact/solver.hpp>
#include <eom/contact/step.hpp>

namespace {

using eom::test::relative;
using Model = eom::mjcf_models::mjcf_rk4;
using K = mjcf_rk4::Kernels;

static_assert(Model::solver_options.integrator == 1, "the header carries <option integrator=\"RK4\">");

eom::test::MujocoModel load() {
  eom::test::MujocoModel model(mj_loadXML(EOM_MJCF_RK4, nullptr, nullptr, 0));
  if (model) {
    model->opt.tolerance = 1e-15;
    model->opt.iterations = 200;
  }
  return model;
}

// A start near the bodies' own positions: the free bodies moved a little and turned, the slides
// near their rest, the limited hinge anywhere in its range or a little past it, every velocity
// random.
void start(const mjModel* m, mjData* d, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  mj_resetData(m, d);
  for (int j = 0; j < m->njnt; ++j) {
    const int a = m->jnt_qposadr[j];
    if (m->jnt_type[j] == mjJNT_FREE) {
      for (int k = 0; k < 3; ++k) d->qpos[a + k] += 0.03 * unit(rng);
      double n = 0;
      for (int k = 3; k < 7; ++k) {
        d->qpos[a + k] += 0.3 * unit(rng);
        n += d->qpos[a + k] * d->qpos[a + k];
      }
      for (int k = 3; k < 7; ++k) d->qpos[a + k] /= std::sqrt(n);
    } else if (m->jnt_limited[j]) {  // within its range or a little past either end
      const double* range = m->jnt_range + 2 * j;
      d->qpos[a] = 0.5 * (range[0] + range[1]) + (0.5 * (range[1] - range[0]) + 0.1) * unit(rng);
    } else {
      d->qpos[a] = 0.03 * unit(rng);
    }
  }
  for (int i = 0; i < m->nv; ++i) d->qvel[i] = unit(rng);
}

// MuJoCo's model and data beside eomgen's stepper and state, stepped together.
struct SideBySide {
  eom::test::MujocoModel model = load();
  eom::test::MujocoData data{model ? mj_makeData(model.get()) : nullptr};
  std::unique_ptr<eom::ContactStepper<K, Model>> stepper =
      std::make_unique<eom::ContactStepper<K, Model>>();
  std::array<double, K::nq> q{};
  std::array<double, K::nv> v{};
  std::array<double, K::nu> u{};
  double t = 0;
  std::mt19937_64 rng;
  std::uniform_real_distribution<double> unit{-1.0, 1.0};

  explicit SideBySide(unsigned seed) : rng(seed) {}
  // A new run: MuJoCo's state from start(), eomgen's the same, its solver cold.
  void begin() {
    start(model.get(), data.get(), rng);
    take_mujocos_state();
    stepper->warm = false;
  }
  void take_mujocos_state() {
    std::copy(data->qpos, data->qpos + K::nq, q.begin());
    std::copy(data->qvel, data->qvel + K::nv, v.begin());
    t = data->time;
  }
  // Random controls to both (scaled by reach: past the motor's range where it is above 1).
  void draw_controls(double reach) {
    for (int i = 0; i < K::nu; ++i) data->ctrl[i] = u[i] = reach * unit(rng);
  }
  // One step of each: eomgen's status.
  eom::StepStatus step() {
    mj_step(model.get(), data.get());
    return eom::contact_step<K, Model>(*stepper, t, q, v, u.data(), K::parameter_values.data());
  }
  // The larger relative difference of q and v from MuJoCo's.
  double difference() const {
    return std::max(relative(q.data(), data->qpos, K::nq), relative(v.data(), data->qvel, K::nv));
  }
};

// One step from each state of 8 MuJoCo rollouts of 150 steps (0.6 s), controls drawn beyond the
// motor's range (its clamp acts). Beside it, MuJoCo's Euler from the same state: RK4 must stand
// far from it, so that the comparison tells the integrators apart.
TEST(mjcf_rk4, OneStepAgreesWithMuJoCo) {
  SideBySide sim(4901);
  ASSERT_TRUE(sim.model);
  mjModel* m = sim.model.get();
  mjData* d = sim.data.get();
  ASSERT_EQ(m->opt.integrator, mjINT_RK4);
  eom::test::MujocoModel euler_model(mj_copyModel(nullptr, m));
  euler_model->opt.integrator = mjINT_EULER;
  eom::test::MujocoData euler_data(mj_makeData(euler_model.get()));
  mjData* e = euler_data.get();
  double worst = 0, forces = 0, from_euler = 0, norm = 0;
  int contacts = 0, limited = 0, states = 0;
  for (int run = 0; run < 8; ++run) {
    sim.begin();
    for (int k = 0; k < 150; ++k) {
      sim.draw_controls(1.5);
      sim.take_mujocos_state();
      std::copy(d->qpos, d->qpos + K::nq, e->qpos);
      std::copy(d->qvel, d->qvel + K::nv, e->qvel);
      std::copy(d->ctrl, d->ctrl + K::nu, e->ctrl);
      std::copy(d->qacc_warmstart, d->qacc_warmstart + K::nv, e->qacc_warmstart);
      mj_step(euler_model.get(), e);
      ASSERT_EQ(sim.step(), eom::StepStatus::ok) << run << " " << k;
      ++states;
      worst = std::max(worst, sim.difference());
      from_euler = std::max(
          {from_euler, relative(e->qpos, d->qpos, K::nq), relative(e->qvel, d->qvel, K::nv)});
      norm = std::max(norm, eom::quaternion_norm_error(eom::layout_of<K>(), sim.q.data()));
      EXPECT_EQ(sim.t, d->time) << run << " " << k;
      ASSERT_EQ(sim.stepper->rows.ncontacts, d->ncon) << run << " " << k;
      contacts += d->ncon;
      for (int r = 0; r < d->nefc; ++r) limited += d->efc_type[r] == mjCNSTR_LIMIT_JOINT;
      forces = std::max(forces, eom::test::force_difference(m, d, *sim.stepper));
    }
  }
  std::printf("%s: one RK4 step of eom::contact_step against mj_step from %d states of MuJoCo's "
              "rollouts (%d contacts, %d limit rows in the last stages): q and v within %.2e "
              "(relative), contact forces within %.2e; MuJoCo's Euler from the same states %.2e "
              "away; quaternion norms within %.1e of 1\n",
              EOM_MJCF_RK4, states, contacts, limited, worst, forces, from_euler, norm);
  EXPECT_GT(contacts, 2000);
  EXPECT_GT(limited, 50);
  EXPECT_LE(worst, 1e-10);  // issue 49's figure for one step
  EXPECT_LE(forces, 1e-10);
  EXPECT_GT(from_euler, 1e-4);
  EXPECT_LE(norm, 1e-15);
}

// Both stepped on from the same start, each from its own state, 4 runs of 250 steps (1 s: the
// bodies land, tumble and come to rest): the difference grows only by rounding's propagation.
TEST(mjcf_rk4, StepsBesideMuJoCo) {
  SideBySide sim(4902);
  ASSERT_TRUE(sim.model);
  double worst = 0, forces = 0;
  int contacts = 0;
  for (int run = 0; run < 4; ++run) {
    sim.begin();
    for (int k = 0; k < 250; ++k) {
      sim.draw_controls(1.0);
      ASSERT_EQ(sim.step(), eom::StepStatus::ok) << run << " " << k;
      worst = std::max(worst, sim.difference());
      ASSERT_EQ(sim.stepper->rows.ncontacts, sim.data->ncon) << run << " " << k;
      contacts += sim.data->ncon;
      forces = std::max(
          forces, eom::test::force_difference(sim.model.get(), sim.data.get(), *sim.stepper));
    }
    EXPECT_EQ(sim.t, sim.data->time);
  }
  std::printf("%s: eom::contact_step (RK4) beside mj_step over 4 runs of 250 steps (%d contacts): "
              "q and v within %.2e (relative), contact forces within %.2e\n",
              EOM_MJCF_RK4, contacts, worst, forces);
  EXPECT_GT(contacts, 1000);
  EXPECT_LE(worst, 1e-9);
  EXPECT_LE(forces, 1e-9);
}

// A failed step leaves the state as it was, also when a later stage fails: the puck's vertical
// slide (no damping) so high and fast that the first stage is finite and the second's position
// (q + h/2 v) overflows. The first stage's solve succeeded (the stepper is warm), the step failed.
TEST(mjcf_rk4, FailedStepKeepsTheState) {
  static_assert(K::nq == 18 && K::nv == 16, "two free bodies, then pivot, px, py, pz");
  auto stepper = std::make_unique<eom::ContactStepper<K, Model>>();
  std::array<double, K::nq> q{};
  std::array<double, K::nv> v{};
  q[3] = q[10] = 1;  // the free bodies' quaternions
  q[K::nq - 1] = 1.796e308, v[K::nv - 1] = 1e308;  // + h/2 v: past the largest double
  const auto q0 = q;
  const auto v0 = v;
  const std::array<double, K::nu> u{};
  double t = 0.5;
  const auto status =
      eom::contact_step<K, Model>(*stepper, t, q, v, u.data(), K::parameter_values.data());
  EXPECT_EQ(status, eom::StepStatus::dynamics_failed);
  EXPECT_TRUE(stepper->warm);
  EXPECT_EQ(t, 0.5);
  EXPECT_EQ(q, q0);
  EXPECT_EQ(v, v0);
}

}  // namespace
