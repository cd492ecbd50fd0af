// The contact scenes of the demo (contacts.hpp): Solo12 (models/robots/solo12.urdf, FLOATING_BASE,
// CONTACTS stance on its four feet, trot_a and trot_b on its diagonal pairs) dropped from 3 cm
// with its joints held by a PD loop at 1 kHz; the touchdown event switches to the stance set
// through the impulse, and the robot then stands while the joints sway its body sideways. Then,
// from standing, a trot (simulate_trot, below). eom::OnContacts holds the feet (kd = 40/s,
// kp = 400/s²).
#include "contacts.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>

#include <eom/integration/contacts.hpp>
#include <eom/integration/integrate.hpp>

#include <solo12.hpp>  // generated

namespace {

using K = solo12::Kernels;
using C = eom::OnContacts<K>;
constexpr int nq = K::nq, nv = K::nv, joints = K::nu, stance = 0;
constexpr int trot_a = 1, trot_b = 2;  // demo/CMakeLists.txt: stance, trot_a (FL, HR), trot_b (FR, HL)
static_assert(K::ncontact_sets == 3 && K::contact_rows[stance] == 12 && K::contact_rows[trot_a] == 6 &&
              K::contact_rows[trot_b] == 6 && joints == 12);
constexpr double period = 1e-3, kp_joint = 5, kd_joint = 0.1, drop = 0.03, t_end = 5, sway_start = 1;

// Legs bent (front HFE 0.8, KFE −1.6; hind mirrored), level base at the height that puts the
// feet at z = height.
std::array<double, nq> posture(double height) {
  std::array<double, nq> q{};
  q[3] = 1;
  for (int leg = 0; leg < 4; ++leg) {
    const double front = leg < 2 ? 1.0 : -1.0;
    q[7 + 3 * leg + 1] = 0.8 * front, q[7 + 3 * leg + 2] = -1.6 * front;
  }
  double x[3], R[9];
  K::frame_placement(0, q.data(), K::parameter_values.data(), x, R);
  q[2] = height - x[2];
  return q;
}

double sway(double t) { return t < sway_start ? 0 : 0.15 * std::sin(std::numbers::pi * (t - sway_start)); }

eom::IntegrationOptions rk4_at_period() {  // one rk4 step per period of the loop
  eom::IntegrationOptions opt;
  opt.method = eom::Method::rk4;
  opt.step = period;
  return opt;
}

double robot_mass() {  // the links' masses are parameters "<link>_mass"
  double mass = 0;
  for (int i = 0; i < K::np; ++i)
    if (K::parameter_names[i].ends_with("_mass")) mass += K::parameter_values[i];
  return mass;
}

}  // namespace

bool simulate_contacts(const std::filesystem::path& dir, std::FILE* summary) {
  const auto q_ref = posture(0), q0 = posture(drop);
  eom::Touchdowns<C, 1> touch(K::parameter_values, {.kd = 40, .kp = 400}, -1,
                              {{{.set = stance, .frame = 0, .height = 0}}}, 0, q0.data());
  const double* p = touch.parameters.data();
  std::array<eom::EventRecord<nq, nv>, 2> storage;
  eom::EventLog<nq, nv> log(storage);
  const auto opt = rk4_at_period();
  std::FILE* csv = std::fopen((dir / "contacts.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t,base_y,base_z,fz_FL,fz_FR,fz_HL,fz_HR,drift\n");
  eom::StateFor<C> x{};
  std::copy(q0.begin(), q0.end(), x.begin());
  double worst_drift = 0, touchdown = -1, impulse_z = 0;
  const auto start = std::chrono::steady_clock::now();
  const long samples = std::lround(t_end / period);
  for (long k = 0; k < samples; ++k) {
    const double t = k * period;
    std::array<double, joints> u;
    for (int j = 0; j < joints; ++j)
      u[j] = kp_joint * (q_ref[7 + j] + (j % 3 == 0 ? sway(t) : 0.0) - x[7 + j]) - kd_joint * x[nq + 6 + j];
    std::array<double, 12> lambda{};
    double drift = 0;
    if (touch.set() == stance) {
      std::array<double, nv> vdot;
      std::array<double, C::max_rows> e;
      C::dynamics(t, x.data(), x.data() + nq, u.data(), p, vdot.data(), lambda.data());
      C::placement_errors(stance, x.data(), p, e.data());
      for (double ei : e) drift = std::max(drift, std::abs(ei));
      worst_drift = std::max(worst_drift, drift);
    }
    if (k % 5 == 0)
      std::fprintf(csv, "%.4f,%.9f,%.9f,%.6f,%.6f,%.6f,%.6f,%.3e\n", t, x[1], x[2], lambda[2], lambda[5],
                   lambda[8], lambda[11], drift);
    const auto r = eom::integrate<C>(t, t + period, x, u.data(), p, opt, touch.events(), log);
    if (r.status != eom::Status::ok) {
      std::fclose(csv);
      std::fprintf(stderr, "eom_demo: Solo12 contact scene stopped at t = %g: %s\n", r.t, eom::to_string(r.status));
      return false;
    }
    if (touchdown < 0 && touch.last() == 0) {
      touchdown = log.records()[0].t;
      for (int f = 0; f < 4; ++f) impulse_z += touch.impulse()[3 * f + 2];
    }
    x = r.x;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fclose(csv);
  const double mass = robot_mass(), g = K::parameter_values[0];
  std::FILE* facts = std::fopen((dir / "contacts.txt").c_str(), "w");
  if (!facts) return false;
  std::fprintf(facts, "touchdown=%.12f\nfree_fall=%.12f\nimpulse_z=%.6f\nmass=%.6f\nweight=%.6f\nworst_drift=%.3e\n"
               "wall_ms=%.1f\nseconds=%g\n",
               touchdown, std::sqrt(2 * drop / g), impulse_z, mass, mass * g, worst_drift, 1e3 * seconds, t_end);
  std::fclose(facts);
  std::fprintf(summary, "solo12 contacts,rk4 1 kHz PD loop,%g s,touchdown %.6f s (free fall %.6f s),feet drift <= %.1e m\n",
               t_end, touchdown, std::sqrt(2 * drop / g), worst_drift);
  std::printf("solo12 contacts: dropped %.0f cm, touchdown at %.6f s (free fall %.6f s), impulse %.4f N s up; "
              "standing and swaying %g s, feet within %.1e m of where they touched; %.0f ms\n",
              drop * 100, touchdown, std::sqrt(2 * drop / g), impulse_z, t_end - touchdown, worst_drift, 1e3 * seconds);
  return touchdown > 0;
}

// The trot (simulate_trot): Solo12 standing on its four feet, then stepping with its diagonal
// pairs in turn. A pair is unloaded on four feet, lifted (eom::Touchdowns::lift: the liftoff where
// its normal force reaches 0), swung along an arc to a point ahead of its hips while the other
// pair holds (trot_a or trot_b), and put down: the first of its feet to reach the floor fires the
// touchdown, whose impulse (stance set, restitution 0) stops all four feet and holds the lot.
//
// The controller, at 1 kHz, deliberately simple: a joint PD (30 N·m/rad; 1 N·m·s/rad on a leg that
// carries, 0.3 on a light swinging leg, which a 1 kHz loop could not damp more) toward targets
// from inverse kinematics: a carrying leg's put the base on its reference (level, at the standing
// height, moving forward at up to trot_speed) with its foot at its anchor; a swinging leg's put
// its foot, from the base where it is, on an arc to where Raibert's rule lands it. Plus the legs'
// own gravity torques (−M v̇ at v = 0, u = 0 from forward_dynamics) and −Jᵀ of the weight shared
// by the carrying feet. While a pair is unloaded on four feet, u is corrected by the least-norm Δu
// that puts the four normal forces, from OnContacts' dynamics (affine in u), on targets: the
// pair's on a ramp to −1 N, the others' the rest of the weight, so that both feet leave together;
// that correction fades over fade_time after the liftoff, and the targets' rate is 0 at a phase
// change, so that u (and with it λ) does not jump.
//
// Only the events of the phase are watched: the lifting pair's liftoff while it is unloaded, the
// swinging pair's touchdowns from the top of its arc (a held foot sits at its touchdown height,
// where its event function would hover about 0). The landing pair's second foot is held where it
// is when the first touches, a little above the floor (there are no three-foot sets).
namespace {

struct Pair {
  std::array<int, 2> feet;  // frame indices, also the legs' indices (FL, FR, HL, HR)
  int set;                  // the set that holds this pair's feet
};
constexpr std::array<Pair, 2> pairs{{{{1, 2}, trot_b}, {{0, 3}, trot_a}}};  // B (FR, HL) swings first, then A
constexpr double trot_kp = 30, trot_kd = 1, swing_kd = 0.3, stand_time = 0.3, unload_time = 0.05, swing_time = 0.2,
                 step_height = 0.04, landing_speed = 0.1, trot_speed = 0.2, trot_accel = 0.25, release_force = -1,
                 settle_time = 0.5, capture_gain = 0.5, fade_time = 0.02;
constexpr int swings = 12;  // six cycles

// q's leg f moved so that its foot reaches `target` (world) with the base at `base` (position and
// quaternion): Newton on the leg's three joints (the 3×3 block of the foot's translational
// Jacobian).
void leg_ik(int f, const double* base, const double* target, std::array<double, nq>& q) {
  std::copy_n(base, 7, q.begin());
  const double* p = K::parameter_values.data();
  for (int iteration = 0; iteration < 4; ++iteration) {
    double x[3], R[9];
    std::array<double, 6 * nv> J;
    K::frame_placement(f, q.data(), p, x, R);
    K::frame_jacobian(f, q.data(), p, J.data());
    std::array<double, 9> A;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) A[r + 3 * c] = J[r + 6 * (6 + 3 * f + c)];
    std::array<int, 3> piv;
    if (!eom::linalg::lu_factor<double, 3>(A, piv)) return;
    double d[3]{target[0] - x[0], target[1] - x[1], target[2] - x[2]};
    eom::linalg::lu_solve<double, 3>(A, piv, d);
    for (int c = 0; c < 3; ++c) q[7 + 3 * f + c] += d[c];
  }
}

std::array<double, 3> foot_position(int f, const double* q) {
  std::array<double, 3> x;
  double R[9];
  K::frame_placement(f, q, K::parameter_values.data(), x.data(), R);
  return x;
}

// The base's tilt from upright [rad]: the angle between its z axis and the world's.
double tilt(const double* q) {
  const double x = q[4], y = q[5];  // q[3..6] = (w, x, y, z): R's zz = 1 − 2(x² + y²)
  return std::acos(std::clamp(1 - 2 * (x * x + y * y), -1.0, 1.0));
}

}  // namespace

bool simulate_trot(const std::filesystem::path& dir, std::FILE* summary) {
  using Gait = eom::Touchdowns<C, 4, 2>;
  // Touchdowns 2P, 2P + 1: pair P's feet reaching z = 0 close the stance set; liftoff P: pair P's
  // first foot's normal force reaching 0 on four feet leaves the other pair holding.
  const auto q0 = posture(0);
  Gait gait(K::parameter_values, {.kd = 40, .kp = 400}, stance,
            {{{.set = stance, .frame = pairs[0].feet[0]}, {.set = stance, .frame = pairs[0].feet[1]},
              {.set = stance, .frame = pairs[1].feet[0]}, {.set = stance, .frame = pairs[1].feet[1]}}},
            0, q0.data(),
            {{{.set = stance, .frame = pairs[0].feet[0], .to = pairs[1].set},
              {.set = stance, .frame = pairs[1].feet[0], .to = pairs[0].set}}});
  const double* p = gait.parameters.data();
  std::array<eom::EventRecord<nq, nv>, 4> storage;
  eom::EventLog<nq, nv> log(storage);
  const auto opt = rk4_at_period();
  std::FILE* csv = std::fopen((dir / "trot.csv").c_str(), "w");
  std::FILE* events = csv ? std::fopen((dir / "trot_events.csv").c_str(), "w") : nullptr;
  if (!events) {
    if (csv) std::fclose(csv);
    return false;
  }
  std::fprintf(csv, "t,base_x,base_y,base_z,tilt,fz_FL,fz_FR,fz_HL,fz_HR,z_FL,z_FR,z_HL,z_HR,set,drift,ref_x\n");
  // kind: 0 liftoff, 1 touchdown; impulse: |Λ| of the landing pair's feet (N s); partner: at a
  // touchdown the height of the pair's other foot, at a liftoff its normal force.
  std::fprintf(events, "t,kind,pair,impulse,impulse_z,partner\n");

  const double weight = robot_mass() * K::parameter_values[0];
  std::array<std::array<double, 3>, 4> nominal;  // the feet from the base in the standing posture
  for (int f = 0; f < 4; ++f) {
    nominal[f] = foot_position(f, q0.data());
    for (int i = 0; i < 3; ++i) nominal[f][i] -= q0[i];
  }
  enum class Phase { standing, unloading, swinging, settling } phase = Phase::standing;
  int P = 0, liftoffs = 0, touchdowns = 0, wrong = 0;
  double phase_start = 0, f0 = 0, vx = 0;
  std::array<double, 7> base{q0[0], q0[1], q0[2], 1, 0, 0, 0};  // the reference: level, facing x
  std::array<std::array<double, 3>, 2> lift_from{}, land_at{};
  std::array<double, nq> q_ref = q0, q_prev = q0;
  std::array<double, joints> shaping{};  // the unloading's last correction of u
  int epoch = 0, rate_epoch = 0;  // phase changes; the targets' rate restarts at each
  constexpr double inf = std::numeric_limits<double>::infinity();
  double worst_drift = 0, worst_impulse = 0, least_impulse = inf, worst_partner = 0, clearance = 0,
         worst_tilt = 0, z_low = inf, z_high = -inf, release_worst = -inf, trot_start = -1,
         trot_end = -1, x_start = 0, x_end = 0, least_force = inf, least_force_t = 0;
  // A liftoff of pair P at time `at` (state qs, vs; the pair's second foot's normal force then):
  // its record, the swing's start and where it lands (Raibert's rule, set here: under the hips
  // where the base reference will be at the touchdown, half a stance's travel ahead, and further
  // along the base's velocity error by half the capture point's lead √(h/g), which steers it back).
  const auto begin_swing = [&](double at, const double* qs, const double* vs, double partner_force) {
    std::fprintf(events, "%.6f,0,%d,0,0,%.6f\n", at, P, partner_force);
    if (!std::isnan(partner_force)) release_worst = std::max(release_worst, partner_force);
    ++liftoffs;
    phase = Phase::swinging, phase_start = at, ++epoch;
    const double lead = capture_gain * std::sqrt(q0[2] / K::parameter_values[0]);
    for (int i = 0; i < 2; ++i) {
      const int f = pairs[P].feet[i];
      lift_from[i] = foot_position(f, qs);
      for (int c = 0; c < 2; ++c) {
        const double v_ref = c == 0 ? vx : 0.0;
        land_at[i][c] =
            base[c] + v_ref * (1.5 * swing_time + 0.5 * unload_time) + nominal[f][c] + lead * (vs[c] - v_ref);
      }
    }
  };
  eom::StateFor<C> x{};
  std::copy(q0.begin(), q0.end(), x.begin());
  const auto start = std::chrono::steady_clock::now();
  double t = 0;
  for (long k = 0; phase != Phase::settling || t < phase_start + settle_time; ++k) {
    t = k * period;
    if (t > 10) break;  // never reached: a stuck gait
    const double* q = x.data();
    const double* v = x.data() + nq;
    // The base reference and the feet's targets.
    const bool moving = phase == Phase::unloading || phase == Phase::swinging;
    const double speed = moving && touchdowns < swings - 1 ? trot_speed : 0.0;  // (the last swing stops)
    vx = std::clamp(speed, vx - trot_accel * period, vx + trot_accel * period);
    base[0] += vx * period;
    const int set = gait.set();
    std::array<std::array<double, 3>, 4> target;
    for (int f = 0; f < 4; ++f) std::copy_n(C::anchor(p, f), 3, target[f].begin());
    if (phase == Phase::swinging) {
      const double s = (t - phase_start) / swing_time, e = std::min(s, 1.0), smooth = e * e * (3 - 2 * e);
      for (int i = 0; i < 2; ++i) {
        auto& y = target[pairs[P].feet[i]];
        for (int c = 0; c < 2; ++c) y[c] = lift_from[i][c] + (land_at[i][c] - lift_from[i][c]) * smooth;
        // Up and down again to the floor (from where the foot left, which may be a little above
        // it), then on down at landing_speed until the touchdown.
        y[2] = s < 1 ? lift_from[i][2] * (1 - smooth) + step_height * 0.5 * (1 - std::cos(2 * std::numbers::pi * s))
                     : -landing_speed * (t - phase_start - swing_time);
      }
    }
    // Held feet: the joints that would put the base on its reference; swinging feet: the joints
    // that put the foot on its arc from the base where it is.
    for (int f = 0; f < 4; ++f) {
      const bool swinging = phase == Phase::swinging && (f == pairs[P].feet[0] || f == pairs[P].feet[1]);
      leg_ik(f, swinging ? q : base.data(), target[f].data(), q_ref);
    }
    // The PD, the legs' gravity, the weight on the carrying feet. The targets' rate is their
    // difference over the period, but at a phase change, where they jump (a swinging foot's
    // target to its anchor, a leg's inverse kinematics from the actual base), it is 0.
    if (epoch != rate_epoch) q_prev = q_ref, rate_epoch = epoch;
    std::array<double, nv> vdot, zero_v{};
    std::array<double, joints> u{};
    K::forward_dynamics(t, q, zero_v.data(), u.data(), p, vdot.data());
    std::array<double, nv * nv> M;
    K::mass_matrix(q, p, M.data());
    std::array<bool, 4> carrying{true, true, true, true};  // (while unloading, the correction below moves it)
    if (phase == Phase::swinging)
      for (int f : pairs[P].feet) carrying[f] = false;
    const double share = weight / std::count(carrying.begin(), carrying.end(), true);
    for (int j = 0; j < joints; ++j) {
      double gravity = 0;  // −(M v̇)ⱼ at v = 0, u = 0
      for (int i = 0; i < nv; ++i) gravity -= M[6 + j + nv * i] * vdot[i];
      const double kd = carrying[j / 3] ? trot_kd : swing_kd;  // a light swinging leg: less damping at 1 kHz
      u[j] = trot_kp * (q_ref[7 + j] - q[7 + j]) + kd * ((q_ref[7 + j] - q_prev[7 + j]) / period - v[6 + j]) +
             gravity;
    }
    q_prev = q_ref;
    for (int f = 0; f < 4; ++f) {
      if (!carrying[f]) continue;
      std::array<double, 6 * nv> J;
      K::frame_jacobian(f, q, p, J.data());
      for (int j = 0; j < joints; ++j) u[j] -= J[2 + 6 * (6 + j)] * share;
    }
    if (phase == Phase::swinging)  // the last correction fades, so that u (and λ) does not jump
      for (int j = 0; j < joints; ++j) u[j] += shaping[j] * std::exp(-(t - phase_start) / fade_time);
    std::array<double, C::max_rows> lambda{};
    if (set >= 0) C::dynamics(t, q, v, u.data(), p, vdot.data(), lambda.data());
    if (phase == Phase::unloading) {  // shape the four normal forces: λ is affine in u
      // Targets: the lifting pair's on a ramp from f0 to release_force, the other pair's the rest
      // of the weight (shared evenly), so that the base is not pushed up or down.
      if (f0 == 0)
        f0 = std::max({lambda[Gait::row_of(stance, pairs[P].feet[0]) + 2],
                       lambda[Gait::row_of(stance, pairs[P].feet[1]) + 2], 1.0});  // both from the larger
      const double ramp = std::min((t - phase_start) / unload_time, 1.0), want = f0 + (release_force - f0) * ramp;
      std::array<double, 4> r;  // the misfit, foot by foot
      for (int f = 0; f < 4; ++f) {
        const bool lifting = f == pairs[P].feet[0] || f == pairs[P].feet[1];
        r[f] = (lifting ? want : 0.5 * weight - want) - lambda[Gait::row_of(stance, f) + 2];
      }
      std::array<double, 4 * joints> G;  // ∂λ_z/∂u, 4 × joints column-major
      for (int j = 0; j < joints; ++j) {
        auto w = u;
        w[j] += 1;
        std::array<double, C::max_rows> l;
        C::dynamics(t, q, v, w.data(), p, vdot.data(), l.data());
        for (int f = 0; f < 4; ++f) G[f + 4 * j] = l[Gait::row_of(stance, f) + 2] - lambda[Gait::row_of(stance, f) + 2];
      }
      std::array<double, 16> A{};  // G Gᵀ; Δu = Gᵀ (G Gᵀ)⁻¹ r, the least-norm correction
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b)
          for (int j = 0; j < joints; ++j) A[a + 4 * b] += G[a + 4 * j] * G[b + 4 * j];
      std::array<int, 4> piv;
      if (eom::linalg::lu_factor<double, 4>(A, piv)) {
        eom::linalg::lu_solve<double, 4>(A, piv, r.data());
        for (int j = 0; j < joints; ++j) {
          shaping[j] = 0;
          for (int f = 0; f < 4; ++f) shaping[j] += G[f + 4 * j] * r[f];
          u[j] += shaping[j];
        }
      }
      C::dynamics(t, q, v, u.data(), p, vdot.data(), lambda.data());
      if (const int lifted = gait.lift(t, q, v, u.data()); lifted >= 0) {
        wrong += lifted != P;
        begin_swing(t, q, v, lambda[Gait::row_of(stance, pairs[P].feet[1]) + 2]);
        C::dynamics(t, q, v, u.data(), p, vdot.data(), lambda.data());  // on the pair that holds now
      }
    } else if (phase == Phase::standing && t >= stand_time) {
      phase = Phase::unloading, phase_start = t, f0 = 0, trot_start = t, x_start = q[0];
    }
    // The record: each foot's normal force in the set that holds, the held feet's drift.
    const int held = gait.set();
    std::array<double, 4> fz{};
    double drift = 0;
    if (held >= 0) {
      for (int f = 0; f < 4; ++f)
        if (const int row = Gait::row_of(held, f); row >= 0) {
          fz[f] = lambda[row + 2];
          if (fz[f] < least_force) least_force = fz[f], least_force_t = t;
        }
      std::array<double, C::max_rows> e{};
      C::placement_errors(held, q, p, e.data());
      for (int i = 0; i < K::contact_rows[held]; ++i) drift = std::max(drift, std::abs(e[i]));
      worst_drift = std::max(worst_drift, drift);
    }
    std::array<double, 4> z;
    for (int f = 0; f < 4; ++f) z[f] = foot_position(f, q)[2];
    if (phase == Phase::swinging)
      for (int f : pairs[P].feet) clearance = std::max(clearance, z[f]);
    if (trot_start >= 0 && phase != Phase::settling) {
      worst_tilt = std::max(worst_tilt, tilt(q));
      z_low = std::min(z_low, q[2]), z_high = std::max(z_high, q[2]);
    }
    if (k % 5 == 0)
      std::fprintf(csv, "%.4f,%.6f,%.6f,%.6f,%.6f,%.4f,%.4f,%.4f,%.4f,%.6f,%.6f,%.6f,%.6f,%d,%.3e,%.6f\n", t, q[0],
                   q[1], q[2], tilt(q), fz[0], fz[1], fz[2], fz[3], z[0], z[1], z[2], z[3], held, drift, base[0]);
    // One period; the events that can fire in this phase.
    std::span<const eom::Event> watch;
    if (phase == Phase::unloading) watch = gait.events().subspan(4 + P, 1);
    if (phase == Phase::swinging && t >= phase_start + 0.5 * swing_time) watch = gait.events().subspan(2 * P, 2);
    log.clear();
    const auto r = eom::integrate<C>(t, t + period, x, u.data(), p, opt, watch, log);
    if (r.status != eom::Status::ok) {
      std::fclose(csv), std::fclose(events);
      std::fprintf(stderr, "eom_demo: Solo12 trot stopped at t = %g: %s\n", r.t, eom::to_string(r.status));
      return false;
    }
    if (phase == Phase::unloading && gait.set() != stance) {  // the liftoff event, inside the period
      const auto& e = log.records()[0];
      begin_swing(e.t, e.x_after.data(), e.x_after.data() + nq, std::numeric_limits<double>::quiet_NaN());
    } else if (phase == Phase::swinging && gait.set() == stance) {  // the touchdown
      const auto& e = log.records()[0];
      const int first = gait.last() - 2 * P, partner = pairs[P].feet[1 - first];
      double impulse = 0, impulse_z = 0;
      for (int f : pairs[P].feet) {
        const double* l = gait.impulse().data() + Gait::row_of(stance, f);
        impulse += std::hypot(l[0], l[1], l[2]), impulse_z += l[2];
      }
      const double gap = foot_position(partner, e.x.data())[2];
      std::fprintf(events, "%.6f,1,%d,%.6f,%.6f,%.6e\n", e.t, P, impulse, impulse_z, gap);
      worst_impulse = std::max(worst_impulse, impulse), least_impulse = std::min(least_impulse, impulse);
      worst_partner = std::max(worst_partner, gap);
      ++touchdowns;
      P = 1 - P;
      if (touchdowns == swings) {
        phase = Phase::settling, trot_end = e.t, x_end = e.x[0];
      } else {
        phase = Phase::unloading, f0 = 0;
      }
      phase_start = e.t, ++epoch;
    }
    x = r.x;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fclose(csv), std::fclose(events);
  std::FILE* facts = std::fopen((dir / "trot.txt").c_str(), "w");
  if (!facts) return false;
  const double distance = x_end - x_start, trot_time = trot_end - trot_start;
  std::fprintf(facts,
               "touchdowns=%d\nliftoffs=%d\nwrong_liftoffs=%d\ntrot_start=%.6f\ntrot_end=%.6f\ndistance=%.6f\n"
               "speed=%.6f\nz_low=%.6f\nz_high=%.6f\nz0=%.6f\nworst_tilt=%.6f\nworst_drift=%.3e\n"
               "impulse_max=%.6f\nimpulse_min=%.6f\npartner_gap=%.6e\nrelease_force=%.6f\nclearance=%.6f\n"
               "weight=%.6f\nwall_ms=%.1f\nseconds=%g\nstep_height=%g\nswing_time=%g\nunload_time=%g\n"
               "trot_speed=%g\nkp=%g\nkd=%g\nswing_kd=%g\nleast_force=%.6f\nleast_force_t=%.6f\ncapture_gain=%g\n"
               "fade_time=%g\n",
               touchdowns, liftoffs, wrong, trot_start, trot_end, distance, distance / trot_time, z_low, z_high, q0[2],
               worst_tilt, worst_drift, worst_impulse, least_impulse, worst_partner, release_worst, clearance, weight,
               1e3 * seconds, t, step_height, swing_time, unload_time, trot_speed, trot_kp, trot_kd, swing_kd, least_force,
               least_force_t, capture_gain, fade_time);
  std::fclose(facts);
  std::fprintf(summary, "solo12 trot,rk4 1 kHz PD loop,%.2f s,%d touchdowns %.3f m forward,feet drift <= %.1e m\n", t,
               touchdowns, distance, worst_drift);
  std::printf("solo12 trot: %d liftoffs, %d touchdowns in %.2f s, %.3f m forward (%.3f m/s), base height %.4f..%.4f m, "
              "tilt <= %.3f rad; held feet within %.1e m; %.0f ms\n",
              liftoffs, touchdowns, trot_time, distance, distance / trot_time, z_low, z_high, worst_tilt, worst_drift,
              1e3 * seconds);
  return touchdowns == swings && liftoffs == swings && wrong == 0;
}
