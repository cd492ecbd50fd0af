// Simulation with contact as MuJoCo (contact_simulation.hpp): eom::contact_step on generated
// kernels and the scenes that eomgen-mjcf wrote from the MJCF files.
//  - MuJoCo's humanoid (libmujoco-samples' humanoid.xml) from its standing pose (MuJoCo's qpos0)
//    with a small push, no control: 3 s of 5 ms steps; per step the floor's and all contacts'
//    normal forces, the deepest penetration, the kinetic and gravitational energy.
//  - 32 humanoids with random controls (a push each, inputs uniform in [-1, 1] per step, beyond the
//    control range at times: the clamp acts), eom::contact_rollout on 1 and on 2 threads, which must
//    agree bitwise.
//  - models/mjcf/incline_sweep.xml: six boxes launched down a 0.3 rad slope at 1 m/s, each with its
//    own friction coefficient μ: the closed form (rigid Coulomb friction) has them move at
//    a = g (sin θ − μ cos θ) while they slide, so those with μ < tan θ speed up and the others stop
//    after v0 / |a| having gone v0² / (2 |a|).
#include "contact_simulation.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <vector>

#include <eom/contact/rollout.hpp>
#include <eom/contact/step.hpp>

#include <demo_contact_humanoid.hpp>  // generated from MuJoCo's humanoid.xml
#include <demo_contact_humanoid_model.hpp>
#include <demo_incline_sweep.hpp>  // generated from models/mjcf/incline_sweep.xml
#include <demo_incline_sweep_model.hpp>

namespace {

using Humanoid = demo_contact_humanoid::Kernels;
using HumanoidScene = eom::mjcf_models::demo_contact_humanoid;
using Incline = demo_incline_sweep::Kernels;
using InclineScene = eom::mjcf_models::demo_incline_sweep;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The humanoid's fall; its facts go to `facts`.
bool humanoid_fall(const std::filesystem::path& dir, std::FILE* facts) {
  using K = Humanoid;
  constexpr int nq = K::nq, nv = K::nv;
  const double* p = K::parameter_values.data();
  const double h = HumanoidScene::solver_options.timestep;
  auto stepper = std::make_unique<eom::ContactStepper<K, HumanoidScene>>();
  std::array<double, nq> q = HumanoidScene::qpos0;  // standing: the torso at (0, 0, 1.5), level
  std::array<double, nv> v{};
  v[0] = 0.3, v[4] = 0.5;  // a push forward and a turn about y (as tests/mjcf lets it fall)
  const std::array<double, K::nu> u{};
  std::array<double, nv * nv> M;
  K::mass_matrix(q.data(), p, M.data());
  const double mass = M[0], weight = mass * p[0];  // the free joint's translational block: m·1
  std::FILE* csv = std::fopen((dir / "contact_humanoid.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t,torso_z,contacts,normal_floor,normal_all,penetration,kinetic,potential\n");
  const long steps = std::lround(3.0 / h);
  double t = 0, deepest = 0, peak_force = 0;
  int most = 0;
  const auto start = std::chrono::steady_clock::now();
  for (long k = 0; k < steps; ++k) {
    // The energies at (q, v); the step's rows and forces are those of this state too.
    K::mass_matrix(q.data(), p, M.data());
    double kinetic = 0;
    for (int i = 0; i < nv; ++i)
      for (int j = 0; j < nv; ++j) kinetic += 0.5 * v[i] * M[i + nv * j] * v[j];
    const double potential = K::potential_energy(q.data(), p);
    const double t_state = t, z = q[2];
    const eom::StepStatus status = eom::contact_step<K, HumanoidScene>(*stepper, t, q, v, u.data(), p);
    if (status != eom::StepStatus::ok) {
      std::fclose(csv);
      std::fprintf(stderr, "eom_demo: the humanoid's step failed at t = %g (status %d)\n", t, static_cast<int>(status));
      return false;
    }
    const auto& rows = stepper->rows;
    double floor = 0, all = 0, penetration = 0;
    for (int c = 0; c < rows.ncontacts; ++c) {
      if (!rows.contact_active[c]) continue;
      const double normal = eom::contact_force<HumanoidScene>(rows, stepper->solution, c)[0];
      const eom::CollisionPair& pair = HumanoidScene::collision_pairs[rows.contact_pair[c]];
      all += normal;
      if (HumanoidScene::geoms[pair.geom1].shape == eom::Shape::plane) floor += normal;
      penetration = std::max(penetration, -rows.contacts[c].dist);
    }
    deepest = std::max(deepest, penetration);
    peak_force = std::max(peak_force, all);
    most = std::max(most, rows.ncontacts);
    std::fprintf(csv, "%.4f,%.6f,%d,%.6f,%.6f,%.6e,%.6f,%.6f\n", t_state, z, rows.ncontacts, floor, all,
                 penetration, kinetic, potential);
  }
  const double wall = seconds_since(start);
  std::fclose(csv);
  std::fprintf(facts, "humanoid_mass=%.6f\nhumanoid_weight=%.6f\nhumanoid_steps=%ld\nhumanoid_h=%g\n"
                      "humanoid_deepest_mm=%.4f\nhumanoid_peak_force=%.3f\nhumanoid_most_contacts=%d\n"
                      "humanoid_end_z=%.4f\nhumanoid_wall_ms=%.2f\n",
               mass, weight, steps, h, 1e3 * deepest, peak_force, most, q[2], 1e3 * wall);
  std::printf("contact simulation: the humanoid falls for %g s (%ld steps of %g ms, up to %d contacts, "
              "penetration at most %.2f mm, torso ends at %.3f m): %.1f ms\n",
              steps * h, steps, 1e3 * h, most, 1e3 * deepest, q[2], 1e3 * wall);
  return q[2] < 0.5;  // on the floor
}

// 32 random-control humanoids on 1 and 2 threads: bitwise equal; torso heights every 10 steps.
bool humanoid_batch(const std::filesystem::path& dir, std::FILE* facts) {
  using K = Humanoid;
  constexpr int nv = K::nv, nu = K::nu;
  constexpr std::size_t cases = 32;
  constexpr long steps = 300;
  std::mt19937_64 rng(49);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> q0, v0(cases * nv), u(cases * steps * nu);
  for (std::size_t c = 0; c < cases; ++c) {
    q0.insert(q0.end(), HumanoidScene::qpos0.begin(), HumanoidScene::qpos0.end());
    v0[c * nv + 0] = 0.3 * unit(rng), v0[c * nv + 1] = 0.3 * unit(rng), v0[c * nv + 4] = 0.5 * unit(rng);
  }
  for (double& x : u) x = unit(rng);
  const eom::RolloutCases rollout_cases{q0, v0, u, K::parameter_values};
  std::array<eom::RolloutResult, 2> runs;
  std::array<double, 2> wall{};
  for (unsigned threads : {1u, 2u}) {
    const auto start = std::chrono::steady_clock::now();
    runs[threads - 1] = eom::contact_rollout<K, HumanoidScene>(rollout_cases,
                                                               {.steps = steps, .threads = threads, .record = true});
    wall[threads - 1] = seconds_since(start);
    if (!runs[threads - 1].ok()) {
      std::fprintf(stderr, "eom_demo: %s\n", runs[threads - 1].error.c_str());
      return false;
    }
  }
  const eom::RolloutResult& r = runs[0];
  const bool identical =
      r.states.size() == runs[1].states.size() &&
      std::memcmp(r.states.data(), runs[1].states.data(), r.states.size() * sizeof(double)) == 0;
  std::FILE* csv = std::fopen((dir / "contact_batch.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t");
  for (std::size_t c = 0; c < cases; ++c) std::fprintf(csv, ",z%zu", c);
  std::fprintf(csv, "\n");
  const double h = HumanoidScene::solver_options.timestep;
  for (long k = 0; k <= steps; k += 5) {
    std::fprintf(csv, "%.4f", k * h);
    for (std::size_t c = 0; c < cases; ++c) std::fprintf(csv, ",%.5f", r.state(c, k)[2]);
    std::fprintf(csv, "\n");
  }
  std::fclose(csv);
  const double total = static_cast<double>(cases * steps);
  std::fprintf(facts, "batch_cases=%zu\nbatch_steps=%ld\nbatch_failed=%zu\nbatch_identical=%d\n"
                      "batch_rate_1=%.0f\nbatch_rate_2=%.0f\n",
               cases, steps, r.failed(), identical ? 1 : 0, total / wall[0], total / wall[1]);
  std::printf("contact simulation: %zu random-control humanoids x %ld steps, %zu failed; 1 and 2 threads "
              "%s; %.0f and %.0f steps/s\n",
              cases, steps, r.failed(), identical ? "bitwise equal" : "DIFFER", total / wall[0], total / wall[1]);
  return identical && r.failed() == 0;
}

// The boxes on the incline against the closed form.
bool incline(const std::filesystem::path& dir, std::FILE* facts) {
  using K = Incline;
  using Scene = InclineScene;
  constexpr int nq = K::nq, nv = K::nv, boxes = nv / 6;
  const double* p = K::parameter_values.data();
  const double h = Scene::solver_options.timestep, g = p[0], v0 = 1.0;
  // The slope: the plane's normal (its z axis) tilted by θ about y; down the slope along x.
  const eom::Geom& slope = Scene::geoms[0];
  const double theta = std::acos(slope.rotation[8]);
  const std::array<double, 3> down{std::cos(theta), 0, -std::sin(theta)};
  std::array<double, boxes> mu{}, a{};  // each box's friction (its pair's) and closed-form rate
  for (const eom::CollisionPair& pair : Scene::collision_pairs)
    mu[Scene::geoms[pair.geom2].link] = pair.friction[0];  // a box's link: its free joint's index
  for (int b = 0; b < boxes; ++b) a[b] = g * (std::sin(theta) - mu[b] * std::cos(theta));
  // Each box where the XML puts it (resting on the slope, turned by θ about y), launched down it.
  std::array<double, nq> q{};
  std::array<double, nv> v{};
  for (int b = 0; b < boxes; ++b) {
    q[7 * b + 0] = 0.05 * std::sin(theta), q[7 * b + 1] = -1.25 + 0.5 * b, q[7 * b + 2] = 0.05 * std::cos(theta);
    q[7 * b + 3] = std::cos(theta / 2), q[7 * b + 5] = std::sin(theta / 2);
    for (int i = 0; i < 3; ++i) v[6 * b + i] = v0 * down[i];
  }
  auto stepper = std::make_unique<eom::ContactStepper<K, Scene>>();
  std::FILE* csv = std::fopen((dir / "contact_incline.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t");
  for (int b = 0; b < boxes; ++b) std::fprintf(csv, ",v%d,s%d", b, b);
  std::fprintf(csv, "\n");
  const auto along = [&](const double* x) { return x[0] * down[0] + x[1] * down[1] + x[2] * down[2]; };
  const std::array<double, nq> q_start = q;
  const auto travelled = [&](int b) {
    std::array<double, 3> d;
    for (int i = 0; i < 3; ++i) d[i] = q[7 * b + i] - q_start[7 * b + i];
    return along(d.data());
  };
  const double t_end = 2.0, t1 = 0.05;  // rates measured from t1 (after the contacts settle)
  std::array<double, boxes> v_t1{}, v_t2{}, t2{}, stop{};
  for (int b = 0; b < boxes; ++b) t2[b] = a[b] < 0 ? std::min(t_end, 0.8 * v0 / -a[b]) : t_end, stop[b] = -1;
  const long steps = std::lround(t_end / h);
  double t = 0;
  const auto start = std::chrono::steady_clock::now();
  for (long k = 0; k <= steps; ++k) {
    for (int b = 0; b < boxes; ++b) {
      const double vb = along(v.data() + 6 * b);
      if (std::abs(t - t1) < h / 2) v_t1[b] = vb;
      if (std::abs(t - t2[b]) < h / 2) v_t2[b] = vb;
      if (stop[b] < 0 && vb < 1e-3 * v0) stop[b] = t;
    }
    if (k % 10 == 0) {
      std::fprintf(csv, "%.4f", t);
      for (int b = 0; b < boxes; ++b) std::fprintf(csv, ",%.6f,%.6f", along(v.data() + 6 * b), travelled(b));
      std::fprintf(csv, "\n");
    }
    if (k == steps) break;
    const eom::StepStatus status = eom::contact_step<K, Scene>(*stepper, t, q, v, nullptr, p);
    if (status != eom::StepStatus::ok) {
      std::fclose(csv);
      std::fprintf(stderr, "eom_demo: the incline's step failed at t = %g (status %d)\n", t, static_cast<int>(status));
      return false;
    }
  }
  const double wall = seconds_since(start);
  std::fclose(csv);
  std::FILE* table = std::fopen((dir / "contact_incline.txt").c_str(), "w");
  if (!table) return false;
  std::fprintf(table, "mu,a_closed,a_measured,stop_closed,stop_measured,distance_closed,distance_measured\n");
  double worst_rate = 0;
  bool as_closed_form = true;
  for (int b = 0; b < boxes; ++b) {
    const double measured = (v_t2[b] - v_t1[b]) / (t2[b] - t1);
    worst_rate = std::max(worst_rate, std::abs(measured - a[b]) / std::abs(a[b]));
    const bool stops = mu[b] > std::tan(theta);
    const double stop_closed = stops ? v0 / -a[b] : -1, distance_closed = stops ? v0 * v0 / (2 * -a[b]) : -1;
    as_closed_form = as_closed_form && (stops == (stop[b] >= 0));
    std::fprintf(table, "%g,%.5f,%.5f,%.4f,%.4f,%.4f,%.4f\n", mu[b], a[b], measured, stop_closed, stop[b],
                 distance_closed, stops ? travelled(b) : -1.0);
  }
  std::fclose(table);
  std::fprintf(facts, "incline_theta=%.6f\nincline_tan=%.6f\nincline_g=%g\nincline_v0=%g\nincline_steps=%ld\n"
                      "incline_worst_rate=%.3e\nincline_wall_ms=%.2f\n",
               theta, std::tan(theta), g, v0, steps, worst_rate, 1e3 * wall);
  std::printf("contact simulation: %d boxes launched down a %.3f rad incline (tan %.4f) for %g s: rates within "
              "%.1e of g (sin - mu cos), %s as the closed form says: %.1f ms\n",
              boxes, theta, std::tan(theta), t_end, worst_rate, as_closed_form ? "sliding and stopping" : "NOT",
              1e3 * wall);
  return as_closed_form && worst_rate < 0.05;
}

}  // namespace

bool simulate_contact_simulation(const std::filesystem::path& dir, std::FILE* summary) {
  std::FILE* facts = std::fopen((dir / "contact_simulation.txt").c_str(), "w");
  if (!facts) return false;
  bool ok = humanoid_fall(dir, facts);
  ok = humanoid_batch(dir, facts) && ok;
  ok = incline(dir, facts) && ok;
  std::fclose(facts);
  std::fprintf(summary, "contact simulation,eom::contact_step (MuJoCo's semi-implicit Euler),humanoid fall, "
                        "random-control batch, incline friction sweep,%s\n",
               ok ? "as expected" : "FAILED");
  return ok;
}
