// Work against precision with contact (issue 49): eom::contact_step with MuJoCo's Euler and RK4
// beside mj_step with the same, on two scenes, over a sweep of time steps to a fixed end time;
// each run's error against a fine-step reference (eomgen's RK4 at a step 32 times below the
// finest), its steps, stage evaluations and wall time. Not a test: no assertion, opt-in.
//
// Usage: eom_work_precision_contact [--quick]
// Prints Markdown tables (docs/benchmarks/work_precision_contact.md). --quick: one timing
// repeat instead of five.
//
// The scenes: models/mjcf/rk4.xml (two free bodies falling onto a floor, a motor-driven pendulum
// held on its limit, a puck on damped slides; its motor's control held at 0.5) and
// models/mjcf/heavy_on_light.xml (a 20 kg box dropped onto a 0.2 kg one on the floor, every
// contact with a 4 ms solref time constant). The step and the integrator are MuJoCo's options: on
// MuJoCo's side set in mjModel.opt, on eomgen's in a model type that overrides the header's
// solver_options (both sides then apply the same refsafe rule, timeconst ≥ 2 h, at each step).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "mujoco_peer.hpp"

#include <eom/contact/step.hpp>

#include <wp_heavy_on_light.hpp>
#include <wp_heavy_on_light_model.hpp>
#include <wp_rk4.hpp>
#include <wp_rk4_model.hpp>

namespace {

constexpr double end_time = 0.4;  // a multiple of every step below
constexpr std::array<double, 6> steps{0.008, 0.004, 0.002, 0.001, 0.0005, 0.00025};
constexpr double reference_step = steps.back() / 32;
constexpr int euler = 0, rk4 = 1;

// Base's scene with MuJoCo's options timestep = h and integrator, the rest as the header says.
template <class Base, int integrator, double h> struct Stepped : Base {
  static constexpr eom::SolverOptions solver_options = [] {
    eom::SolverOptions o = Base::solver_options;
    o.timestep = h;
    o.integrator = integrator;
    return o;
  }();
};

struct Start {
  std::vector<double> q, v, u;
};

struct Run {
  std::vector<double> q, v;
  double seconds = 0;  // the fastest of the repeats
  bool ok = true;
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// eomgen from start to end_time with the step and integrator of Stepped<Base, integrator, h>.
template <class K, class Base, int integrator, double h> Run run_eomgen(const Start& s, int repeats) {
  using Model = Stepped<Base, integrator, h>;
  auto stepper = std::make_unique<eom::ContactStepper<K, Model>>();
  const int n = static_cast<int>(std::lround(end_time / h));
  Run r;
  r.seconds = 1e300;
  for (int rep = 0; rep < repeats; ++rep) {
    std::array<double, K::nq> q;
    std::array<double, K::nv> v;
    std::copy(s.q.begin(), s.q.end(), q.begin());
    std::copy(s.v.begin(), s.v.end(), v.begin());
    stepper->warm = false;
    double t = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < n && r.ok; ++k)
      r.ok = eom::contact_step<K, Model>(*stepper, t, q, v, s.u.data(),
                                         K::parameter_values.data()) == eom::StepStatus::ok;
    r.seconds = std::min(r.seconds, seconds_since(t0));
    r.q.assign(q.begin(), q.end());
    r.v.assign(v.begin(), v.end());
  }
  return r;
}

// MuJoCo the same way, its solver at the model's options (tolerance 1e-8, 100 iterations).
Run run_mujoco(const char* file, const Start& s, int integrator, double h, int repeats) {
  eom::test::MujocoModel model(mj_loadXML(file, nullptr, nullptr, 0));
  if (!model) {
    std::fprintf(stderr, "eom_work_precision_contact: MuJoCo cannot load %s\n", file);
    std::exit(1);
  }
  mjModel* m = model.get();
  m->opt.timestep = h;
  m->opt.integrator = integrator == rk4 ? mjINT_RK4 : mjINT_EULER;
  eom::test::MujocoData data(mj_makeData(m));
  mjData* d = data.get();
  const int n = static_cast<int>(std::lround(end_time / h));
  Run r;
  r.seconds = 1e300;
  for (int rep = 0; rep < repeats; ++rep) {
    mj_resetData(m, d);
    std::copy(s.q.begin(), s.q.end(), d->qpos);
    std::copy(s.v.begin(), s.v.end(), d->qvel);
    std::copy(s.u.begin(), s.u.end(), d->ctrl);
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < n; ++k) mj_step(m, d);
    r.seconds = std::min(r.seconds, seconds_since(t0));
    r.q.assign(d->qpos, d->qpos + m->nq);
    r.v.assign(d->qvel, d->qvel + m->nv);
  }
  for (double x : r.q) r.ok = r.ok && std::isfinite(x);
  return r;
}

double max_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double e = 0;
  for (std::size_t i = 0; i < a.size(); ++i) e = std::max(e, std::abs(a[i] - b[i]));
  return std::isfinite(e) ? e : INFINITY;
}

std::string error_text(const Run& r, const Run& ref) {
  if (!r.ok) return "failed";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.1e / %.1e", max_difference(r.q, ref.q),
                max_difference(r.v, ref.v));
  return buffer;
}

// One scene's table: per step, per integrator, eomgen's and MuJoCo's error (q / v, max norm, to
// the reference) and time, and the two sides' distance from each other.
template <class K, class Base, std::size_t... i>
void study(const char* title, const char* file, const Start& start, int repeats,
           std::index_sequence<i...>) {
  const Run reference = run_eomgen<K, Base, rk4, reference_step>(start, 1);
  const Run check = run_eomgen<K, Base, rk4, 2 * reference_step>(start, 1);
  const Run mujoco_reference = run_mujoco(file, start, rk4, reference_step, 1);
  std::printf("\n### %s\n\n", title);
  std::printf("Reference: eomgen's RK4 at h = %g ms (%d steps); at twice that step it moves by "
              "%.1e / %.1e (q / v); MuJoCo's RK4 at the reference's step is %.1e / %.1e from "
              "it.\n\n",
              1e3 * reference_step, static_cast<int>(std::lround(end_time / reference_step)),
              max_difference(check.q, reference.q), max_difference(check.v, reference.v),
              max_difference(mujoco_reference.q, reference.q),
              max_difference(mujoco_reference.v, reference.v));
  std::printf("| h (ms) | method | steps | stage evaluations | eomgen error q / v | MuJoCo error q "
              "/ v | eomgen − MuJoCo q / v | eomgen time (ms) | MuJoCo time (ms) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  auto row = [&](double h, int integrator, const Run& ours) {
    const Run theirs = run_mujoco(file, start, integrator, h, repeats);
    const int n = static_cast<int>(std::lround(end_time / h));
    std::printf("| %g | %s | %d | %d | %s | %s | %s | %.2f | %.2f |\n", 1e3 * h,
                integrator == rk4 ? "RK4" : "Euler", n, integrator == rk4 ? 4 * n : n,
                error_text(ours, reference).c_str(), error_text(theirs, reference).c_str(),
                ours.ok && theirs.ok ? error_text(ours, theirs).c_str() : "–",
                1e3 * ours.seconds, 1e3 * theirs.seconds);
    std::fflush(stdout);
  };
  ((row(steps[i], euler, run_eomgen<K, Base, euler, steps[i]>(start, repeats)),
    row(steps[i], rk4, run_eomgen<K, Base, rk4, steps[i]>(start, repeats))),
   ...);
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  const int repeats = quick ? 1 : 5;
  std::printf("End time %g s; errors are max-norm differences of q (m, rad, quaternion "
              "components) and v at the end time; times the fastest of %d runs.\n",
              end_time, repeats);
  {
    using K = wp_rk4::Kernels;
    Start s{{}, {}, {0.5}};
    s.q.assign(K::nq, 0.0);
    s.v.assign(K::nv, 0.0);
    // the bodies where the file puts them (mj_resetData), then set moving
    eom::test::MujocoModel m(mj_loadXML(EOM_MJCF_RK4, nullptr, nullptr, 0));
    if (!m) return 1;
    std::copy(m->qpos0, m->qpos0 + K::nq, s.q.begin());
    s.q[14] = 0.5;  // the pendulum off its limit
    const std::array<double, K::nv> v0{0.3, -0.2, 0.5, 2.0, -1.0, 0.5, -0.4, 0.1, 0.0,
                                       1.0, 3.0,  0.0, 1.5,  0.8, -0.5, 0.0};
    std::copy(v0.begin(), v0.end(), s.v.begin());
    study<K, eom::mjcf_models::wp_rk4>("models/mjcf/rk4.xml: free bodies, a limit, damped slides",
                                       EOM_MJCF_RK4, s, repeats,
                                       std::make_index_sequence<steps.size()>());
  }
  {
    using K = wp_heavy_on_light::Kernels;
    Start s;
    eom::test::MujocoModel m(mj_loadXML(EOM_MJCF_HEAVY_ON_LIGHT, nullptr, nullptr, 0));
    if (!m) return 1;
    s.q.assign(m->qpos0, m->qpos0 + K::nq);
    s.v.assign(K::nv, 0.0);
    s.v[8] = -0.5;  // the heavy box moving down
    study<K, eom::mjcf_models::wp_heavy_on_light>(
        "models/mjcf/heavy_on_light.xml: 20 kg on 0.2 kg, solref 4 ms", EOM_MJCF_HEAVY_ON_LIGHT, s,
        repeats, std::make_index_sequence<steps.size()>());
  }
}
