// The contact scene of the demo (contacts.hpp): Solo12 (models/robots/solo12.urdf, FLOATING_BASE,
// CONTACTS stance on its four feet) dropped from 3 cm with its joints held by a PD loop at 1 kHz;
// the touchdown event switches to the stance set through the impulse, and the robot then stands
// while the joints sway its body sideways. eom::OnContacts holds the feet (kd = 40/s, kp = 400/s²).
#include "contacts.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>

#include <eom/integration/contacts.hpp>
#include <eom/integration/integrate.hpp>

#include <solo12.hpp>  // generated

namespace {

using K = solo12::Kernels;
using C = eom::OnContacts<K>;
constexpr int nq = K::nq, nv = K::nv, joints = K::nu, stance = 0;
static_assert(K::ncontact_sets == 1 && K::contact_rows[stance] == 12 && joints == 12);
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

}  // namespace

bool simulate_contacts(const std::filesystem::path& dir, std::FILE* summary) {
  const auto q_ref = posture(0), q0 = posture(drop);
  eom::Touchdowns<C, 1> touch(K::parameter_values, {.kd = 40, .kp = 400}, -1,
                              {{{.set = stance, .frame = 0, .height = 0}}}, 0, q0.data());
  const double* p = touch.parameters.data();
  std::array<eom::EventRecord<nq, nv>, 2> storage;
  eom::EventLog<nq, nv> log(storage);
  eom::IntegrationOptions opt;
  opt.method = eom::Method::rk4;
  opt.step = period;
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
  double mass = 0;  // the links' masses are parameters "<link>_mass"
  for (int i = 0; i < K::np; ++i)
    if (K::parameter_names[i].ends_with("_mass")) mass += K::parameter_values[i];
  const double g = K::parameter_values[0];
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
