// Computed-torque tracking of the Franka Emika Panda, closed loop on kernels generated from its
// URDF file (add_eom_model(panda URDF panda.urdf)): the control law, the reference trajectory,
// a payload on the flange, and the sampled loop. Written against any Kernels type of the Panda
// (the example's, generated with four kernels, or eomgen's bundled `panda`, with all of them:
// demo/main.cpp runs the same loop on it).
//
// The control law, through the generated inverse dynamics
//
//   τ = ID(q, q̇, a) = M(q) a + c(q, q̇) + ∂V/∂q − Q(q, q̇, 0),
//   a = q̈_d + Kd ė + Kp e,  e = q_d − q.
//
// The URDF model's generalized forces are Q = u − d q̇ (d: the file's joint damping), so with
// u = τ the robot M q̈ + c + ∂V/∂q = τ − d q̇ becomes ë + Kd ė + Kp e = 0 when the model is exact:
// ID at u = 0 compensates every force of the model that is not the input. The variant without
// the velocity terms, τ = ID(q, 0, a) = M a + ∂V/∂q, drops c and the damping force d q̇
// (≤ 0.008 N·m here, negligible beside c).
//
// The loop: a digital controller at 1 kHz samples (q, q̇), computes τ and holds it over the
// sample period (zero-order hold) while eom::integrate (DOP853, rtol 1e-10, atol 1e-12) carries
// the plant to the next sample; one integrate call per sample, so no step straddles the jump of
// τ, with the whole period as the first step tried.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string_view>
#include <vector>

#include <eom/integration/integrate.hpp>
#include <eom/model/kernels.hpp>

#include "panda_payload.hpp"

namespace panda_ct {

using panda::parameter_index;
using panda::with_payload;

constexpr int n = 7;
using Vector = std::array<double, n>;

// The published joint limits (models/robots/panda.urdf, from franka_ros joint_limits.yaml).
constexpr Vector lower{-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973};
constexpr Vector upper{2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973};
constexpr Vector velocity_limit{2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61};
constexpr Vector effort_limit{87, 87, 87, 87, 12, 12, 12};

struct Setpoint {
  Vector q{}, qd{}, qdd{};  // desired position, velocity, acceleration
};

// The reference: q_d = centre + amplitude · sin(ω t) per joint, about Franka's "ready" pose
// (0, −π/4, 0, −3π/4, 0, π/2, π/4); every joint moves at once, each at its own frequency, inside
// its position limits (by ≥ 0.2 rad) and under 75% of its velocity limit (peak A ω: 0.5, 0.42,
// 0.68, 0.44, 1.0, 0.92, 1.56 rad/s).
constexpr Vector centre{0, -std::numbers::pi / 4, 0, -3 * std::numbers::pi / 4, 0,
                        std::numbers::pi / 2, std::numbers::pi / 4};
constexpr Vector amplitude{0.5, 0.35, 0.4, 0.4, 0.5, 0.4, 0.6};
constexpr Vector omega{1.0, 1.2, 1.7, 1.1, 2.0, 2.3, 2.6};  // [rad/s]

inline Setpoint reference(double t) {
  Setpoint r;
  for (int i = 0; i < n; ++i) {
    const double s = std::sin(omega[i] * t), c = std::cos(omega[i] * t);
    r.q[i] = centre[i] + amplitude[i] * s;
    r.qd[i] = amplitude[i] * omega[i] * c;
    r.qdd[i] = -amplitude[i] * omega[i] * omega[i] * s;
  }
  return r;
}

enum class Law {
  full,                  // τ = ID(q, q̇, a)
  no_velocity_terms,     // τ = ID(q, 0, a): c (and the damping force) dropped
};

// The controller; allocation-free and noexcept. p: the parameters it believes.
template <class Model> class ComputedTorque {
 public:
  using K = eom::RequireKernels<Model, eom::Kernel::inverse_dynamics>;
  static_assert(K::nq == n && K::nu == n && K::nc == 0,
                "the Panda: 7 joints, one torque input each, no constraints");

  ComputedTorque(double natural_frequency, const std::array<double, K::np>& p, Law law) noexcept
      : kp_(natural_frequency * natural_frequency), kd_(2 * natural_frequency), p_(p), law_(law) {}

  void torque(double t, const double* q, const double* qd, const Setpoint& ref,
              double* tau) const noexcept {
    Vector a;
    const Vector zero{};
    for (int i = 0; i < n; ++i)  // critically damped error dynamics on every joint
      a[i] = ref.qdd[i] + kd_ * (ref.qd[i] - qd[i]) + kp_ * (ref.q[i] - q[i]);
    K::inverse_dynamics(t, q, law_ == Law::full ? qd : zero.data(), a.data(), zero.data(),
                        p_.data(), tau);
  }

 private:
  double kp_, kd_;
  std::array<double, K::np> p_;
  Law law_;
};

struct Settings {
  double sample_period = 1e-3;    // 1 kHz [s]
  double duration = 10;           // [s]
  double natural_frequency = 10;  // of the error dynamics [rad/s]
  double settle_time = 2;         // figures "after settling" over t ≥ this [s]
  int log_every = 10;             // a log row every 10 samples
};

struct Run {
  bool ok = true;
  double failed_at = 0;             // where the plant integration stopped, when !ok
  const char* failure = "";
  double max_error_settled = 0;     // max over joints and t ≥ settle_time of |e| [rad]
  double rms_error_settled = 0;     // over joints and samples, t ≥ settle_time [rad]
  double max_error = 0;             // over the whole run (the start offset included)
  Vector max_error_joint{};         // per joint, t ≥ settle_time
  Vector max_torque{};              // per joint, whole run [N·m]
  long steps = 0, rejected = 0, evaluations = 0;  // the plant integration's work
  struct Row {
    double t;
    Vector q, e, tau;
  };
  std::vector<Row> log;  // every log_every samples
};

// The start: on the reference's position at t = 0 plus this offset, at rest.
constexpr Vector start_offset{0.05, -0.05, 0.05, 0.05, -0.05, 0.05, -0.05};

// Runs the closed loop on the plant with parameters p_plant, the controller believing p_model.
template <class K>
Run simulate(const std::array<double, K::np>& p_plant, const std::array<double, K::np>& p_model,
             Law law, const Settings& s = {}) {
  const ComputedTorque<K> controller(s.natural_frequency, p_model, law);
  Run run;
  const long samples = std::lround(s.duration / s.sample_period);
  run.log.reserve(static_cast<std::size_t>(samples / s.log_every + 1));
  eom::StateOf<n> x{};
  const auto start = reference(0);
  for (int i = 0; i < n; ++i) x[i] = start.q[i] + start_offset[i];
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = 1e-10;
  opt.atol = 1e-12;
  double sum_sq = 0;
  long count = 0;
  for (long k = 0; k <= samples; ++k) {
    const double t = static_cast<double>(k) * s.sample_period;
    const auto ref = reference(t);
    Vector tau, e;
    controller.torque(t, x.data(), x.data() + n, ref, tau.data());
    for (int i = 0; i < n; ++i) {
      e[i] = ref.q[i] - x[i];
      run.max_error = std::max(run.max_error, std::abs(e[i]));
      run.max_torque[i] = std::max(run.max_torque[i], std::abs(tau[i]));
      if (t >= s.settle_time) {
        run.max_error_joint[i] = std::max(run.max_error_joint[i], std::abs(e[i]));
        sum_sq += e[i] * e[i];
        ++count;
      }
    }
    if (k % s.log_every == 0) {
      Run::Row row{t, {}, e, tau};
      for (int i = 0; i < n; ++i) row.q[i] = x[i];
      run.log.push_back(row);
    }
    if (k == samples) break;
    const double t_next = static_cast<double>(k + 1) * s.sample_period;
    opt.step = t_next - t;  // exact (Sterbenz): the first step lands on t_next
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
  for (double v : run.max_error_joint) run.max_error_settled = std::max(run.max_error_settled, v);
  run.rms_error_settled = std::sqrt(sum_sq / static_cast<double>(count));
  return run;
}

}  // namespace panda_ct
