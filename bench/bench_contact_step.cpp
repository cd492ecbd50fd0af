// A step with contact, eomgen against MuJoCo 2.2 on the same scene, side by side in one binary
// (eombench::compare: alternating rounds, the median of the per-round ratios): MuJoCo's humanoid
// on the floor (it fell there from its standing pose, as tests/mjcf lets it fall), and a stack of
// four boxes at rest (models/mjcf/stack.xml); one step from that state, eom::contact_step (the generated mass_matrix and forward_dynamics, the rows, the
// solver run to rounding) against mj_step (its Newton solver at the model's tolerance, and run
// to its limit as tests/mjcf runs it). Both from the same state every call (no warm start
// between calls for either: MuJoCo's qacc_warmstart is reset to the state's).
#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>

#include <bench_humanoid_step.hpp>
#include <bench_humanoid_step_model.hpp>
#include <bench_stack_step.hpp>
#include <bench_stack_step_model.hpp>
#include <eom/contact/step.hpp>

#include "mujoco_peer.hpp"  // tests/support: MuJoCo's model and data owned
#include "paired_timing.hpp"

// One scene side by side: K, Model its generated kernels and header, `file` the same MJCF for
// MuJoCo, `settle` MuJoCo steps from its initial state (with `push` on qvel) before the timed step.
template <class K, class Model>
bool scene(const char* title, const char* file, int settle, const std::array<double, 2>& push) {
  char error[1000] = "";
  eom::test::MujocoModel model(mj_loadXML(file, nullptr, error, sizeof error));
  if (!model) {
    std::fprintf(stderr, "bench_contact_step: %s: %s\n", file, error);
    return false;
  }
  mjModel* m = model.get();
  eom::test::MujocoData data(mj_makeData(m));
  mjData* d = data.get();
  constexpr int nq = K::nq, nv = K::nv;
  const double* p = K::parameter_values.data();
  // The state: let settle (fall, or rest) for a while (MuJoCo), then one step from there.
  std::copy(m->qpos0, m->qpos0 + nq, d->qpos);
  d->qvel[0] = push[0], d->qvel[4] = push[1];
  for (int k = 0; k < settle; ++k) mj_step(m, d);
  std::array<double, nq> q0;
  std::array<double, nv> v0;
  std::copy(d->qpos, d->qpos + nq, q0.begin());
  std::copy(d->qvel, d->qvel + nv, v0.begin());
  auto stepper = std::make_unique<eom::ContactStepper<K, Model>>();
  std::array<double, nq> q;
  std::array<double, nv> v;
  std::array<double, K::nu> u{};
  auto ours = [&](int) {
    q = q0, v = v0;
    stepper->warm = false;  // as MuJoCo's warm start below: not the last call's answer
    double t = 0;
    eombench::sink = static_cast<double>(eom::contact_step<K, Model>(*stepper, t, q, v, u.data(), p));
  };
  auto theirs = [&](int) {
    std::copy(q0.begin(), q0.end(), d->qpos);
    std::copy(v0.begin(), v0.end(), d->qvel);
    std::fill(d->qacc_warmstart, d->qacc_warmstart + nv, 0.0);
    d->time = 0;
    mj_step(m, d);
    eombench::sink = d->qvel[0];
  };
  ours(0);
  theirs(0);
  double diff = 0, scale = 0;
  for (int i = 0; i < nv; ++i)
    diff = std::max(diff, std::abs(v[i] - d->qvel[i])), scale = std::max(scale, std::abs(d->qvel[i]));
  std::printf("%s (%d dof, %d contacts, %d constraint rows, MuJoCo %s): one step's v agrees to "
              "%.1e relative (MuJoCo at its tolerance %.0e)\n",
              title, nv, d->ncon, d->nefc, mj_versionString(), diff / scale, m->opt.tolerance);
  std::printf("%-62s %11s %11s   %s\n", "", "eomgen", "MuJoCo", "ratio");
  eombench::compare("contact step: eom::contact_step / mj_step (MuJoCo's tolerance)", ours, theirs);
  m->opt.tolerance = 1e-15;
  m->opt.iterations = 200;
  eombench::compare("contact step: eom::contact_step / mj_step (run to its limit)", ours, theirs);
  return true;
}

int main() {
  // MuJoCo's humanoid let fall with a push for 0.6 s; the stack of boxes after 0.5 s at rest.
  const bool humanoid = scene<bench_humanoid_step::Kernels, eom::mjcf_models::bench_humanoid_step>(
      "MuJoCo humanoid on the floor", EOM_MJCF_HUMANOID, 120, {0.3, 0.5});
  std::printf("\n");
  const bool stack = scene<bench_stack_step::Kernels, eom::mjcf_models::bench_stack_step>(
      "four boxes stacked on the floor", EOM_MJCF_STACK, 250, {0.0, 0.0});
  return humanoid && stack ? 0 : 1;
}
