// A step with contact, eomgen against MuJoCo 2.2 on the same scene, side by side in one binary
// (eombench::compare: alternating rounds, the median of the per-round ratios): MuJoCo's humanoid
// on the floor (it fell there from its standing pose, as tests/mjcf lets it fall), and a stack of
// four boxes at rest (models/mjcf/stack.xml); one step from that state, eom::contact_step (the generated mass_matrix and forward_dynamics, the rows, the
// solver run to rounding) against mj_step (its Newton solver at the model's tolerance, and run
// to its limit as tests/mjcf runs it). Both from the same state every call (no warm start
// between calls for either: MuJoCo's qacc_warmstart is reset to the state's).
// Then ensembles: N humanoids let fall from their standing pose with random pushes and random
// controls at every step, eom::contact_rollout on all cores against MuJoCo with one mjData per
// thread (the same thread pool, cases handed out the same way), steps per second of each.
#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <thread>
#include <vector>

#include <bench_humanoid_step.hpp>
#include <bench_humanoid_step_model.hpp>
#include <bench_stack_step.hpp>
#include <bench_stack_step_model.hpp>
#include <eom/contact/rollout.hpp>
#include <eom/contact/step.hpp>

#include "mujoco_peer.hpp"  // tests/support: MuJoCo's model and data owned
#include "paired_timing.hpp"

// MuJoCo's model of `file`; null, the reason printed, where MuJoCo cannot load it.
eom::test::MujocoModel load(const char* file) {
  char error[1000] = "";
  eom::test::MujocoModel model(mj_loadXML(file, nullptr, error, sizeof error));
  if (!model) std::fprintf(stderr, "bench_contact_step: %s: %s\n", file, error);
  return model;
}

// One scene side by side: K, Model its generated kernels and header, `file` the same MJCF for
// MuJoCo, `settle` MuJoCo steps from its initial state (with `push` on qvel) before the timed step.
template <class K, class Model>
bool scene(const char* title, const char* file, int settle, const std::array<double, 2>& push) {
  eom::test::MujocoModel model = load(file);
  if (!model) return false;
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

// N humanoids × `steps` steps on `threads` threads: eom::contact_rollout against MuJoCo, one mjData
// per thread (reset to each case's state; its warm start carried from step to step within a case,
// as contact_step's). Alternating timed rounds; the medians of each side's steps per second and of
// the per-round ratios.
template <class K, class Model> bool ensemble(const char* file, std::size_t cases, long steps, unsigned threads) {
  eom::test::MujocoModel model = load(file);
  if (!model) return false;
  mjModel* m = model.get();
  constexpr int nq = K::nq, nv = K::nv, nu = K::nu;
  std::mt19937_64 rng(49);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> q0, v0(cases * nv), u(cases * steps * nu);
  for (std::size_t c = 0; c < cases; ++c) {
    q0.insert(q0.end(), m->qpos0, m->qpos0 + nq);
    v0[c * nv + 0] = 0.3 * unit(rng), v0[c * nv + 1] = 0.3 * unit(rng), v0[c * nv + 4] = 0.5 * unit(rng);
  }
  for (double& x : u) x = unit(rng);  // beyond ctrlrange at times: both clamp
  const eom::RolloutCases rollout_cases{q0, v0, u, K::parameter_values};
  const eom::RolloutOptions opt{.steps = steps, .threads = threads};
  std::vector<double> final_q(cases * nq);
  std::vector<eom::test::MujocoData> data(threads);
  for (auto& d : data) d.reset(mj_makeData(m));
  auto ours = [&] {
    const eom::RolloutResult r = eom::contact_rollout<K, Model>(rollout_cases, opt);
    eombench::sink = r.q[2];
    return r.failed();
  };
  auto theirs = [&] {
    std::atomic<unsigned> slot{0};
    std::atomic<std::size_t> next{0};
    auto work = [&] {
      mjData* d = data[slot.fetch_add(1)].get();
      for (std::size_t c; (c = next.fetch_add(1, std::memory_order_relaxed)) < cases;) {
        mj_resetData(m, d);
        std::copy_n(q0.data() + c * nq, nq, d->qpos);
        std::copy_n(v0.data() + c * nv, nv, d->qvel);
        for (long k = 0; k < steps; ++k) {
          std::copy_n(u.data() + (c * steps + k) * nu, nu, d->ctrl);
          mj_step(m, d);
        }
        std::copy_n(d->qpos, nq, final_q.data() + c * nq);
      }
    };
    eom::detail::run_on_threads(threads, work);
    eombench::sink = final_q[2];
  };
  auto seconds = [](auto&& f) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  // Agreement, MuJoCo's solver run to its limit (after 1 s of falling and flailing the two part
  // by rounding amplified through the contacts; printed, not timed).
  const double tolerance = m->opt.tolerance;
  const int iterations = m->opt.iterations;
  m->opt.tolerance = 1e-15, m->opt.iterations = 200;
  const eom::RolloutResult check = eom::contact_rollout<K, Model>(rollout_cases, opt);
  theirs();
  double worst = 0;
  for (std::size_t i = 0; i < final_q.size(); ++i) worst = std::max(worst, std::abs(check.q[i] - final_q[i]));
  double lowest = 1e300;
  for (std::size_t c = 0; c < cases; ++c) lowest = std::min(lowest, check.q[c * nq + 2]);
  std::printf("\nensemble: %zu humanoids x %ld steps (%.1f s each, random controls), %u threads; "
              "%zu cases failed; lowest torso at the end %.3f m; final q against MuJoCo (run to its "
              "limit) within %.1e\n",
              cases, steps, steps * m->opt.timestep, threads, check.failed(), lowest, worst);
  double load[1] = {-1};
  getloadavg(load, 1);  // other work on the cores moves the ratio: said beside it
  std::printf("%-62s %11s %11s   %s (load average %.1f)\n", "", "eomgen", "MuJoCo", "ratio", load[0]);
  for (int limit = 0; limit < 2; ++limit) {
    m->opt.tolerance = limit ? 1e-15 : tolerance, m->opt.iterations = limit ? 200 : iterations;
    constexpr int rounds = 15;  // the machine's load moves whole rounds: the median of many
    std::vector<double> a, b, ratio;
    for (int r = 0; r < rounds; ++r) {
      const double x = seconds(ours), y = seconds(theirs);
      a.push_back(x), b.push_back(y), ratio.push_back(x / y);
    }
    auto median = [](std::vector<double> v) {
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    const double total = static_cast<double>(cases) * static_cast<double>(steps);
    std::printf("%-62s %9.0f/s %9.0f/s   time ratio %.2f\n",
                limit ? "ensemble steps/s: contact_rollout / mj_step (run to its limit)"
                      : "ensemble steps/s: contact_rollout / mj_step (MuJoCo's tolerance)",
                total / median(a), total / median(b), median(ratio));
  }
  m->opt.tolerance = tolerance, m->opt.iterations = iterations;
  return check.failed() == 0;
}

int main() {
  // MuJoCo's humanoid let fall with a push for 0.6 s; the stack of boxes after 0.5 s at rest.
  const bool humanoid = scene<bench_humanoid_step::Kernels, eom::mjcf_models::bench_humanoid_step>(
      "MuJoCo humanoid on the floor", EOM_MJCF_HUMANOID, 120, {0.3, 0.5});
  std::printf("\n");
  const bool stack = scene<bench_stack_step::Kernels, eom::mjcf_models::bench_stack_step>(
      "four boxes stacked on the floor", EOM_MJCF_STACK, 250, {0.0, 0.0});
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const bool humanoids = ensemble<bench_humanoid_step::Kernels, eom::mjcf_models::bench_humanoid_step>(
      EOM_MJCF_HUMANOID, 64, 200, cores);
  return humanoid && stack && humanoids ? 0 : 1;
}
