// MuJoCo's equality constraints as soft rows of the contact step (eom::contact_step on
// models/mjcf/tethers.xml: a connect, a weld between two free bodies with a torquescale, a joint
// equality, among contacts with the floor) against MuJoCo on the states of its own rollouts, its
// solver run to its limit: at every state the forces without constraints (−τ of the inverse
// dynamics at v̇ = 0 against qfrc_smooth), each equality row (pos, J, aref, R, D, diagApprox)
// against MuJoCo's efc arrays, the constrained acceleration against mj_forward's qacc, and one
// step from MuJoCo's state against mj_step. aref and R are as well conditioned as the residual
// allows: a difference δ in pos moves aref by K·(I + |I′|·|pos|)·δ (K the stiffness, I the
// impedance, I′ its slope, from MuJoCo's efc_KBIP; K ≈ 2800 /s² for solref 0.02) and R by
// |I′|·δ / (I (1 − I)) relative, which the bounds add to 1e-12 (δ the equality's largest over
// its rows, times 2 for the norm). A weld's rotation rows are the model's φ, the vector
// part of the relative quaternion with w ≥ 0: MuJoCo's (the sign its body quaternions give) are
// compared in that hemisphere (both the residual and the Jacobian turn sign there, so qacc does
// not).
// The same scene under two options set at run time on both sides (MuJoCo's m->opt, eomgen's
// Model::solver_options in a model derived from the header's): RK4, one step from MuJoCo's states
// against mj_step; and MuJoCo's equality disable flag, no equality rows, qacc against mj_forward's
// and one Euler step against mj_step.
#include <gtest/gtest.h>

#include <mujoco/mujoco.h>

#include "contact_peer.hpp"
#include "mujoco_peer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <mjcf_tethers.hpp>
#include <mjcf_tethers_model.hpp>

#include <eom/contact/constraints.hpp>
#include <eom/contact/step.hpp>

namespace {

using eom::test::relative;
using Model = eom::mjcf_models::mjcf_tethers;
using K = mjcf_tethers::Kernels;

// The model with the header's options but the integrator and disable flags given.
template <int integrator, int disable_flags> struct WithOptions : Model {
  static constexpr eom::SolverOptions solver_options = [] {
    eom::SolverOptions o = Model::solver_options;
    o.integrator = integrator;
    o.disable_flags = disable_flags;
    return o;
  }();
};
using RK4 = WithOptions<1, 0>;
using NoEqualities = WithOptions<0, mjDSBL_EQUALITY>;
static_assert(Model::solver_options.integrator == 0 && Model::solver_options.disable_flags == 0);
static_assert(mjDSBL_EQUALITY == eom::detail::disable_equality);

// A run of sim from the model's qpos0 at velocities drawn from rng.
template <class M> void start(eom::test::SideBySide<K, M>& sim, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::array<double, K::nv> v0;
  for (double& x : v0) x = 0.5 * unit(rng);
  sim.start(sim.model->qpos0, v0.data());
}

// MuJoCo's state handed to eomgen's side (the next step is one from MuJoCo's state); the largest
// equality residual |φ| there.
template <class M> double take_mujocos_state(eom::test::SideBySide<K, M>& sim) {
  const mjData* d = sim.data.get();
  std::copy(d->qpos, d->qpos + K::nq, sim.q.begin());
  std::copy(d->qvel, d->qvel + K::nv, sim.v.begin());
  sim.t = d->time;
  std::array<double, K::nc> phi;
  K::constraint_residual(sim.q.data(), K::parameter_values.data(), phi.data());
  double largest = 0;
  for (double x : phi) largest = std::max(largest, std::abs(x));
  return largest;
}

TEST(mjcf_tethers, SoftEqualitiesStepAsInMuJoCo) {
  static_assert(K::nc == 10 && Model::equality_softness.size() == 3);
  eom::test::SideBySide<K, Model> sim(EOM_MJCF_TETHERS);
  ASSERT_TRUE(sim.model);
  mjModel* m = sim.model.get();
  mjData* d = sim.data.get();
  constexpr int nq = K::nq, nv = K::nv;
  ASSERT_EQ(m->nq, nq);
  ASSERT_EQ(m->nv, nv);
  std::mt19937_64 rng(49);
  std::array<double, nv> zero{}, tau;
  std::array<double, nq> q_start;
  std::array<double, nv> v_start;
  double aref_ratio = 0, R_ratio = 0;  // each difference over its bound
  double worst_smooth = 0, worst_pos = 0, worst_J = 0, worst_aref = 0, worst_R = 0,
         worst_qacc = 0, worst_step = 0, largest_pos = 0;
  int contacts = 0, states = 0, flipped = 0;
  for (int run = 0; run < 3; ++run) {
    start(sim, rng);
    for (int k = 0; k < 300; ++k, ++states) {
      take_mujocos_state(sim);
      q_start = sim.q, v_start = sim.v;
      const auto [status, difference] = sim.step();
      ASSERT_EQ(status, eom::StepStatus::ok) << run << " " << k;
      worst_step = std::max(worst_step, difference);
      // d holds mj_forward's arrays of the state the step started from, as sim.stepper its rows.
      const eom::ConstraintRows<Model>& rows = sim.stepper->rows;
      ASSERT_EQ(rows.rows, d->nefc);
      ASSERT_EQ(rows.ncontacts, d->ncon);
      ASSERT_EQ(d->ne, K::nc);
      contacts += d->ncon;
      worst_qacc = std::max(worst_qacc, relative(sim.stepper->solution.qacc.data(), d->qacc, nv));
      K::inverse_dynamics(0.0, q_start.data(), v_start.data(), zero.data(), nullptr,
                          K::parameter_values.data(), tau.data());
      for (double& x : tau) x = -x;
      worst_smooth = std::max(worst_smooth, relative(tau.data(), d->qfrc_smooth, nv));
      for (int e = 0, r = 0; e < m->neq; ++e) {
        const int size = m->eq_type[e] == mjEQ_CONNECT ? 3 : m->eq_type[e] == mjEQ_WELD ? 6 : 1;
        double w = 1;  // of neg(q2) q1 relpose, as mj_instantiateEquality
        if (m->eq_type[e] == mjEQ_WELD) {
          mjtNum q1r[4], q2n[4], err[4];
          mju_mulQuat(q1r, d->xquat + 4 * m->eq_obj1id[e], m->eq_data + mjNEQDATA * e + 6);
          mju_negQuat(q2n, d->xquat + 4 * m->eq_obj2id[e]);
          mju_mulQuat(err, q2n, q1r);
          w = err[0];
          flipped += w < 0;
        }
        double delta = 0;  // the largest difference of the equality's pos
        for (int i = r; i < r + size; ++i) {
          const double sign = i >= r + 3 && w < 0 ? -1 : 1;
          delta = std::max(delta, std::abs(rows.pos[i] - sign * d->efc_pos[i]));
        }
        delta *= 2;
        for (int i = r; i < r + size; ++i) {
          ASSERT_EQ(rows.kind[i], eom::RowKind::equality);
          ASSERT_EQ(d->efc_type[i], mjCNSTR_EQUALITY);
          ASSERT_EQ(rows.id[i], d->efc_id[i]);
          const double sign = i >= r + 3 && w < 0 ? -1 : 1;
          std::array<double, nv> J;
          for (int j = 0; j < nv; ++j) J[j] = sign * d->efc_J[i * nv + j];
          largest_pos = std::max(largest_pos, std::abs(d->efc_pos[i]));
          worst_pos = std::max(worst_pos, std::abs(rows.pos[i] - sign * d->efc_pos[i]));
          worst_J = std::max(worst_J, relative(rows.J.data() + i * nv, J.data(), nv));
          const double aref = std::abs(rows.aref[i] - sign * d->efc_aref[i]) /
                              std::max(1.0, std::abs(d->efc_aref[i]));
          const double R = std::max({std::abs(rows.R[i] / d->efc_R[i] - 1),
                                     std::abs(rows.D[i] / d->efc_D[i] - 1),
                                     std::abs(rows.diag_approx[i] / d->efc_diagApprox[i] - 1)});
          const double* KBIP = d->efc_KBIP + 4 * i;  // stiffness, damping, impedance, its slope
          const double slope = std::abs(KBIP[3]);
          worst_aref = std::max(worst_aref, aref);
          worst_R = std::max(worst_R, R);
          aref_ratio = std::max(
              aref_ratio, aref / (1e-12 + KBIP[0] * (KBIP[2] + slope * std::abs(d->efc_pos[i])) *
                                              delta / std::max(1.0, std::abs(d->efc_aref[i]))));
          R_ratio = std::max(R_ratio, R / (1e-12 + slope * delta / (KBIP[2] * (1 - KBIP[2]))));
        }
        r += size;
      }
    }
  }
  std::printf(
      "%s: %d states of MuJoCo's rollouts (%d contacts on the way, %d with the weld's w < 0, "
      "largest residual %.2e): forces without constraints %.2e; equality rows against MuJoCo's: "
      "pos %.2e, J %.2e, aref %.2e (%.2f of its bound), R, D and diagApprox %.2e (relative; %.2f of "
      "its bound); qacc %.2e (relative); "
      "one step against mj_step: q and v %.2e (relative)\n",
      EOM_MJCF_TETHERS, states, contacts, flipped, largest_pos, worst_smooth, worst_pos, worst_J,
      worst_aref, aref_ratio, worst_R, R_ratio, worst_qacc, worst_step);
  EXPECT_GT(contacts, 500);
  EXPECT_GT(largest_pos, 1e-4);  // the equalities do give way
  EXPECT_LE(worst_smooth, 1e-12);
  EXPECT_LE(worst_pos, 1e-12);
  EXPECT_LE(worst_J, 1e-12);
  EXPECT_LE(aref_ratio, 1.0);
  EXPECT_LE(R_ratio, 1.0);
  EXPECT_LE(worst_qacc, 1e-8);
  EXPECT_LE(worst_step, 1e-10);
}

// One RK4 step from each state of MuJoCo's RK4 rollouts (integrator set on both sides) against
// mj_step: q, v and t after it, the contacts of RK4's last stage and their forces. Beside it,
// MuJoCo's Euler from the same state: RK4 must stand far from it, so that the comparison tells
// the integrators apart.
TEST(mjcf_tethers, RK4StepsAsInMuJoCo) {
  eom::test::SideBySide<K, RK4> sim(EOM_MJCF_TETHERS);
  ASSERT_TRUE(sim.model);
  mjModel* m = sim.model.get();
  mjData* d = sim.data.get();
  m->opt.integrator = mjINT_RK4;
  eom::test::MujocoModel euler_model(mj_copyModel(nullptr, m));
  euler_model->opt.integrator = mjINT_EULER;
  eom::test::MujocoData euler_data(mj_makeData(euler_model.get()));
  mjData* e = euler_data.get();
  constexpr int nq = K::nq, nv = K::nv;
  std::mt19937_64 rng(4949);
  double worst = 0, forces = 0, from_euler = 0, largest_phi = 0;
  int contacts = 0, states = 0;
  for (int run = 0; run < 2; ++run) {
    start(sim, rng);
    for (int k = 0; k < 300; ++k, ++states) {
      largest_phi = std::max(largest_phi, take_mujocos_state(sim));
      std::copy(d->qpos, d->qpos + nq, e->qpos);
      std::copy(d->qvel, d->qvel + nv, e->qvel);
      std::copy(d->qacc_warmstart, d->qacc_warmstart + nv, e->qacc_warmstart);
      e->time = d->time;
      mj_step(euler_model.get(), e);
      const auto [status, difference] = sim.step();
      ASSERT_EQ(status, eom::StepStatus::ok) << run << " " << k;
      worst = std::max(worst, difference);
      from_euler = std::max({from_euler, relative(e->qpos, d->qpos, nq),
                             relative(e->qvel, d->qvel, nv)});
      EXPECT_EQ(sim.t, d->time) << run << " " << k;
      ASSERT_EQ(d->ne, K::nc);  // RK4's last stage
      ASSERT_EQ(sim.stepper->rows.ncontacts, d->ncon) << run << " " << k;
      contacts += d->ncon;
      forces = std::max(forces, eom::test::force_difference(m, d, *sim.stepper));
    }
  }
  std::printf("%s: one RK4 step of eom::contact_step against mj_step from %d states of MuJoCo's "
              "RK4 rollouts (%d contacts in the last stages, largest equality residual %.2e): q "
              "and v within %.2e (relative), contact forces within %.2e; MuJoCo's Euler from the same "
              "states %.2e away\n",
              EOM_MJCF_TETHERS, states, contacts, largest_phi, worst, forces, from_euler);
  EXPECT_GT(contacts, 300);
  EXPECT_GT(largest_phi, 1e-4);  // the equalities do give way
  EXPECT_LE(worst, 1e-10);
  EXPECT_LE(forces, 1e-10);
  EXPECT_GT(from_euler, 1e-4);
}

// MuJoCo's <flag equality="disable"/> (set on both sides): the equalities leave no rows, the
// tethered box falls free, the twin arm swings on its own. At every state of MuJoCo's rollouts:
// the rows those of MuJoCo in number (contacts only), the constrained acceleration against
// mj_forward's qacc, and one Euler step against mj_step.
TEST(mjcf_tethers, DisabledEqualitiesLeaveNoRows) {
  eom::test::SideBySide<K, NoEqualities> sim(EOM_MJCF_TETHERS);
  ASSERT_TRUE(sim.model);
  mjModel* m = sim.model.get();
  mjData* d = sim.data.get();
  m->opt.disableflags |= mjDSBL_EQUALITY;
  constexpr int nv = K::nv;
  std::mt19937_64 rng(4950);
  double worst_qacc = 0, worst_step = 0, largest_phi = 0;
  int contacts = 0, states = 0;
  for (int run = 0; run < 2; ++run) {
    start(sim, rng);
    for (int k = 0; k < 300; ++k, ++states) {
      largest_phi = std::max(largest_phi, take_mujocos_state(sim));
      const auto [status, difference] = sim.step();
      ASSERT_EQ(status, eom::StepStatus::ok) << run << " " << k;
      worst_step = std::max(worst_step, difference);
      // d holds mj_forward's arrays of the state the step started from, as sim.stepper its rows.
      const auto& rows = sim.stepper->rows;
      ASSERT_EQ(d->ne, 0);
      ASSERT_EQ(rows.rows, d->nefc) << run << " " << k;
      ASSERT_EQ(rows.ncontacts, d->ncon) << run << " " << k;
      for (int i = 0; i < rows.rows; ++i)
        ASSERT_NE(rows.kind[i], eom::RowKind::equality) << run << " " << k << " " << i;
      contacts += d->ncon;
      worst_qacc = std::max(worst_qacc, relative(sim.stepper->solution.qacc.data(), d->qacc, nv));
    }
  }
  std::printf("%s, equalities disabled: %d states of MuJoCo's rollouts (%d contacts, no equality "
              "rows, largest equality residual %.2e): qacc %.2e (relative); one step against "
              "mj_step: q and v %.2e (relative)\n",
              EOM_MJCF_TETHERS, states, contacts, largest_phi, worst_qacc, worst_step);
  EXPECT_GT(contacts, 300);
  EXPECT_GT(largest_phi, 0.1);  // the equalities no longer hold
  EXPECT_LE(worst_qacc, 1e-8);
  EXPECT_LE(worst_step, 1e-10);
}

}  // namespace
