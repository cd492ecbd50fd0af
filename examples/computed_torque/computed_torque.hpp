// Computed-torque control (feedback linearization) of a fully actuated robot:
//
//   τ = M(q) (q̈_d + Kd ė + Kp e) + c(q, q̇) + ∂V/∂q,     e = q_d − q,
//
// which turns the robot M q̈ + c + ∂V/∂q = τ into the decoupled linear error dynamics
// ë + Kd ė + Kp e = 0 when the model is exact. Written against eom kernels, so it runs on a
// model's generated `Kernels` (or on eom::Reference<Model>); it assumes the model's generalized
// forces are the actuator torques, Q = u (one input per coordinate, no other forces).
//
// Allocation-free and noexcept: fit for the real-time loop.
#pragma once

#include <array>

#include <eom/model/kernels.hpp>

namespace examples {

template <class Model> class ComputedTorque {
 public:
  // The kernels the control law evaluates; a model generated without one of them stops the
  // build with a message naming it (add it to KERNELS in add_eom_model()).
  using K = eom::RequireKernels<Model, eom::Kernel::mass_matrix, eom::Kernel::coriolis,
                                eom::Kernel::potential_gradient>;
  static constexpr int n = K::nq;
  static_assert(K::nu == K::nq && K::nc == 0,
                "computed torque needs an unconstrained model with one actuator per coordinate");

  using Vector = std::array<double, n>;
  struct Gains {
    Vector kp{}, kd{};  // per joint [1/s²], [1/s]
  };
  // Critically damped error dynamics with natural frequency wn on every joint: the error decays
  // like (1 + wn t) e^(−wn t).
  static constexpr Gains critically_damped(double wn) noexcept {
    Gains g;
    for (int i = 0; i < n; ++i) g.kp[i] = wn * wn, g.kd[i] = 2 * wn;
    return g;
  }
  struct Setpoint {
    Vector q{}, qd{}, qdd{};  // desired position, velocity, acceleration
  };

  // p: the parameters the controller believes (the plant's may differ: model error).
  ComputedTorque(const Gains& gains, const std::array<double, K::np>& p) noexcept
      : gains_(gains), p_(p) {}

  // The torque for the measured state (q, q̇) and the setpoint; tau has n entries.
  void torque(const double* q, const double* qd, const Setpoint& ref, double* tau) const noexcept {
    std::array<double, n * n> M;  // column-major
    Vector c, dVdq, a;
    K::mass_matrix(q, p_.data(), M.data());
    K::coriolis(q, qd, p_.data(), c.data());
    K::potential_gradient(q, p_.data(), dVdq.data());
    for (int i = 0; i < n; ++i)  // the commanded acceleration
      a[i] = ref.qdd[i] + gains_.kd[i] * (ref.qd[i] - qd[i]) + gains_.kp[i] * (ref.q[i] - q[i]);
    for (int i = 0; i < n; ++i) {
      double Ma = 0;
      for (int j = 0; j < n; ++j) Ma += M[i + n * j] * a[j];
      tau[i] = Ma + c[i] + dVdq[i];
    }
  }

 private:
  Gains gains_;
  std::array<double, K::np> p_;
};

}  // namespace examples
