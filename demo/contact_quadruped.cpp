// Solo12 standing and trotting on MuJoCo's soft contact (contact_quadruped.hpp): eom::contact_step
// on the demo's solo12 kernels and the scene add_eom_model(... GROUND) wrote from
// models/robots/solo12_feet.urdf (a 0.016 m sphere at each foot, the ground plane z = 0, MuJoCo's
// default contact parameters: friction 1, pyramidal cones, Newton), stepped at 1 ms with the
// contacts' solref time constant 5 ms (MuJoCo's default 20 ms is made for 2 ms steps and heavier
// bodies).
//
// The controller runs at the step rate and is deliberately simple, open loop in its gait:
//   u = Kp (q_ref − q) − Kd q̇ + G_joints(q) − Σ_stance J_fᵀ (0, 0, m g / n_stance)
// a joint PD toward a reference posture plus gravity compensation through the kernels (G = −M a₀,
// a₀ the forward dynamics at q̇ = 0, u = 0) less the joint torques that carry the stance feet's
// share of the weight (frame_jacobian of each foot). The reference: legs bent (hip 0.8 rad, knee
// −1.6 rad; hind mirrored), the foot straight below its hip. From t_stand a trot: the diagonal
// pairs (FL, HR) and (FR, HL) swing in turn, each for half a period; a swinging leg's foot is
// lifted by bending its knee (the hip taking half, so the foot stays on the hip–foot line) along
// a half sine, and moved from behind the hip to ahead of it by turning the hip–foot line through
// ±stride, while the stance pair's turns the other way and so carries the body forward.
#include "contact_quadruped.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>

#include <eom/contact/step.hpp>

#include <solo12.hpp>        // generated (demo/CMakeLists.txt)
#include <solo12_model.hpp>  // the scene: the feet's spheres and the ground

namespace {

using K = solo12::Kernels;
// The scene as written, stepped at 1 ms, its contacts stiffer (MuJoCo's other defaults kept).
struct Scene : eom::urdf_models::solo12 {
  static constexpr eom::SolverOptions solver_options = [] {
    eom::SolverOptions o;
    o.timestep = 0.001;
    return o;
  }();
  static constexpr auto collision_pairs = [] {
    auto pairs = eom::urdf_models::solo12::collision_pairs;
    for (auto& pair : pairs) pair.softness.solref = {0.005, 1.0};  // stiffer than MuJoCo's 0.02: 5 steps
    return pairs;
  }();
};
constexpr int nq = K::nq, nv = K::nv, legs = 4;
static_assert(Scene::geoms.size() == 1 + legs, "the ground and one sphere per foot");

constexpr double kp = 6, kd = 0.2, hip = 0.8, knee = 1.6;                 // N·m/rad, N·m·s/rad, rad
constexpr double t_stand = 1.0, t_end = 4.0, half_period = 0.15;          // s
constexpr double stride = 0.12, lift = 0.35, ramp = 0.3, drop = 0.005;    // rad, rad, s, m

// Leg l's phase at time t: whether it swings and its progress s ∈ [0, 1) through the half period.
struct Phase {
  bool swing;
  double s;
};
Phase phase(int l, double t) {
  if (t < t_stand) return {false, 0};
  const double cycles = (t - t_stand) / half_period;
  const long half = static_cast<long>(std::floor(cycles));
  const bool pair_a = l == 0 || l == 3;  // FL, HR swing in the even halves
  return {(half % 2 == 0) == pair_a, cycles - static_cast<double>(half)};
}

// The joints' reference at time t (q[7..19)).
std::array<double, nq> reference(double t, double base_z) {
  std::array<double, nq> q{};
  q[2] = base_z, q[3] = 1;
  const double amplitude = t < t_stand ? 0 : stride * std::min(1.0, (t - t_stand) / ramp);
  for (int l = 0; l < legs; ++l) {
    const double side = l < 2 ? 1.0 : -1.0;  // front legs bend one way, hind the other
    const Phase ph = phase(l, t);
    const double c = std::cos(std::numbers::pi * ph.s);
    const double bend = ph.swing ? lift * std::sin(std::numbers::pi * ph.s) : 0;
    const double line = ph.swing ? amplitude * c : -amplitude * c;  // hip–foot line's angle about y
    q[7 + 3 * l + 1] = side * (hip + bend / 2) + line;
    q[7 + 3 * l + 2] = -side * (knee + bend);
  }
  return q;
}

// The controller's torques at (t, q, v).
std::array<double, K::nu> control(double t, const std::array<double, nq>& q, const std::array<double, nv>& v,
                                  double weight) {
  const double* p = K::parameter_values.data();
  const std::array<double, nq> ref = reference(t, q[2]);
  std::array<double, nv * nv> M;
  std::array<double, nv> a0, G{}, zero{};
  const std::array<double, K::nu> none{};
  K::mass_matrix(q.data(), p, M.data());
  K::forward_dynamics(t, q.data(), zero.data(), none.data(), p, a0.data());
  for (int i = 0; i < nv; ++i)
    for (int j = 0; j < nv; ++j) G[i] -= M[i + nv * j] * a0[j];  // M a₀ + G = 0 at rest
  int stance = 0;
  for (int l = 0; l < legs; ++l) stance += !phase(l, t).swing;
  std::array<double, K::nu> u;
  for (int j = 0; j < K::nu; ++j) u[j] = kp * (ref[7 + j] - q[7 + j]) - kd * v[6 + j] + G[6 + j];
  for (int l = 0; l < legs; ++l) {
    if (phase(l, t).swing) continue;
    std::array<double, 6 * nv> J;
    K::frame_jacobian(l, q.data(), p, J.data());  // frames 0..3: the feet (CONTACTS stance)
    for (int j = 0; j < K::nu; ++j) u[j] -= J[2 + 6 * (6 + j)] * weight / stance;
  }
  return u;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

bool simulate_contact_quadruped(const std::filesystem::path& dir, std::FILE* summary) {
  const double* p = K::parameter_values.data();
  const double h = Scene::solver_options.timestep, radius = Scene::geoms[1].size[0];
  // Standing posture, its feet `drop` above the ground.
  std::array<double, nq> q = reference(0, 0);
  std::array<double, nv * nv> M;
  K::mass_matrix(q.data(), p, M.data());
  const double mass = M[0], weight = mass * p[0];  // the free joint's translational block: m·1
  {
    double x[3], R[9];
    K::frame_placement(0, q.data(), p, x, R);
    q[2] = radius + drop - x[2];
  }
  std::array<double, nv> v{};
  auto stepper = std::make_unique<eom::ContactStepper<K, Scene>>();
  std::FILE* csv = std::fopen((dir / "contact_quadruped.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t,x,y,z,fz_FL,fz_FR,fz_HL,fz_HR,penetration,kinetic,potential\n");
  const long steps = std::lround(t_end / h);
  double t = 0, deepest = 0, deepest_standing = 0, peak = 0, lowest = q[2], worst_tilt = 0;
  double stand_z = 0, stand_force = 0, x_start = 0, y_start = 0;
  long stand_samples = 0;
  const auto start = std::chrono::steady_clock::now();
  for (long k = 0; k < steps; ++k) {
    const auto u = control(t, q, v, weight);
    const double kinetic = K::kinetic_energy(q.data(), v.data(), p), potential = K::potential_energy(q.data(), p);
    const std::array<double, nq> q_state = q;
    const double t_state = t;
    const eom::StepStatus status = eom::contact_step<K, Scene>(*stepper, t, q, v, u.data(), p);
    if (status != eom::StepStatus::ok) {
      std::fclose(csv);
      std::fprintf(stderr, "eom_demo: Solo12's contact step failed at t = %g (status %d)\n", t,
                   static_cast<int>(status));
      return false;
    }
    // The rows and forces are those at (t_state, q_state).
    const auto& rows = stepper->rows;
    std::array<double, legs> fz{};
    double penetration = 0;
    for (int c = 0; c < rows.ncontacts; ++c) {
      if (!rows.contact_active[c]) continue;
      const eom::CollisionPair& pair = Scene::collision_pairs[rows.contact_pair[c]];
      fz[pair.geom2 - 1] += eom::contact_force<Scene>(rows, stepper->solution, c)[0];  // geom 0: the ground
      penetration = std::max(penetration, -rows.contacts[c].dist);
    }
    const double total = fz[0] + fz[1] + fz[2] + fz[3];
    deepest = std::max(deepest, penetration);
    peak = std::max(peak, total);
    const double qx = q_state[4], qy = q_state[5];  // the base's tilt: acos of its z axis' z
    const double tilt = std::acos(std::clamp(1 - 2 * (qx * qx + qy * qy), -1.0, 1.0));
    if (t_state >= 0.5 && t_state < t_stand) {  // standing, settled
      stand_z += q_state[2], stand_force += total, ++stand_samples;
      deepest_standing = std::max(deepest_standing, penetration);
    }
    if (std::abs(t_state - t_stand) < h / 2) x_start = q_state[0], y_start = q_state[1];
    if (t_state >= t_stand) lowest = std::min(lowest, q_state[2]), worst_tilt = std::max(worst_tilt, tilt);
    if (k % 5 == 0)
      std::fprintf(csv, "%.4f,%.6f,%.6f,%.6f,%.5f,%.5f,%.5f,%.5f,%.6e,%.6f,%.6f\n", t_state, q_state[0], q_state[1],
                   q_state[2], fz[0], fz[1], fz[2], fz[3], penetration, kinetic, potential);
  }
  const double wall = seconds_since(start);
  std::fclose(csv);
  stand_z /= static_cast<double>(stand_samples), stand_force /= static_cast<double>(stand_samples);
  const double forward = q[0] - x_start, sideways = q[1] - y_start, trot_time = t_end - t_stand;
  const double yaw = 2 * std::atan2(q[6], q[3]);  // about z, for a base close to level
  const bool upright = lowest > 0.5 * stand_z && worst_tilt < 0.5;
  std::FILE* facts = std::fopen((dir / "contact_quadruped.txt").c_str(), "w");
  if (!facts) return false;
  const double solref = Scene::collision_pairs[0].softness.solref[0];
  std::fprintf(facts, "mass=%.6f\nweight=%.6f\nh=%g\nsolref=%g\nradius=%g\ndrop=%g\nkp=%g\nkd=%g\n", mass, weight, h,
               solref, radius, drop, kp, kd);
  std::fprintf(facts, "t_stand=%g\nt_end=%g\nhalf_period=%g\nstride=%g\nlift=%g\n", t_stand, t_end, half_period,
               stride, lift);
  std::fprintf(facts,
               "stand_z=%.5f\nstand_force=%.4f\nstand_deepest_mm=%.4f\ndeepest_mm=%.4f\npeak_force=%.3f\n"
               "forward=%.4f\nspeed=%.4f\nsideways=%.4f\nyaw=%.4f\nlowest=%.5f\nworst_tilt=%.4f\nupright=%d\n"
               "steps=%ld\nwall_ms=%.2f\n",
               stand_z, stand_force, 1e3 * deepest_standing, 1e3 * deepest, peak, forward, forward / trot_time,
               sideways, yaw, lowest, worst_tilt, upright ? 1 : 0, steps, 1e3 * wall);
  std::fclose(facts);
  std::printf("contact simulation: Solo12 on its foot spheres stands at %.4f m (normal forces %.3f N, weight %.3f N, "
              "penetration %.2f mm), then trots %.3f m forward in %g s (%.3f m/s; %s, tilt at most %.3f rad): "
              "%ld steps in %.1f ms\n",
              stand_z, stand_force, weight, 1e3 * deepest_standing, forward, trot_time, forward / trot_time,
              upright ? "upright" : "FELL", worst_tilt, steps, 1e3 * wall);
  std::fprintf(summary, "solo12 on soft contact,eom::contact_step 1 ms + joint PD and gravity compensation,"
                        "stands then trots %.3f m in %g s,%s\n",
               forward, trot_time, upright ? "upright" : "FELL");
  return upright;
}
