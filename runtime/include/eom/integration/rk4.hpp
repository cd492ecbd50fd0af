// The classical fixed-step fourth-order Runge-Kutta method (paper eq. 27) over any eom::Dynamics,
// on the first-order state x = (q, v) (v = q̇ without a free joint). Allocation-free; stops, and
// says why, at the first step whose dynamics are singular or whose state is not finite.
// Constrained models may be stabilized (Baumgarte or projection, see stabilization.hpp); a free
// joint's quaternion is normalized after every step (state.hpp).
#pragma once

#include <array>
#include <cmath>
#include <concepts>
#include <type_traits>

#include "eom/integration/state.hpp"

namespace eom {

// One RK4 step of size h from (t, x); x is updated only on success.
template <Dynamics K>
bool rk4_step(double t, double h, StateFor<K>& x, const double* u, const double* p,
              const Stabilization& stab = {}) noexcept {
  constexpr int m = K::nq + nv_of<K>;
  StateFor<K> k0, k1, k2, k3, y;
  auto stage = [&](const StateFor<K>& k, double a) {
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
  normalize_state<K>(x);
  return true;
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

template <int nq, int nv = nq> struct Rk4Result {
  Status status = Status::ok;
  double t = 0;         // time reached (the failing step's start when status != ok)
  StateOf<nq, nv> x{};  // state at t
  long steps = 0;       // steps taken
};

// Integrates from t0 to t1 in `steps` equal steps, calling observer(t, x) at t0 and after every
// step. The observer is any callable (t, const StateFor<K>&); pass [](auto&&...) {} for none.
// For a constrained model, `stab` selects the stabilization; with projection the initial state
// is projected onto the constraints first, otherwise a start off the constraints is refused.
// An initial quaternion (free joint) whose norm is off 1 by more than quaternion_norm_tolerance
// is refused like a non-finite state (Status::invalid_argument).
template <Dynamics K, class Observer>
Rk4Result<K::nq, nv_of<K>> rk4(double t0, double t1, long steps, const StateFor<K>& x0,
                               const double* u, const double* p, Observer&& observer,
                               const Stabilization& stab = {}) noexcept {
  constexpr int n = K::nq;
  using Method = Stabilization::Method;
  Rk4Result<K::nq, nv_of<K>> r;
  r.t = t0;
  r.x = x0;
  bool finite = std::isfinite(t0) && std::isfinite(t1) && unit_quaternion<K>(x0);
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
