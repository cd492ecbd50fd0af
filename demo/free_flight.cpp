// The free-flying scenes of the demo (free_flight.hpp): each integrated with DOP853 on its
// generated kernels (state x = (q, v), the quaternion kept on the unit sphere by the integrator),
// the invariants computed independently from the bodies' motions (eom/multibody/momentum.hpp).
#include "free_flight.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>
#include <span>
#include <vector>

#include <eom/integration/integrate.hpp>
#include <eom/model/free_joint.hpp>
#include <eom/multibody/momentum.hpp>

#include <demo_free_panda.hpp>  // generated: models/robots/panda.urdf with FLOATING_BASE, g = 0
#include <demo_free_panda_model.hpp>
#include <models/spacecraft_free.hpp>
#include <solo12.hpp>  // generated: models/robots/solo12.urdf with FLOATING_BASE
#include <solo12_model.hpp>
#include <spacecraft_free.hpp>  // generated

namespace {

constexpr double deg = 180.0 / std::numbers::pi;
using Vec = std::array<double, 3>;

double norm(const Vec& a) { return std::hypot(a[0], a[1], a[2]); }

// The total mass, mass centre, linear momentum and angular momentum (about the world origin) of
// a model's bodies at (q, v).
struct Totals {
  double mass = 0;
  Vec centre{}, P{}, H{};
};
template <class Model, int n> Totals totals(const double* q, const double* v, std::span<const double, n> p) {
  constexpr int nq = eom::ModelInfo<Model>::nq, nv = eom::ModelInfo<Model>::nv;
  const auto b = eom::body_motions_of<Model>(std::span<const double>(q, nq), std::span<const double>(v, nv),
                                             std::span<const double>(p.data(), p.size()));
  Totals t;
  for (const auto& body : b) {
    t.mass += body.mass;
    for (int i = 0; i < 3; ++i) {
      t.centre[i] += body.mass * body.position[i];
      t.P[i] += body.mass * body.velocity[i];
    }
  }
  for (double& x : t.centre) x /= t.mass;
  t.H = eom::angular_momentum(b);
  return t;
}

// The rotation vector (axis · angle) of a unit quaternion, in degrees.
Vec rotation_vector_deg(const double* quaternion) {
  const double w = quaternion[0], s = std::hypot(quaternion[1], quaternion[2], quaternion[3]);
  const double angle = 2 * std::atan2(s, w);
  const double k = s > 0 ? angle / s * deg : 2 * deg;
  return {k * quaternion[1], k * quaternion[2], k * quaternion[3]};
}

// The spacecraft-boom deployment, hub free: 60 s, dense output every 50 ms.
bool free_spacecraft(const std::filesystem::path& dir, std::FILE* summary) {
  using K = spacecraft_free::Kernels;
  using Model = eom::models::SpacecraftFree;
  constexpr int nq = K::nq;
  const auto p = K::parameter_values;
  const double t1 = 60.0;
  eom::StateFor<K> x0{};
  for (int i = 0; i < nq; ++i) x0[i] = Model::initial_q[i];
  std::vector<double> times;
  for (int k = 0; k <= 1200; ++k) times.push_back(0.05 * k);
  std::FILE* csv = std::fopen((dir / "free_spacecraft.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t,angle_deg,rx_deg,ry_deg,rz_deg,hub_x_mm,hub_y_mm,hub_z_mm,com_x_mm,com_y_mm,"
                    "com_z_mm,P,H,energy,quaternion_error\n");
  const auto T0 = totals<Model, 10>(x0.data(), x0.data() + nq, p);
  double max_angle = 0, max_drift = 0, max_P = 0, max_dH = 0, max_com = 0, max_q_error = 0;
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = 1e-11;
  opt.atol = 1e-13;
  opt.output_times = times;
  const auto start = std::chrono::steady_clock::now();
  const auto r = eom::integrate<K>(0.0, t1, x0, nullptr, p.data(), opt, [&](double t, const eom::StateFor<K>& x) {
    const auto T = totals<Model, 10>(x.data(), x.data() + nq, p);
    const Vec rv = rotation_vector_deg(x.data() + 3);
    const double angle = norm(rv), drift = 1e3 * std::hypot(x[0], x[1], x[2]);
    Vec dH, dc;
    for (int i = 0; i < 3; ++i) {
      dH[i] = T.H[i] - T0.H[i];
      dc[i] = 1e3 * (T.centre[i] - T0.centre[i]);
    }
    const double q_error = eom::quaternion_norm_error(eom::Layout(nq, K::nv), x.data());
    max_angle = std::max(max_angle, angle);
    max_drift = std::max(max_drift, drift);
    max_P = std::max(max_P, norm(T.P));
    max_dH = std::max(max_dH, norm(dH));
    max_com = std::max(max_com, norm(dc));
    max_q_error = std::max(max_q_error, q_error);
    const double E = K::kinetic_energy(x.data(), x.data() + nq, p.data()) + K::potential_energy(x.data(), p.data());
    std::fprintf(csv, "%.2f,%.8f,%.8f,%.8f,%.8f,%.6f,%.6f,%.6f,%.3e,%.3e,%.3e,%.3e,%.3e,%.10f,%.2e\n", t, angle,
                 rv[0], rv[1], rv[2], 1e3 * x[0], 1e3 * x[1], 1e3 * x[2], dc[0], dc[1], dc[2], norm(T.P), norm(dH), E,
                 q_error);
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fclose(csv);
  if (r.status != eom::Status::ok) {
    std::fprintf(stderr, "eom_demo: free spacecraft stopped at t = %g: %s\n", r.t, eom::to_string(r.status));
    return false;
  }
  std::FILE* facts = std::fopen((dir / "free_spacecraft.txt").c_str(), "w");
  if (!facts) return false;
  std::fprintf(facts,
               "steps=%ld\nwall_ms=%.1f\nmax_angle_deg=%.4f\nmax_drift_mm=%.4f\nend_drift_mm=%.4f\nmax_P=%.3e\n"
               "max_dH=%.3e\nmax_com_mm=%.3e\nmax_quaternion_error=%.2e\n",
               r.accepted, 1e3 * seconds, max_angle, max_drift, 1e3 * std::hypot(r.x[0], r.x[1], r.x[2]), max_P,
               max_dH, max_com, max_q_error);
  std::fclose(facts);
  std::fprintf(summary,
               "free spacecraft,DOP853 rtol=1e-11,%ld steps,%.0f ms,max hub rotation=%.3f deg,max hub drift=%.2f mm,"
               "max |P|=%.1e kg m/s,max |H(t)-H(0)|=%.1e N m s,mass centre moved %.1e mm\n",
               r.accepted, 1e3 * seconds, max_angle, max_drift, max_P, max_dH, max_com);
  std::printf("free spacecraft: hub turned up to %.2f deg and drifted up to %.2f mm; |P| <= %.1e, |H - H0| <= %.1e, "
              "mass centre moved %.1e mm, |q| - 1 <= %.1e; %ld DOP853 steps, %.0f ms\n",
              max_angle, max_drift, max_P, max_dH, max_com, max_q_error, r.accepted, 1e3 * seconds);
  return true;
}

// The Panda on a free base in zero gravity: joint torques u_j(t) = a_j sin(π t + j),
// held over 5 ms pieces, move the arm for 4 s; nothing acts from outside, so P and H stay 0.
bool free_panda(const std::filesystem::path& dir, std::FILE* summary) {
  using K = demo_free_panda::Kernels;
  using Model = eom::urdf_models::demo_free_panda;
  constexpr int nq = K::nq, nu = K::nu;
  static_assert(K::parameter_names[0] == "g");
  auto p = K::parameter_values;
  p[0] = 0.0;  // zero gravity
  eom::StateFor<K> x{};
  x[3] = 1.0;  // upright, at rest, the arm in a bent pose
  const std::array<double, 7> pose{0.0, -0.5, 0.0, -2.0, 0.0, 1.5, 0.8};
  for (int j = 0; j < 7; ++j) x[7 + j] = pose[j];
  std::FILE* csv = std::fopen((dir / "free_panda.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t,base_angle_deg,base_rx_deg,base_ry_deg,base_rz_deg,q1,q2,q3,q4,q5,q6,q7,P,H\n");
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = 1e-12;
  opt.atol = 1e-14;
  const double piece = 0.005, t1 = 4.0;
  double max_P = 0, max_H = 0, max_angle = 0;
  long steps = 0;
  const auto start = std::chrono::steady_clock::now();
  auto record = [&](double t, const eom::StateFor<K>& s) {
    const auto T = totals<Model, K::np>(s.data(), s.data() + nq, p);
    const Vec rv = rotation_vector_deg(s.data() + 3);
    max_P = std::max(max_P, norm(T.P));
    max_H = std::max(max_H, norm(T.H));
    max_angle = std::max(max_angle, norm(rv));
    std::fprintf(csv, "%.3f,%.8f,%.8f,%.8f,%.8f", t, norm(rv), rv[0], rv[1], rv[2]);
    for (int j = 0; j < 7; ++j) std::fprintf(csv, ",%.8f", s[7 + j] * deg);
    std::fprintf(csv, ",%.3e,%.3e\n", norm(T.P), norm(T.H));
  };
  record(0.0, x);
  const long pieces = std::lround(t1 / piece);
  for (long k = 0; k < pieces; ++k) {
    const double t = k * piece;
    std::array<double, nu> u;
    for (int j = 0; j < nu; ++j) u[j] = (j < 4 ? 1.0 : 0.3) * std::sin(std::numbers::pi * (t + 0.5 * piece) + j);
    const auto r = eom::integrate<K>(t, t + piece, x, u.data(), p.data(), opt);
    if (r.status != eom::Status::ok) {
      std::fprintf(stderr, "eom_demo: free Panda stopped at t = %g: %s\n", r.t, eom::to_string(r.status));
      std::fclose(csv);
      return false;
    }
    x = r.x;
    steps += r.accepted;
    if ((k + 1) % 4 == 0) record(t + piece, x);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fclose(csv);
  std::FILE* facts = std::fopen((dir / "free_panda.txt").c_str(), "w");
  if (!facts) return false;
  std::fprintf(facts, "steps=%ld\nwall_ms=%.1f\nmax_base_angle_deg=%.4f\nmax_P=%.3e\nmax_H=%.3e\n", steps,
               1e3 * seconds, max_angle, max_P, max_H);
  std::fclose(facts);
  std::fprintf(summary,
               "free-floating Panda (zero g),DOP853 rtol=1e-12,%ld steps,%.0f ms,base turned up to %.2f deg,"
               "max |P|=%.1e kg m/s,max |H|=%.1e N m s (initially 0)\n",
               steps, 1e3 * seconds, max_angle, max_P, max_H);
  std::printf("free-floating Panda: the base counter-rotates up to %.2f deg; |P| <= %.1e, |H| <= %.1e (both 0 at "
              "the start); %ld DOP853 steps, %.0f ms\n",
              max_angle, max_P, max_H, steps, 1e3 * seconds);
  return true;
}

// Solo12 thrown with its joints limp (u = 0, no damping): 1 s of free fall, its mass centre on
// the parabola c0 + w0 t − ½ g t² e_z whatever its legs do.
bool solo12_fall(const std::filesystem::path& dir, std::FILE* summary) {
  using K = solo12::Kernels;
  using Model = eom::urdf_models::solo12;
  constexpr int nq = K::nq, nv = K::nv;
  const auto p = K::parameter_values;
  const double g = p[0];
  eom::StateFor<K> x0{};
  x0[2] = 0.5;
  const double half = 0.5 * 0.4;  // the base turned 0.4 rad about (1, 2, 2)/3
  x0[3] = std::cos(half);
  x0[4] = std::sin(half) / 3;
  x0[5] = 2 * std::sin(half) / 3;
  x0[6] = 2 * std::sin(half) / 3;
  for (int leg = 0; leg < 4; ++leg) {
    x0[7 + 3 * leg] = 0.1 * (leg % 2 == 0 ? 1 : -1);
    x0[8 + 3 * leg] = 0.8;
    x0[9 + 3 * leg] = -1.6;
  }
  const std::array<double, 6> base_v{0.4, -0.2, 1.5, 1.0, -2.0, 3.0};
  for (int i = 0; i < 6; ++i) x0[nq + i] = base_v[i];
  for (int j = 6; j < nv; ++j) x0[nq + j] = 2.0 * std::sin(1.7 * j);
  const auto T0 = totals<Model, K::np>(x0.data(), x0.data() + nq, p);
  const Vec c0 = T0.centre, w0{T0.P[0] / T0.mass, T0.P[1] / T0.mass, T0.P[2] / T0.mass};
  std::vector<double> times;
  for (int k = 0; k <= 200; ++k) times.push_back(0.005 * k);
  std::FILE* csv = std::fopen((dir / "solo12_fall.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t,com_z,parabola_z,deviation,base_z\n");
  double worst = 0;
  const std::array<double, K::nu> u{};
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = 1e-12;
  opt.atol = 1e-14;
  opt.output_times = times;
  const auto r = eom::integrate<K>(0.0, 1.0, x0, u.data(), p.data(), opt, [&](double t, const eom::StateFor<K>& x) {
    const auto T = totals<Model, K::np>(x.data(), x.data() + nq, p);
    Vec expected;
    for (int i = 0; i < 3; ++i) expected[i] = c0[i] + w0[i] * t;
    expected[2] -= 0.5 * g * t * t;
    const double d = std::hypot(T.centre[0] - expected[0], T.centre[1] - expected[1], T.centre[2] - expected[2]);
    worst = std::max(worst, d);
    std::fprintf(csv, "%.3f,%.12f,%.12f,%.3e,%.12f\n", t, T.centre[2], expected[2], d, x[2]);
  });
  std::fclose(csv);
  if (r.status != eom::Status::ok) {
    std::fprintf(stderr, "eom_demo: Solo12 fall stopped at t = %g: %s\n", r.t, eom::to_string(r.status));
    return false;
  }
  std::FILE* facts = std::fopen((dir / "solo12_fall.txt").c_str(), "w");
  if (!facts) return false;
  std::fprintf(facts, "steps=%ld\nmax_deviation_m=%.3e\nmass_kg=%.6f\n", r.accepted, worst, T0.mass);
  std::fclose(facts);
  std::fprintf(summary, "Solo12 free fall (limp),DOP853 rtol=1e-12,%ld steps,mass centre off the parabola by <= %.1e m\n",
               r.accepted, worst);
  std::printf("Solo12 free fall: mass centre within %.1e m of the parabola over 1 s (%ld DOP853 steps)\n", worst,
              r.accepted);
  return true;
}

}  // namespace

bool simulate_free_flight(const std::filesystem::path& dir, std::FILE* summary) {
  bool ok = free_spacecraft(dir, summary);
  ok = free_panda(dir, summary) && ok;
  ok = solo12_fall(dir, summary) && ok;
  return ok;
}
