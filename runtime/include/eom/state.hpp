// What every integrator shares: how an integration ends (Status), the first-order state
// x = (q, q̇), its derivative ẋ = (q̇, q̈) through the forward dynamics (or their Baumgarte-
// stabilized form), and the start of a constrained integration (projected or checked).
#pragma once

#include <array>
#include <cmath>

#include "eom/kernels.hpp"
#include "eom/stabilization.hpp"

namespace eom {

enum class Status {
  ok,                 // reached the end time
  singular_dynamics,  // forward_dynamics returned false (M or C M⁻¹Cᵀ singular, bad input)
  non_finite_state,   // a state component became Inf or NaN
  invalid_argument,   // a step count, time span or initial state that cannot be integrated
  inconsistent_initial_state,  // φ(q0) ≠ 0 or C q̇0 ≠ 0 beyond the tolerance (no projection asked)
  projection_failed,  // the state could not be projected onto the constraints
  step_size_underflow,  // an adaptive step fell below 16 ε |t| (the dynamics may blow up)
  step_limit,         // the allowed number of steps was used up before the end time
  nonlinear_solve_failed,  // an implicit step's Newton iteration did not converge
  method_unavailable,  // the method needs kernels these Kernels lack (see eom/integrate.hpp)
  event_not_finite,    // an event function returned Inf or NaN (result: which event, and when)
  event_reset_failed,  // an event's reset map failed or returned a non-finite state
  event_chattering,    // resets faster than EventSettings::max_reset_rate (e.g. a Zeno bounce)
};

constexpr const char* to_string(Status s) {
  switch (s) {
    case Status::ok: return "ok";
    case Status::singular_dynamics: return "singular dynamics (forward_dynamics returned false)";
    case Status::non_finite_state: return "non-finite state";
    case Status::invalid_argument: return "invalid argument";
    case Status::inconsistent_initial_state:
      return "initial state violates the constraints (project it, or use Stabilization::projection)";
    case Status::projection_failed: return "projection onto the constraints failed";
    case Status::step_size_underflow: return "step size underflow";
    case Status::step_limit: return "step limit reached";
    case Status::nonlinear_solve_failed: return "the implicit step's Newton iteration did not converge";
    case Status::method_unavailable:
      return "the method needs kernels that were not generated (add them to KERNELS)";
    case Status::event_not_finite: return "an event function returned a non-finite value";
    case Status::event_reset_failed: return "an event's reset map failed or returned a non-finite state";
    case Status::event_chattering: return "events reset the state faster than the allowed rate (chattering)";
  }
  return "unknown";
}

template <int nq> using StateOf = std::array<double, 2 * nq>;  // (q, q̇)

// ẋ = f(t, x) = (q̇, q̈(t, q, q̇)); false when the dynamics are singular. With Baumgarte
// stabilization q̈ comes from baumgarte_dynamics instead of the forward_dynamics kernel.
template <Dynamics K>
bool state_derivative(double t, const StateOf<K::nq>& x, const double* u, const double* p,
                      StateOf<K::nq>& dx, const Stabilization& stab = {}) noexcept {
  constexpr int n = K::nq;
  for (int i = 0; i < n; ++i) dx[i] = x[n + i];
  if constexpr (K::nc > 0)
    if (stab.method == Stabilization::Method::baumgarte)
      return baumgarte_dynamics<K>(t, x.data(), x.data() + n, u, p, stab.alpha, stab.beta, dx.data() + n);
  return K::forward_dynamics(t, x.data(), x.data() + n, u, p, dx.data() + n);
}

// The start of a constrained integration: with projection, x is projected onto φ = 0 and
// C q̇ = 0; otherwise a start farther than stab.initial_tolerance from them is refused.
template <Dynamics K>
Status constrained_start(StateOf<K::nq>& x, const double* p, const Stabilization& stab) noexcept {
  constexpr int n = K::nq;
  if constexpr (K::nc > 0) {
    if (stab.method == Stabilization::Method::projection)
      return project<K>(x.data(), x.data() + n, p, stab.tolerance) ? Status::ok
                                                                     : Status::projection_failed;
    const auto res = constraint_residuals<K>(x.data(), x.data() + n, p);
    if (!(res[0] <= stab.initial_tolerance && res[1] <= stab.initial_tolerance))
      return Status::inconsistent_initial_state;
  }
  return Status::ok;
}

}  // namespace eom
