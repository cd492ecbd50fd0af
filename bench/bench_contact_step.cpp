// A step with contact, eomgen against MuJoCo 2.2 on the same scene, side by side in one binary
// (eombench::compare: alternating rounds, the median of the per-round ratios): MuJoCo's humanoid
// on the floor (it fell there from its standing pose, as tests/mjcf lets it fall), a stack of
// four boxes at rest (models/mjcf/stack.xml), and Solo12 standing on its four foot spheres under a
// joint PD (models/robots/solo12_feet.urdf with GROUND; MuJoCo's side the same scene in MJCF); one
// step from that state, eom::contact_step (the generated mass_matrix and forward_dynamics, the
// rows, the solver run to rounding) against mj_step (its Newton solver at the model's tolerance,
// and run to its limit as tests/mjcf runs it). Both from the same state and inputs every call (no
// warm start between calls for either: MuJoCo's qacc_warmstart is reset to the state's). And the
// step's Jacobians: eom::contact_step_derivatives against mjd_transitionFD from the same state.
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
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <bench_humanoid_step.hpp>
#include <bench_humanoid_step_model.hpp>
#include <bench_solo12_step.hpp>
#include <bench_solo12_step_model.hpp>
#include <bench_stack_step.hpp>
#include <bench_stack_step_model.hpp>
#include <eom/contact/rollout.hpp>
#include <eom/contact/step.hpp>
#include <eom/contact/step_derivatives.hpp>
#include <eom/multibody/tree.hpp>

#include "mujoco_peer.hpp"  // tests/support: MuJoCo's model and data owned
#include "paired_timing.hpp"

// MuJoCo's model of `file`; null, the reason printed, where MuJoCo cannot load it.
eom::test::MujocoModel load(const char* file) {
  char error[1000] = "";
  eom::test::MujocoModel model(mj_loadXML(file, nullptr, error, sizeof error));
  if (!model) std::fprintf(stderr, "bench_contact_step: %s: %s\n", file, error);
  return model;
}

// The step's Jacobians at (q0, v0) under u: eom::contact_step_derivatives (the step, the solver
// differentiated at its solution) against mjd_transitionFD (finite differences of mj_step, forward
// as MuJoCo's users call it and centered, eps 1e-6, at the model's tolerance); their agreement
// first, then their times.
template <class K, class Model>
void time_derivatives(mjModel* m, mjData* d, const std::array<double, K::nq>& q0,
                      const std::array<double, K::nv>& v0, const std::array<double, K::nu>& u) {
  constexpr int nv = K::nv, nu = K::nu, n = 2 * nv;
  const double* p = K::parameter_values.data();
  auto stepper = std::make_unique<eom::ContactStepper<K, Model>>();
  auto jacobians = std::make_unique<eom::StepDerivatives<K, Model>>();
  std::array<double, K::nq> q;
  std::array<double, nv> v;
  std::vector<double> A(n * n), B(n * std::max(nu, 1));
  eom::StepStatus status = eom::StepStatus::ok;
  auto ours = [&](int) {
    q = q0, v = v0;
    stepper->warm = false;
    double t = 0;
    status = eom::contact_step_derivatives<K, Model>(*stepper, *jacobians, t, q, v, u.data(), p);
    eombench::sink = jacobians->A[0];
  };
  auto theirs = [&](bool centered) {
    return [&, centered](int) {
      std::copy(q0.begin(), q0.end(), d->qpos);
      std::copy(v0.begin(), v0.end(), d->qvel);
      std::copy(u.begin(), u.begin() + nu, d->ctrl);
      std::fill(d->qacc_warmstart, d->qacc_warmstart + nv, 0.0);
      d->time = 0;
      mjd_transitionFD(m, d, 1e-6, centered, A.data(), nu > 0 ? B.data() : nullptr, nullptr, nullptr);
      eombench::sink = A[0];
    };
  };
  ours(0);
  theirs(true)(0);
  double diff = 0, scale = 1;  // ours column-major, MuJoCo's row-major
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      diff = std::max(diff, std::abs(jacobians->A[i + n * j] - A[n * i + j])),
      scale = std::max(scale, std::abs(A[n * i + j]));
  std::printf("step derivatives (status %d): A agrees with mjd_transitionFD's (centered) to %.1e "
              "of max(1, |A|) = %.3g\n",
              static_cast<int>(status), diff / scale, scale);
  eombench::compare("step derivatives: contact_step_derivatives / mjd_transitionFD forward", ours,
                    theirs(false), 10, 41);
  eombench::compare("step derivatives: contact_step_derivatives / mjd_transitionFD centered", ours,
                    theirs(true), 10, 41);
}

// One step from (q0, v0) under inputs u, side by side: K, Model the generated kernels and header,
// (m, d) MuJoCo's same scene; its one-step agreement printed, then timed at MuJoCo's tolerance and
// run to its limit.
template <class K, class Model>
void time_step(const char* title, mjModel* m, mjData* d, const std::array<double, K::nq>& q0,
               const std::array<double, K::nv>& v0, const std::array<double, K::nu>& u) {
  constexpr int nq = K::nq, nv = K::nv, nu = K::nu;
  const double* p = K::parameter_values.data();
  auto stepper = std::make_unique<eom::ContactStepper<K, Model>>();
  std::array<double, nq> q;
  std::array<double, nv> v;
  auto ours = [&](int) {
    q = q0, v = v0;
    stepper->warm = false;  // as MuJoCo's warm start below: not the last call's answer
    double t = 0;
    eombench::sink = static_cast<double>(eom::contact_step<K, Model>(*stepper, t, q, v, u.data(), p));
  };
  auto theirs = [&](int) {
    std::copy(q0.begin(), q0.end(), d->qpos);
    std::copy(v0.begin(), v0.end(), d->qvel);
    std::copy(u.begin(), u.begin() + nu, d->ctrl);
    std::fill(d->qacc_warmstart, d->qacc_warmstart + nv, 0.0);
    d->time = 0;
    mj_step(m, d);
    eombench::sink = d->qvel[0];
  };
  const double tolerance = m->opt.tolerance;
  const int iterations = m->opt.iterations;
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
  m->opt.tolerance = tolerance, m->opt.iterations = iterations;
  if constexpr (Model::solver_options.integrator == 0) time_derivatives<K, Model>(m, d, q0, v0, u);
}

// One MJCF scene side by side: `file` the MJCF K and Model were generated from, `settle` MuJoCo
// steps from its initial state (with `push` on qvel) before the timed step, no inputs.
template <class K, class Model>
bool scene(const char* title, const char* file, int settle, const std::array<double, 2>& push) {
  eom::test::MujocoModel model = load(file);
  if (!model) return false;
  mjModel* m = model.get();
  eom::test::MujocoData data(mj_makeData(m));
  mjData* d = data.get();
  constexpr int nq = K::nq, nv = K::nv;
  // The state: let settle (fall, or rest) for a while (MuJoCo), then one step from there.
  std::copy(m->qpos0, m->qpos0 + nq, d->qpos);
  d->qvel[0] = push[0], d->qvel[4] = push[1];
  for (int k = 0; k < settle; ++k) mj_step(m, d);
  std::array<double, nq> q0;
  std::array<double, nv> v0;
  std::copy(d->qpos, d->qpos + nq, q0.begin());
  std::copy(d->qvel, d->qvel + nv, v0.begin());
  time_step<K, Model>(title, m, d, q0, v0, std::array<double, K::nu>{});
  return true;
}

// models/robots/solo12_feet.urdf in MJCF, as tests/urdf/test_urdf_scene.cpp writes its URDF scene
// for MuJoCo: body for link (the feet's fixed joints as bodies without a joint), the inertials as
// written, the joints' <limit>s as ranges, a motor (gear 1, no ctrlrange) on each joint for u; the
// ground a plane at z = 0; MuJoCo's defaults for every contact parameter and option, as the scene
// states them. The feet touch the ground only (contype/conaffinity), as the scene's four
// ground:foot pairs: no foot:foot pairs for either side.
std::string solo12_mjcf() {
  struct Leg {
    const char* name;
    double x, y, s;  // the hip's place; s: +1 on the left, -1 on the right (mirrored numbers)
  };
  const Leg legs[4] = {{"FL", 0.19, 0.1046, 1}, {"FR", 0.19, -0.1046, -1},
                       {"HL", -0.19, 0.1046, 1}, {"HR", -0.19, -0.1046, -1}};
  std::string text = R"(<mujoco model="solo12_feet">
  <compiler angle="radian" inertiafromgeom="false"/>
  <worldbody>
    <geom name="ground" type="plane" size="0 0 1" contype="0" conaffinity="1"/>
    <body name="base_link">
      <freejoint name="root"/>
      <inertial pos="0 0 0" mass="1.63315091" fullinertia="0.00578574 0.01938108 0.02476124 0 0 0"/>
)";
  char buf[4000];
  for (const Leg& l : legs) {
    const double s = l.s;
    std::snprintf(buf, sizeof buf, R"(      <body name="%s_SHOULDER" pos="%.17g %.17g 0">
        <joint name="%s_HAA" type="hinge" axis="1 0 0" limited="true" range="-10 10"/>
        <inertial pos="0 0 0" mass="0.150" fullinertia="0.00000001 0.00000001 0.00000001 0 0 0"/>
        <body name="%s_UPPER_LEG">
          <joint name="%s_HFE" type="hinge" axis="0 1 0" limited="true" range="-10 10"/>
          <inertial pos="%.17g %.17g -0.07870700" mass="0.14853845" fullinertia="0.00041107 0.00041193 0.00003024 0 0 %.17g"/>
          <body name="%s_LOWER_LEG" pos="0 %.17g -0.16">
            <joint name="%s_KFE" type="hinge" axis="0 1 0" limited="true" range="-10 10"/>
            <inertial pos="0 0.00787644 -0.08928215" mass="0.03070001" fullinertia="0.00012024 0.00012029 0.00000216 0 0 %.17g"/>
            <body name="%s_FOOT" pos="0 %.17g -0.16">
              <inertial pos="0 0 0.00035767" mass="0.00693606" fullinertia="0.00000057 0.00000084 0.00000053 0 0 0"/>
              <geom name="%s_FOOT_sphere" type="sphere" size="0.016" contype="1" conaffinity="0"/>
            </body>
          </body>
        </body>
      </body>
)",
                  l.name, l.x, l.y, l.name, l.name, l.name, s * 0.00001377, s * 0.01935853, s * 0.00004671,
                  l.name, s * 0.03745, l.name, s * 0.00000305, l.name, s * 0.008, l.name);
    text += buf;
  }
  text += "    </body>\n  </worldbody>\n  <actuator>\n";
  for (const Leg& l : legs)
    for (const char* j : {"HAA", "HFE", "KFE"}) {
      std::snprintf(buf, sizeof buf, "    <motor joint=\"%s_%s\" gear=\"1\"/>\n", l.name, j);
      text += buf;
    }
  return text + "  </actuator>\n</mujoco>\n";
}

// Solo12 standing on its four foot spheres (tests/urdf/test_urdf_solo12_stands.cpp's scenario):
// legs bent (hip 0.8 rad, knee -1.6 rad, hind mirrored), dropped from 5 mm with the joints held by
// a PD (20 N·m/rad, 0.3 N·m·s/rad), `settle` steps (MuJoCo), then one step from there with the PD's
// inputs at that state, the same u on both sides.
template <class K, class Model> bool quadruped(const char* title, int settle) {
  char error[1000] = "";
  eom::test::MujocoModel model = eom::test::load_text("solo12_feet.xml", solo12_mjcf(), error, sizeof error);
  if (!model) {
    std::fprintf(stderr, "bench_contact_step: Solo12's MJCF: %s\n", error);
    return false;
  }
  mjModel* m = model.get();
  constexpr int nq = K::nq, nv = K::nv, nu = K::nu;
  std::vector<std::array<int, 2>> pairs;  // the scene's candidate pairs are those MuJoCo tests
  for (const auto& x : Model::collision_pairs) pairs.push_back({x.geom1, x.geom2});
  if (m->nq != nq || m->nv != nv || m->nu != nu || pairs != eom::test::tested_pairs(m)) {
    std::fprintf(stderr, "bench_contact_step: Solo12's MJCF does not match its URDF scene\n");
    return false;
  }
  eom::test::MujocoData data(mj_makeData(m));
  mjData* d = data.get();
  const double radius = Model::geoms[1].size[0], drop = 0.005;
  std::array<double, nq> q{}, q_ref;
  q[3] = 1;
  for (int leg = 0; leg < 4; ++leg) {
    const double side = leg < 2 ? 1.0 : -1.0;
    q[7 + 3 * leg + 1] = 0.8 * side, q[7 + 3 * leg + 2] = -1.6 * side;
  }
  const auto X = eom::tree_placements<double>(eom::tree_of<Model, double>(K::parameter_values),
                                              std::span<const double>(q));
  q[2] = radius + drop - X[Model::geoms[1].link].translation[2];
  q_ref = q;
  std::copy(q.begin(), q.end(), d->qpos);
  auto pd = [&](std::array<double, nu>& u) {
    for (int j = 0; j < nu; ++j) u[j] = 20 * (q_ref[7 + j] - d->qpos[7 + j]) - 0.3 * d->qvel[6 + j];
  };
  std::array<double, nu> u;
  for (int k = 0; k < settle; ++k) {
    pd(u);
    std::copy(u.begin(), u.end(), d->ctrl);
    mj_step(m, d);
  }
  std::array<double, nq> q0;
  std::array<double, nv> v0;
  std::copy(d->qpos, d->qpos + nq, q0.begin());
  std::copy(d->qvel, d->qvel + nv, v0.begin());
  pd(u);
  time_step<K, Model>(title, m, d, q0, v0, u);
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

// Arguments: the parts to run (humanoid, stack, solo12, ensemble); all without any.
int main(int argc, char** argv) {
  auto run = [&](const char* part) {
    bool any = argc < 2;
    for (int i = 1; i < argc; ++i) any |= std::string(argv[i]) == part;
    return any;
  };
  // MuJoCo's humanoid let fall with a push for 0.6 s; the stack of boxes after 0.5 s at rest;
  // Solo12 after 0.5 s standing under its PD.
  const bool humanoid = !run("humanoid") || scene<bench_humanoid_step::Kernels, eom::mjcf_models::bench_humanoid_step>(
      "MuJoCo humanoid on the floor", EOM_MJCF_HUMANOID, 120, {0.3, 0.5});
  std::printf("\n");
  const bool stack = !run("stack") || scene<bench_stack_step::Kernels, eom::mjcf_models::bench_stack_step>(
      "four boxes stacked on the floor", EOM_MJCF_STACK, 250, {0.0, 0.0});
  std::printf("\n");
  const bool solo12 = !run("solo12") || quadruped<bench_solo12_step::Kernels, eom::urdf_models::bench_solo12_step>(
      "Solo12 standing on its four feet", 250);
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const bool humanoids = !run("ensemble") || ensemble<bench_humanoid_step::Kernels, eom::mjcf_models::bench_humanoid_step>(
      EOM_MJCF_HUMANOID, 64, 200, cores);
  return humanoid && stack && solo12 && humanoids ? 0 : 1;
}
