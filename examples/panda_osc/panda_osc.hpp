// Operational-space control (Khatib) of the Franka Emika Panda's flange, closed loop on kernels
// generated from its URDF file (add_eom_model(panda URDF panda.urdf FRAMES panda_link8)): the
// control law, the reference (a circle held at a fixed orientation), and the sampled loop.
// Written against any Kernels type of the Panda that has the six kernels the law uses and the
// flange among its frames.
//
// The task is the flange's pose, 6-D (position and orientation), on the 7-dof arm; its kinematics
// come from the frame kernels (docs/CONTRACT.md §2, world axes): x and R = frame_placement,
// J (6×7: rows 0-2 the origin's velocity, 3-5 the angular velocity) = frame_jacobian, and
// a = J̇ v = frame_acceleration_bias, so that the flange accelerates by J q̈ + a. The law:
//
//   M = L Lᵀ (Cholesky),  Z = L⁻¹ Jᵀ (7×6),  Λ⁻¹ = J M⁻¹ Jᵀ = Zᵀ Z (6×6, = Lλ Lλᵀ),
//   ẍ* = ẍ_d + Kd ė + Kp e − a,        e = (x_d − x, e_o),  ė = (ẋ_d − J_v v, ω_d − J_ω v),
//   e_o = ½ Σᵢ rᵢ × r_d,i              (rᵢ, r_d,i the columns of R, R_d: world axes; = sin θ k
//                                        for R_d = Rot(k, θ) R),
//   τ₀ = −Kn (q − q_ready) − Dn q̇     (a posture torque for the redundant elbow),
//   τ  = Jᵀ F + Nᵀ τ₀ + c + ∂V/∂q + d⊙q̇,   F = Λ ẍ*,
//   Nᵀ = 1 − Jᵀ J̄ᵀ,  J̄ = M⁻¹ Jᵀ Λ   (the dynamically consistent inverse: J M⁻¹ Nᵀ = 0).
//
// Nᵀ τ₀ = τ₀ − Jᵀ Λ J M⁻¹ τ₀ = τ₀ − Jᵀ Λ Zᵀ (L⁻¹ τ₀), so the two task-space products share one
// solve: τ = Jᵀ Λ (ẍ* − Zᵀ L⁻¹ τ₀) + τ₀ + c + ∂V/∂q + d⊙q̇. Cost: the 7×7 Cholesky, 7 forward
// substitutions, the 6×6 Gram product and Cholesky, one 6×6 solve, no inverse formed.
//
// With the exact model, M q̈ + c + ∂V/∂q = τ − d⊙q̇ (the URDF model's Q = u − d⊙q̇) gives
// J q̈ + a = ẍ* + a, i.e. ë + Kd ė + Kp e = 0 in translation (and its small-angle counterpart in
// rotation), while the posture torque acts only in the null space of J. The file's joint damping
// d (0.003 N·m·s/rad) is a force of the model, so the law compensates it (+ d⊙q̇, the parameters
// `<joint>_damping`), as the inverse dynamics of the computed-torque example does.
//
// The loop: a digital controller at 1 kHz samples (q, q̇), computes τ and holds it over the
// sample period (zero-order hold) while eom::integrate (DOP853, rtol 1e-10, atol 1e-12) carries
// the plant to the next sample, one integrate call per sample (as examples/panda_computed_torque).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string_view>
#include <vector>

#include <eom/integration/integrate.hpp>
#include <eom/model/kernels.hpp>

#include "../panda_computed_torque/panda_payload.hpp"  // parameter_index, with_payload
#include <eom/numeric/linalg.hpp>

namespace panda_osc {

using panda::parameter_index;
using panda::with_payload;

constexpr int n = 7;  // joints
constexpr int m = 6;  // task: flange position and orientation
using Vector = std::array<double, n>;
using Vec3 = std::array<double, 3>;
using Rot = std::array<double, 9>;  // column-major, frame axes → world

// The published limits (models/robots/panda.urdf, from franka_ros joint_limits.yaml).
constexpr Vector lower{-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973};
constexpr Vector upper{2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973};
constexpr Vector effort_limit{87, 87, 87, 87, 12, 12, 12};

// Franka's "ready" pose: the start, and the posture the null-space term pulls the elbow to.
constexpr Vector ready{0, -std::numbers::pi / 4, 0, -3 * std::numbers::pi / 4, 0,
                       std::numbers::pi / 2, std::numbers::pi / 4};

inline Vec3 cross(const Vec3& a, const Vec3& b) noexcept {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// e_o = ½ Σᵢ rᵢ × r_d,i: the orientation error, world axes (sin θ times the axis of the rotation
// R_d Rᵀ that carries R to R_d).
inline Vec3 orientation_error(const Rot& R, const Rot& Rd) noexcept {
  Vec3 e{};
  for (int i = 0; i < 3; ++i) {
    const Vec3 c = cross({R[3 * i], R[3 * i + 1], R[3 * i + 2]}, {Rd[3 * i], Rd[3 * i + 1], Rd[3 * i + 2]});
    for (int k = 0; k < 3; ++k) e[k] += 0.5 * c[k];
  }
  return e;
}

// The angle θ of R_d Rᵀ: atan2(sin θ, cos θ) with sin θ = |e_o| and cos θ = (tr(Rᵀ R_d) − 1)/2.
inline double orientation_angle(const Rot& R, const Rot& Rd) noexcept {
  const Vec3 e = orientation_error(R, Rd);
  double trace = 0;
  for (int k = 0; k < 9; ++k) trace += R[k] * Rd[k];
  return std::atan2(std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), 0.5 * (trace - 1));
}

struct Setpoint {
  Vec3 x{}, xd{}, xdd{};  // desired position, velocity, acceleration of the flange (world)
  Rot R{};                // desired orientation
  Vec3 w{}, wd{};         // desired angular velocity and acceleration (world)
};

// The reference: a circle of `radius` through the start x0, in the plane spanned by the unit
// vectors u, w (x_d = x0 + r ((cos φ − 1) u + sin φ w)), run at `frequency` after a smooth start:
// the phase rate φ̇ rises from 0 to 2π·frequency over `ramp` seconds along the quintic
// s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ (so ẍ_d is continuous and the start at rest is on the reference);
// the orientation is held at R0 (ω_d = 0).
struct Circle {
  Vec3 x0{}, u{}, w{};
  Rot R0{};
  double radius = 0.1, frequency = 0.5, ramp = 1.0;

  Setpoint at(double t) const noexcept {
    const double omega = 2 * std::numbers::pi * frequency;
    double phi, dphi, ddphi;
    if (t < ramp) {
      const double s = t / ramp, s2 = s * s, s3 = s2 * s;
      phi = omega * ramp * s2 * s2 * (2.5 - 3 * s + s2);        // ∫ s: τ⁴ (5/2 − 3τ + τ²)
      dphi = omega * s3 * (10 - 15 * s + 6 * s2);
      ddphi = omega / ramp * 30 * s2 * (1 - 2 * s + s2);         // 30 τ² (1 − τ)²
    } else {
      phi = omega * (0.5 * ramp + (t - ramp));
      dphi = omega;
      ddphi = 0;
    }
    const double c = std::cos(phi), s = std::sin(phi), r = radius;
    Setpoint sp;
    for (int k = 0; k < 3; ++k) {
      const double radial = c * u[k] + s * w[k], tangent = -s * u[k] + c * w[k];
      sp.x[k] = x0[k] + r * ((c - 1) * u[k] + s * w[k]);
      sp.xd[k] = r * dphi * tangent;
      sp.xdd[k] = r * ddphi * tangent - r * dphi * dphi * radial;
    }
    sp.R = R0;
    return sp;
  }
};

// The index of frame `name` in K::frame_names, or −1.
template <class K> constexpr int frame_index(std::string_view name) {
  for (int i = 0; i < K::nframes; ++i)
    if (K::frame_names[i] == name) return i;
  return -1;
}

struct Gains {
  double position_frequency = 25;     // ωn of the translational error dynamics [rad/s]
  double orientation_frequency = 25;  // ωn of the rotational one [rad/s]; both critically damped
  double posture_stiffness = 20;      // Kn [N·m/rad], every joint
  double posture_damping = 4;         // Dn [N·m·s/rad], every joint
};

struct Variant {
  bool bias = true;               // subtract a = J̇ v (false: drop it, a wrong law)
  bool compensate_damping = true; // add d⊙q̇
  bool posture = true;            // the null-space term Nᵀ τ₀
};

// What the kernels give at one state: the controller's inputs to the task-space solve.
struct Terms {
  std::array<double, n * n> M;  // mass matrix
  Vector h;                     // c + ∂V/∂q
  std::array<double, m * n> J;  // the flange's Jacobian, 6×7 column-major
  std::array<double, m> a;      // J̇ v
  Vec3 x;                       // the flange's origin
  Rot R;                        // its orientation
};

// Fixed-size Cholesky, A = L Lᵀ in place (lower triangle of the column-major A; the strict upper
// triangle is not read), with the pivots' reciprocals in inv so that the substitutions multiply:
// eom::linalg::cholesky's algorithm and pivot test (eom::linalg::pivot_ok: a pivot not clearly
// positive against its diagonal entry means a singular matrix), without its divisions.
template <int N> bool factor(std::array<double, N * N>& A, std::array<double, N>& inv) noexcept {
  for (int j = 0; j < N; ++j) {
    double d = A[j + N * j];
    for (int k = 0; k < j; ++k) d -= A[j + N * k] * A[j + N * k];
    if (!eom::linalg::pivot_ok(d, A[j + N * j])) return false;
    const double l = std::sqrt(d);
    A[j + N * j] = l;
    inv[j] = 1 / l;
    for (int i = j + 1; i < N; ++i) {
      double s = A[i + N * j];
      for (int k = 0; k < j; ++k) s -= A[i + N * k] * A[j + N * k];
      A[i + N * j] = s * inv[j];
    }
  }
  return true;
}

// b ← L⁻¹ b and b ← L⁻ᵀ b, L from factor().
template <int N> void forward(const std::array<double, N * N>& L, const std::array<double, N>& inv,
                              double* b) noexcept {
  for (int i = 0; i < N; ++i) {
    double s = b[i];
    for (int k = 0; k < i; ++k) s -= L[i + N * k] * b[k];
    b[i] = s * inv[i];
  }
}
template <int N> void backward(const std::array<double, N * N>& L, const std::array<double, N>& inv,
                               double* b) noexcept {
  for (int i = N - 1; i >= 0; --i) {
    double s = b[i];
    for (int k = i + 1; k < N; ++k) s -= L[k + N * i] * b[k];
    b[i] = s * inv[i];
  }
}

// The controller; allocation-free and noexcept. p: the parameters it believes.
template <class Model> class OperationalSpace {
 public:
  using K = eom::RequireKernels<Model, eom::Kernel::mass_matrix, eom::Kernel::coriolis,
                                eom::Kernel::potential_gradient, eom::Kernel::frame_placement,
                                eom::Kernel::frame_jacobian, eom::Kernel::frame_acceleration_bias>;
  static_assert(K::nq == n && K::nv == n && K::nu == n && K::nc == 0,
                "the Panda: 7 joints, one torque input each, no constraints");
  static constexpr int flange = frame_index<K>("panda_link8");
  static_assert(flange >= 0, "the Panda's flange: add_eom_model(... FRAMES panda_link8)");

  OperationalSpace(const Gains& g, const std::array<double, K::np>& p, Variant v = {}) noexcept
      : kp_{g.position_frequency * g.position_frequency,
            g.orientation_frequency * g.orientation_frequency},
        kd_{2 * g.position_frequency, 2 * g.orientation_frequency},
        kn_(v.posture ? g.posture_stiffness : 0), dn_(v.posture ? g.posture_damping : 0),
        p_(p), variant_(v) {
    constexpr std::array<std::string_view, n> joint{
        "panda_joint1_damping", "panda_joint2_damping", "panda_joint3_damping", "panda_joint4_damping",
        "panda_joint5_damping", "panda_joint6_damping", "panda_joint7_damping"};
    for (int i = 0; i < n; ++i) {
      const int at = parameter_index<K>(joint[i]);
      damping_[i] = at >= 0 && v.compensate_damping ? p[at] : 0.0;
    }
  }

  // The kernels' part of a control step: M, c + ∂V/∂q, the flange's placement, J and J̇v.
  void evaluate(const double* q, const double* qd, Terms& k) const noexcept {
    K::mass_matrix(q, p_.data(), k.M.data());
    Vector g;
    K::coriolis(q, qd, p_.data(), k.h.data());
    K::potential_gradient(q, p_.data(), g.data());
    for (int i = 0; i < n; ++i) k.h[i] += g[i];
    K::frame_placement(flange, q, p_.data(), k.x.data(), k.R.data());
    K::frame_jacobian(flange, q, p_.data(), k.J.data());
    K::frame_acceleration_bias(flange, q, qd, p_.data(), k.a.data());
  }

  // The task-space solve: τ from the kernels' terms (header comment). False, with τ untouched,
  // when M or Λ⁻¹ is not positive definite (a singular Jacobian).
  bool solve(const double* q, const double* qd, const Setpoint& ref, const Terms& k,
             double* tau) const noexcept {
    // Task velocity J v and the commanded task acceleration ẍ* = ẍ_d + Kd ė + Kp e − a.
    std::array<double, m> xdot{};
    for (int j = 0; j < n; ++j)
      for (int r = 0; r < m; ++r) xdot[r] += k.J[r + m * j] * qd[j];
    const Vec3 eo = orientation_error(k.R, ref.R);
    std::array<double, m> acc;
    for (int r = 0; r < 3; ++r) {
      acc[r] = ref.xdd[r] + kd_[0] * (ref.xd[r] - xdot[r]) + kp_[0] * (ref.x[r] - k.x[r]);
      acc[3 + r] = ref.wd[r] + kd_[1] * (ref.w[r] - xdot[3 + r]) + kp_[1] * eo[r];
      if (variant_.bias) acc[r] -= k.a[r], acc[3 + r] -= k.a[3 + r];
    }
    // M = L Lᵀ; Z = L⁻¹ Jᵀ (column r of Z: L z = row r of J).
    std::array<double, n * n> L = k.M;
    Vector inv;  // 1 / L_ii: one division per pivot, products after
    if (!factor<n>(L, inv)) return false;
    std::array<double, n * m> Z;
    for (int r = 0; r < m; ++r) {
      double* z = &Z[n * r];
      for (int i = 0; i < n; ++i) z[i] = k.J[r + m * i];
      forward<n>(L, inv, z);
    }
    // The posture torque τ₀ and y = L⁻¹ τ₀; then ẍ* − Zᵀ y (= ẍ* − J M⁻¹ τ₀).
    Vector tau0, y;
    for (int i = 0; i < n; ++i) y[i] = tau0[i] = -kn_ * (q[i] - ready[i]) - dn_ * qd[i];
    forward<n>(L, inv, y.data());
    for (int r = 0; r < m; ++r) {
      double s = 0;
      for (int i = 0; i < n; ++i) s += Z[i + n * r] * y[i];
      acc[r] -= s;
    }
    // Λ⁻¹ = Zᵀ Z (lower triangle) = Lλ Lλᵀ, and F' = Λ (ẍ* − J M⁻¹ τ₀).
    std::array<double, m * m> S;
    for (int c = 0; c < m; ++c)
      for (int r = c; r < m; ++r) {
        double s = 0;
        for (int i = 0; i < n; ++i) s += Z[i + n * r] * Z[i + n * c];
        S[r + m * c] = s;
      }
    std::array<double, m> inv_s;
    if (!factor<m>(S, inv_s)) return false;
    forward<m>(S, inv_s, acc.data());
    backward<m>(S, inv_s, acc.data());
    // τ = Jᵀ F' + τ₀ + c + ∂V/∂q + d⊙q̇.
    for (int j = 0; j < n; ++j) {
      double s = tau0[j] + k.h[j] + damping_[j] * qd[j];
      for (int r = 0; r < m; ++r) s += k.J[r + m * j] * acc[r];
      tau[j] = s;
    }
    return true;
  }

  // One control step: the kernels, then the solve. `terms` (optional) receives the kernels' terms.
  bool torque(const double* q, const double* qd, const Setpoint& ref, double* tau,
              Terms* terms = nullptr) const noexcept {
    Terms local;
    Terms& k = terms ? *terms : local;
    evaluate(q, qd, k);
    return solve(q, qd, ref, k, tau);
  }

  // The flange's placement, for the initial pose and the logs.
  void placement(const double* q, Vec3& x, Rot& R) const noexcept {
    K::frame_placement(flange, q, p_.data(), x.data(), R.data());
  }

 private:
  std::array<double, 2> kp_, kd_;
  double kn_, dn_;
  std::array<double, K::np> p_;
  Vector damping_{};
  Variant variant_;
};

struct Settings {
  double sample_period = 1e-3;  // 1 kHz [s]
  double duration = 7;          // the 1 s ramp, then 3 periods of the circle [s]
  double settle_time = 1;       // figures "after the start" over t ≥ this [s]
  int log_every = 5;            // a log row every 5 samples
  Gains gains{};
};

struct Run {
  bool ok = true;
  double failed_at = 0;  // where the loop stopped, when !ok
  const char* failure = "";
  double max_position_error = 0;         // max |x_d − x| over t ≥ settle_time [m]
  double rms_position_error = 0;         // over samples t ≥ settle_time [m]
  double max_orientation_error = 0;      // max angle of R_d Rᵀ over t ≥ settle_time [rad]
  double max_position_error_all = 0;     // over the whole run
  double max_orientation_error_all = 0;
  double max_posture_deviation = 0;      // max_i |q_i − ready_i| over the run [rad]
  double min_limit_margin = 1e9;         // min over joints and samples of the distance to the limits [rad]
  Vector max_torque{};                   // per joint, whole run [N·m]
  long steps = 0, rejected = 0, evaluations = 0;  // the plant integration's work
  struct Row {
    double t;
    Vec3 x, x_ref;
    double position_error, orientation_error;
    Vector q, qd, tau;
  };
  std::vector<Row> log;  // every log_every samples
};

inline Circle circle_from(const Vec3& x0, const Rot& R0) {
  // The circle's plane: sideways (world y) and up, tilted 30° back toward the base
  // (w = (−sin 30°, 0, cos 30°)): the flange moves in all three world axes.
  Circle c;
  c.x0 = x0;
  c.R0 = R0;
  c.u = {0, 1, 0};
  c.w = {-0.5, 0, std::sqrt(3.0) / 2};
  return c;
}

// Runs the closed loop on the plant with parameters p_plant, the controller believing p_model;
// the arm starts at rest in the ready pose, the circle starts there.
template <class K>
Run simulate(const std::array<double, K::np>& p_plant, const std::array<double, K::np>& p_model,
             Variant variant, const Settings& s = {}) {
  const OperationalSpace<K> controller(s.gains, p_model, variant);
  Run run;
  const long samples = std::lround(s.duration / s.sample_period);
  run.log.reserve(static_cast<std::size_t>(samples / s.log_every + 1));
  eom::StateOf<n> x{};
  for (int i = 0; i < n; ++i) x[i] = ready[i];
  Vec3 x0;
  Rot R0;
  controller.placement(x.data(), x0, R0);
  const Circle circle = circle_from(x0, R0);
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = 1e-10;
  opt.atol = 1e-12;
  double sum_sq = 0;
  long count = 0;
  for (long k = 0; k <= samples; ++k) {
    const double t = static_cast<double>(k) * s.sample_period;
    const Setpoint ref = circle.at(t);
    Vector tau;
    Terms terms;
    if (!controller.torque(x.data(), x.data() + n, ref, tau.data(), &terms)) {
      run.ok = false;
      run.failed_at = t;
      run.failure = "the task-space solve failed (M or J M⁻¹ Jᵀ not positive definite)";
      return run;
    }
    double ep = 0;
    for (int r = 0; r < 3; ++r) ep += (ref.x[r] - terms.x[r]) * (ref.x[r] - terms.x[r]);
    ep = std::sqrt(ep);
    const double eo = orientation_angle(terms.R, ref.R);
    run.max_position_error_all = std::max(run.max_position_error_all, ep);
    run.max_orientation_error_all = std::max(run.max_orientation_error_all, eo);
    if (t >= s.settle_time) {
      run.max_position_error = std::max(run.max_position_error, ep);
      run.max_orientation_error = std::max(run.max_orientation_error, eo);
      sum_sq += ep * ep;
      ++count;
    }
    for (int i = 0; i < n; ++i) {
      run.max_torque[i] = std::max(run.max_torque[i], std::abs(tau[i]));
      run.max_posture_deviation = std::max(run.max_posture_deviation, std::abs(x[i] - ready[i]));
      run.min_limit_margin = std::min({run.min_limit_margin, x[i] - lower[i], upper[i] - x[i]});
    }
    if (k % s.log_every == 0) {
      Run::Row row{t, terms.x, ref.x, ep, eo, {}, {}, tau};
      for (int i = 0; i < n; ++i) row.q[i] = x[i], row.qd[i] = x[n + i];
      run.log.push_back(row);
    }
    if (k == samples) break;
    const double t_next = static_cast<double>(k + 1) * s.sample_period;
    opt.step = t_next - t;  // the first step lands on t_next
    const auto r = eom::integrate<K>(t, t_next, x, tau.data(), p_plant.data(), opt);
    if (r.status != eom::Status::ok) {
      run.ok = false;
      run.failed_at = r.t;
      run.failure = eom::to_string(r.status);
      return run;
    }
    x = r.x;
    run.steps += r.accepted, run.rejected += r.rejected, run.evaluations += r.evaluations;
  }
  run.rms_position_error = std::sqrt(sum_sq / static_cast<double>(count));
  return run;
}

}  // namespace panda_osc
