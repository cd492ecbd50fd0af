// The classical fixed-step fourth-order Runge-Kutta method (paper eq. 27) over any eom::Dynamics,
// on the first-order state x = (q, q̇). Allocation-free; stops, and says why, at the first step
// whose dynamics are singular or whose state is not finite. Constrained models may be stabilized
// (Baumgarte or projection, see stabilization.hpp).
#pragma once

#include <array>
#include <cmath>
#include <concepts>
#include <type_traits>

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

// One RK4 step of size h from (t, x); x is updated only on success.
template <Dynamics K>
bool rk4_step(double t, double h, StateOf<K::nq>& x, const double* u, const double* p,
              const Stabilization& stab = {}) noexcept {
  constexpr int m = 2 * K::nq;
  StateOf<K::nq> k0, k1, k2, k3, y;
  auto stage = [&](const StateOf<K::nq>& k, double a) {
    for (int i = 0; i < m; ++i) y[i] = x[i] + a * h * k[i];
  };
  if (!state_derivative<K>(t, x, u, p, k0, stab)) return false;
  stage(k0, 0.5);
  if (!state_derivative<K>(t + 0.5 * h, y, u, p, k1, stab)) return false;
  stage(k1, 0.5);
  if (!state_derivative<K>(t + 0.5 * h, y, u, p, k2, stab)) return false;
  stage(k2, 1.0);
  if (!state_derivative<K>(t + h, y, u, p, k3, stab)) return false;
  for (int i = 0; i < m; ++i) x[i] += h / 6.0 * (k0[i] + 2.0 * k1[i] + 2.0 * k2[i] + k3[i]);
  return true;
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

namespace detail {
// An observer that may end a fixed-step integration after any step (the event handling of
// integrate.hpp): after calling it, rk4() and variational() return once o.stopped() is true.
template <class O>
concept StoppingObserver = requires(const std::remove_cvref_t<O>& o) {
  { o.stopped() } -> std::same_as<bool>;
};
template <class O> bool stop_requested(const O& observer) noexcept {
  if constexpr (StoppingObserver<O>)
    return observer.stopped();
  else
    return false;
}
}  // namespace detail

template <int nq> struct Rk4Result {
  Status status = Status::ok;
  double t = 0;        // time reached (the failing step's start when status != ok)
  StateOf<nq> x{};     // state at t
  long steps = 0;      // steps taken
};

// Integrates from t0 to t1 in `steps` equal steps, calling observer(t, x) at t0 and after every
// step. The observer is any callable (t, const StateOf<nq>&); pass [](auto&&...) {} for none.
// For a constrained model, `stab` selects the stabilization; with projection the initial state
// is projected onto the constraints first, otherwise a start off the constraints is refused.
template <Dynamics K, class Observer>
Rk4Result<K::nq> rk4(double t0, double t1, long steps, const StateOf<K::nq>& x0,
                     const double* u, const double* p, Observer&& observer,
                     const Stabilization& stab = {}) noexcept {
  constexpr int n = K::nq;
  using Method = Stabilization::Method;
  Rk4Result<K::nq> r;
  r.t = t0;
  r.x = x0;
  bool finite = std::isfinite(t0) && std::isfinite(t1);
  for (double v : x0) finite = finite && std::isfinite(v);
  if (steps <= 0 || !(t1 > t0) || !finite || (K::nc == 0 && stab.method != Method::none)) {
    r.status = Status::invalid_argument;
    return r;
  }
  const bool projecting = stab.method == Method::projection;
  if ((r.status = constrained_start<K>(r.x, p, stab)) != Status::ok) return r;
  const double h = (t1 - t0) / static_cast<double>(steps);
  observer(r.t, r.x);
  for (long k = 0; k < steps; ++k) {
    const double t = t0 + static_cast<double>(k) * h;
    if (!rk4_step<K>(t, h, r.x, u, p, stab)) {
      r.status = Status::singular_dynamics;
      r.t = t;
      return r;
    }
    for (double v : r.x)
      if (!std::isfinite(v)) {
        r.status = Status::non_finite_state;
        r.t = t + h;
        return r;
      }
    if constexpr (K::nc > 0)
      if (projecting && !project<K>(r.x.data(), r.x.data() + n, p, stab.tolerance)) {
        r.status = Status::projection_failed;
        r.t = t + h;
        return r;
      }
    r.t = k + 1 == steps ? t1 : t + h;
    ++r.steps;
    observer(r.t, r.x);
    if (detail::stop_requested(observer)) return r;
  }
  return r;
}

}  // namespace eom
