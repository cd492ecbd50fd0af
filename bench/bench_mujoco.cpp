// The generated kernels of MuJoCo's own humanoid (libmujoco-samples' humanoid.xml, read through
// add_eom_model(... MJCF ...)) against MuJoCo 2.2 on the same file, side by side in one binary
// (eombench::compare: alternating rounds, the median of the per-round ratios):
//   - forward_dynamics against mj_forward with contacts and constraints disabled (the dynamics
//     both compute: tests/mjcf checks that qacc agrees), at the same state;
//   - forward_dynamics_derivatives (∂v̇/∂q, ∂v̇/∂v, ∂v̇/∂u, exact) against mjd_transitionFD (MuJoCo's
//     derivatives: centred differences of mj_step, giving the step's transition matrices; the
//     figure issue 47 names, not the same quantity: a whole step's sensitivities).
// Opt-in (EOM_BENCH_MUJOCO: the derivative kernel of a 27-dof model takes a while to compile);
// bench/mujoco.sh builds and runs it.
#include <mujoco/mujoco.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <bench_humanoid.hpp>

#include "mujoco_peer.hpp"  // tests/support: MuJoCo's model and data owned
#include "paired_timing.hpp"

int main() {
  using K = bench_humanoid::Kernels;
  char error[1000] = "";
  eom::test::MujocoModel model(mj_loadXML(EOM_MJCF_HUMANOID, nullptr, error, sizeof error));
  if (!model) {
    std::fprintf(stderr, "bench_mujoco: %s: %s\n", EOM_MJCF_HUMANOID, error);
    return 1;
  }
  mjModel* m = model.get();
  m->opt.disableflags |= mjDSBL_CONSTRAINT | mjDSBL_CONTACT;
  eom::test::MujocoData data(mj_makeData(m));
  mjData* d = data.get();
  if (m->nq != K::nq || m->nv != K::nv || m->nu != K::nu) {
    std::fprintf(stderr, "bench_mujoco: the generated model's sizes differ from MuJoCo's\n");
    return 1;
  }
  // One state as tests/mjcf draws them: a unit quaternion, moderate rates, controls in range.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> q(K::nq), v(K::nv), u(K::nu), qdd(K::nv);
  for (double& x : q) x = unit(rng);
  const double n = std::sqrt(q[3] * q[3] + q[4] * q[4] + q[5] * q[5] + q[6] * q[6]);
  for (int i = 3; i < 7; ++i) q[i] /= n;
  for (double& x : v) x = unit(rng);
  for (int i = 0; i < K::nu; ++i) u[i] = 0.5 * unit(rng);
  std::copy(q.begin(), q.end(), d->qpos);
  std::copy(v.begin(), v.end(), d->qvel);
  std::copy(u.begin(), u.end(), d->ctrl);
  const double* p = K::parameter_values.data();

  mj_forward(m, d);
  K::forward_dynamics(0.0, q.data(), v.data(), u.data(), p, qdd.data());
  double diff = 0, scale = 0;
  for (int i = 0; i < K::nv; ++i) diff = std::max(diff, std::abs(qdd[i] - d->qacc[i])), scale = std::max(scale, std::abs(d->qacc[i]));
  std::printf("MuJoCo humanoid (%d dof, MuJoCo %s): qacc agrees to %.1e relative\n", K::nv, mj_versionString(),
              diff / scale);
  std::printf("%-62s %11s %11s   %s\n", "", "eomgen", "MuJoCo", "ratio");
  eombench::compare(
      "forward dynamics: forward_dynamics / mj_forward",
      [&](int) { eombench::sink = K::forward_dynamics(0.0, q.data(), v.data(), u.data(), p, qdd.data()); },
      [&](int) {
        mj_forward(m, d);
        eombench::sink = d->qacc[0];
      });
  std::vector<double> dq(K::nv * K::nv), dv(K::nv * K::nv), du(K::nv * K::nu);
  const int nx = 2 * m->nv + m->na;
  std::vector<mjtNum> A(nx * nx), B(nx * m->nu);
  eombench::compare(
      "derivatives: forward_dynamics_derivatives / mjd_transitionFD",
      [&](int) {
        eombench::sink = K::forward_dynamics_derivatives(0.0, q.data(), v.data(), u.data(), p, dq.data(),
                                                         dv.data(), du.data());
      },
      [&](int) {
        mjd_transitionFD(m, d, 1e-6, 1, A.data(), B.data(), nullptr, nullptr);
        eombench::sink = A[0];
      });
  return 0;
}
