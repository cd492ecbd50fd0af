// The forward dynamics' derivatives of MJCF models (add_eom_model(... MJCF ... KERNELS
// forward_dynamics_derivatives)) against MuJoCo 2.2 itself on the same files: differences of
// MuJoCo's qacc (mj_forward, mjDSBL_CONSTRAINT as in tests/mjcf) in q, v and ctrl at random
// states, for models/mjcf's runner and anchors and for free_arm.xml (a free joint). tests/mjcf
// checks the kernels' values against MuJoCo; this checks their derivatives against an
// implementation that shares no code with eomgen (springs, damping, armature, anchors off the body
// origins, the actuators' gains and biases, which depend on q and v, the force clamps).
//
// q is perturbed on the configuration manifold by MuJoCo's own mj_integratePos along a tangent
// direction: for the free joint x + δ_lin and the quaternion q ⊗ exp(δ_ang/2), which is
// docs/CONTRACT.md §2's convention for ∂/∂q; for hinges and slides q + δ. ctrl is drawn inside
// the control ranges (at a clamp the derivative in ctrl does not exist), and a state where an
// actuator's force lies within 0.1 of a force-range end is drawn again (differences across the
// kink would be meaningless; the steps below move a force by less than 0.02, kp · h with the
// largest kp, 50, of a force-limited actuator); elsewhere the force clamp acting or not is fine,
// the derivative being that of the side taken, in both.
//
// The differences and the tolerance: central differences D(h) extrapolated, (4 D(h/2) − D(h))/3,
// with h = 3e-4 (q, v and ctrl are of order 1): truncation O(h⁴) ≈ 1e-14 (times the fifth
// derivative), rounding about 2ε · max |v̇| / h ≈ 3e-12 · max |v̇|, relative to max |∂v̇|. The
// worst differences measured (printed) are 1.5e-10 (free_arm's ∂v̇/∂v) and below; a plain central
// difference with h = 1e-6 gave up to 8e-9, with h = 1e-5 5e-9. The tolerance 1e-9 leaves a
// factor of 6 over the worst measured.
#include <gtest/gtest.h>

#include <mujoco/mujoco.h>

#include "mujoco_peer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <vector>

#include <peer_anchors.hpp>
#include <peer_free_arm.hpp>
#include <peer_runner.hpp>

namespace {

using Deleter = eom::test::MujocoDeleter;
using eom::test::relative;


// Actuator i's force before its force range: gain · ctrl + bias (fixed or affine gain, affine or
// no bias: what eomgen-mjcf accepts), at the state mj_forward left in d.
double unclamped_force(const mjModel* m, const mjData* d, int i) {
  const double L = d->actuator_length[i], V = d->actuator_velocity[i];
  const double* g = m->actuator_gainprm + mjNGAIN * i;
  const double* b = m->actuator_biasprm + mjNBIAS * i;
  const double gain = m->actuator_gaintype[i] == mjGAIN_AFFINE ? g[0] + g[1] * L + g[2] * V : g[0];
  const double bias = m->actuator_biastype[i] == mjBIAS_AFFINE ? b[0] + b[1] * L + b[2] * V : 0.0;
  return gain * d->ctrl[i] + bias;
}

struct Worst {
  double forward = 0, dq = 0, dv = 0, du = 0;
  int clamped = 0, redrawn = 0;  // states with a force clamp acting; states drawn again
};

template <class K>
Worst compare(const char* file, int samples) {
  char error[1000] = "";
  std::unique_ptr<mjModel, Deleter> model(mj_loadXML(file, nullptr, error, sizeof error));
  EXPECT_TRUE(model) << error;
  if (!model) return {};
  mjModel* m = model.get();
  m->opt.disableflags |= mjDSBL_CONSTRAINT;
  std::unique_ptr<mjData, Deleter> data(mj_makeData(m));
  mjData* d = data.get();
  constexpr int nq = K::nq, nv = K::nv, nu = K::nu;
  EXPECT_EQ(nq, m->nq);
  EXPECT_EQ(nv, m->nv);
  EXPECT_EQ(nu, m->nu);
  if (nq != m->nq || nv != m->nv || nu != m->nu) return {};
  for (int i = 0; i < nu; ++i) EXPECT_EQ(m->actuator_dyntype[i], mjDYN_NONE);
  const double* p = K::parameter_values.data();
  const double h = 3e-4, margin = 0.1;
  std::mt19937_64 rng(47);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Worst worst;
  std::vector<double> q(nq), v(nv), u(nu), qdd(nv), dq(nv * nv), dv(nv * nv), du(nv * nu),
      fd_q(nv * nv), fd_v(nv * nv), fd_u(nv * nu), up(nv), down(nv);
  // MuJoCo's qacc at (qpos, qvel, ctrl).
  auto qacc = [&](const std::vector<double>& qpos, const std::vector<double>& qvel,
                  const std::vector<double>& ctrl, std::vector<double>& out) {
    std::copy(qpos.begin(), qpos.end(), d->qpos);
    std::copy(qvel.begin(), qvel.end(), d->qvel);
    std::copy(ctrl.begin(), ctrl.end(), d->ctrl);
    mj_forward(m, d);
    std::copy(d->qacc, d->qacc + nv, out.begin());
  };
  for (int sample = 0; sample < samples;) {
    for (int i = 0; i < nq; ++i) q[i] = unit(rng);
    if constexpr (nq > nv) {  // the free joint's quaternion, unit
      const double n = std::sqrt(q[3] * q[3] + q[4] * q[4] + q[5] * q[5] + q[6] * q[6]);
      for (int i = 3; i < 7; ++i) q[i] /= n;
    }
    for (int i = 0; i < nv; ++i) v[i] = 2 * unit(rng);
    for (int i = 0; i < nu; ++i) {  // inside the control range, off its ends
      const double* range = m->actuator_ctrlrange + 2 * i;
      u[i] = m->actuator_ctrllimited[i]
                 ? 0.5 * (range[0] + range[1]) + 0.4 * (range[1] - range[0]) * unit(rng)
                 : 2 * unit(rng);
    }
    qacc(q, v, u, qdd);
    bool near_kink = false, clamped = false;
    for (int i = 0; i < nu; ++i) {
      if (!m->actuator_forcelimited[i]) continue;
      const double f = unclamped_force(m, d, i), *range = m->actuator_forcerange + 2 * i;
      near_kink |= std::min(std::abs(f - range[0]), std::abs(f - range[1])) < margin;
      clamped |= f < range[0] || f > range[1];
    }
    if (near_kink) {
      ++worst.redrawn;
      continue;
    }
    ++sample;
    worst.clamped += clamped;

    std::vector<double> ours(nv);
    EXPECT_TRUE(K::forward_dynamics(0.0, q.data(), v.data(), u.data(), p, ours.data()));
    worst.forward = std::max(worst.forward, relative(ours.data(), qdd.data(), nv));
    EXPECT_TRUE(K::forward_dynamics_derivatives(0.0, q.data(), v.data(), u.data(), p, dq.data(),
                                                dv.data(), du.data()));

    // Column j of the differences in q (which = 0, along MuJoCo's q ⊕ step e_j), v (1) or ctrl (2).
    auto central = [&](int which, int j, double step, double* column) {
      std::vector<double> qp = q, qm = q, vp = v, vm = v, cp = u, cm = u, direction(nv);
      if (which == 0) {
        direction[j] = 1;
        mj_integratePos(m, qp.data(), direction.data(), step);
        mj_integratePos(m, qm.data(), direction.data(), -step);
      } else {
        (which == 1 ? vp : cp)[j] += step;
        (which == 1 ? vm : cm)[j] -= step;
      }
      qacc(qp, vp, cp, up);
      qacc(qm, vm, cm, down);
      for (int i = 0; i < nv; ++i) column[i] = (up[i] - down[i]) / (2 * step);
    };
    std::vector<double> coarse(nv), fine(nv);
    for (int which = 0; which < 3; ++which) {
      double* fd = which == 0 ? fd_q.data() : which == 1 ? fd_v.data() : fd_u.data();
      for (int j = 0; j < (which == 2 ? nu : nv); ++j) {
        central(which, j, h, coarse.data());
        central(which, j, h / 2, fine.data());
        for (int i = 0; i < nv; ++i) fd[i + nv * j] = (4 * fine[i] - coarse[i]) / 3;
      }
    }
    worst.dq = std::max(worst.dq, relative(dq.data(), fd_q.data(), nv * nv));
    worst.dv = std::max(worst.dv, relative(dv.data(), fd_v.data(), nv * nv));
    worst.du = std::max(worst.du, relative(du.data(), fd_u.data(), nv * nu));
  }
  std::printf(
      "%s: over %d states (%d with a force clamp acting, %d drawn again near one): forward "
      "dynamics %.2e from qacc; derivatives from MuJoCo's extrapolated differences (h = %g): "
      "dv̇/dq %.2e, dv̇/dv %.2e, dv̇/du %.2e\n",
      file, samples, worst.clamped, worst.redrawn, worst.forward, h, worst.dq, worst.dv, worst.du);
  return worst;
}

void expect_agreement(const Worst& w) {
  EXPECT_LE(w.forward, 1e-12);
  EXPECT_LE(w.dq, 1e-9);
  EXPECT_LE(w.dv, 1e-9);
  EXPECT_LE(w.du, 1e-9);
}

TEST(mujoco_derivatives, RunnerAgreesWithMuJoCo) {
  expect_agreement(compare<peer_runner::Kernels>(EOM_MJCF_RUNNER, 100));
}
TEST(mujoco_derivatives, AnchorsAgreeWithMuJoCo) {
  expect_agreement(compare<peer_anchors::Kernels>(EOM_MJCF_ANCHORS, 100));
}
TEST(mujoco_derivatives, FreeArmAgreesWithMuJoCo) {
  expect_agreement(compare<peer_free_arm::Kernels>(EOM_FREE_ARM, 100));
}

}  // namespace
