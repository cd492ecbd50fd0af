// What every integrator shares: how an integration ends (Status), the first-order state
// x = (q, v), its derivative ẋ = (G(q) v, v̇) through the forward dynamics (or their Baumgarte-
// stabilized form), and the start of an integration (normalized; projected or checked).
//
// Without a free joint v = q̇ (nv = nq, G = I) and x = (q, q̇) as always. With one
// (eom/model/free_joint.hpp) q holds a unit quaternion that no integrator keeps on the unit sphere by
// itself: every method puts it back (normalize_state) at the start, after each accepted step
// and in every state it hands out between step ends (dense output, events). Why projection
// rather than a Lie-group update (q ⊗ exp(h ω/2) inside the stages): it works for every method
// unchanged (explicit, implicit, Taylor, extrapolation), it keeps each method's order and its
// error estimate, which is taken before the projection (Hairer, Lubich & Wanner, Geometric
// Numerical Integration, §IV.4), and it costs one square root per step.
#pragma once

#include <array>
#include <cmath>

#include "eom/integration/stabilization.hpp"
#include "eom/model/diagnosis.hpp"
#include "eom/model/free_joint.hpp"
#include "eom/model/kernels.hpp"

namespace eom {

enum class Status {
  ok,                 // reached the end time
  singular_dynamics,  // forward_dynamics returned false (M or C M⁻¹Cᵀ singular or indefinite,
                      // bad input): eom::integrate's result says which (failure, diagnosis.hpp)
  non_finite_state,   // a state component became Inf or NaN
  invalid_argument,   // a step count, time span or initial state that cannot be integrated
  inconsistent_initial_state,  // φ(q0) ≠ 0 or C q̇0 ≠ 0 beyond the tolerance (no projection asked)
  projection_failed,  // the state could not be projected onto the constraints
  step_size_underflow,  // an adaptive step fell below 16 ε |t| (the dynamics may blow up)
  step_limit,         // the allowed number of steps was used up before the end time
  nonlinear_solve_failed,  // an implicit step's Newton iteration did not converge
  method_unavailable,  // the method needs kernels these Kernels lack (see eom/integration/integrate.hpp), or
                       // cannot take the model (variational with a free joint, variational.hpp)
  event_not_finite,    // an event function returned Inf or NaN (result: which event, and when)
  event_reset_failed,  // an event's reset map failed, or returned a non-finite state or a
                       // free joint's quaternion off the unit sphere
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
      return "the method needs kernels that were not generated (add them to KERNELS), or cannot "
             "take this model (the variational method: no free or ball joint; radau5: no ball joint)";
    case Status::event_not_finite: return "an event function returned a non-finite value";
    case Status::event_reset_failed:
      return "an event's reset map failed or returned a non-finite state (or a non-unit quaternion)";
    case Status::event_chattering: return "events reset the state faster than the allowed rate (chattering)";
  }
  return "unknown";
}

template <int nq, int nv = nq> using StateOf = std::array<double, nq + nv>;  // (q, v)
template <class K> using StateFor = StateOf<K::nq, nv_of<K>>;          // K's state

// ẋ = f(t, x) = (G(q) v, v̇(t, q, v)); false when the dynamics are singular, and then why is
// noted for eom::integrate (eom/model/diagnosis.hpp). With Baumgarte stabilization v̇ comes from
// baumgarte_dynamics instead of the forward_dynamics kernel.
template <Dynamics K>
bool state_derivative(double t, const StateFor<K>& x, const double* u, const double* p,
                      StateFor<K>& dx, const Stabilization& stab = {}) noexcept {
  constexpr int n = K::nq;
  configuration_rate(layout_of<K>(), x.data(), x.data() + n, dx.data());
  const bool ok = [&] {
    if constexpr (K::nc > 0)
      if (stab.method == Stabilization::Method::baumgarte)
        return baumgarte_dynamics<K>(t, x.data(), x.data() + n, u, p, stab.alpha, stab.beta, dx.data() + n);
    return K::forward_dynamics(t, x.data(), x.data() + n, u, p, dx.data() + n);
  }();
  if (!ok) detail::note_dynamics_failure<K>(t, x.data(), x.data() + n, u, p);
  return ok;
}

// How far from 1 an initial quaternion's norm may be: farther is a wrong input (a quaternion
// that is no rotation, or q and v mixed up), not round-off, and is refused
// (Status::invalid_argument) rather than silently normalized.
inline constexpr double quaternion_norm_tolerance = 1e-6;

// True when x can start an integration as far as its quaternions go (the free joint's, ball
// joints'): each one's norm within quaternion_norm_tolerance of 1 (always true without; NaN is
// false).
template <Dynamics K> bool unit_quaternion(const StateFor<K>& x) noexcept {
  if constexpr (nv_of<K> == K::nq) {
    (void)x;
    return true;
  } else {
    return quaternion_norm_error(layout_of<K>(), x.data()) <= quaternion_norm_tolerance;
  }
}

// Puts x's quaternions back on the unit sphere (nothing without one). A zero or
// non-finite quaternion is left as it is, for the caller's finiteness check to report.
template <Dynamics K> void normalize_state(StateFor<K>& x) noexcept {
  if constexpr (nv_of<K> != K::nq) normalize_configuration(layout_of<K>(), x.data());
  (void)x;
}

// The start of an integration (after its input was validated): a free joint's quaternion
// normalized, so that the whole run is on the unit sphere; then for a constrained model, with
// projection, x is projected onto φ = 0 and C v = 0, otherwise a start farther than
// stab.initial_tolerance from them is refused.
template <Dynamics K>
Status constrained_start(StateFor<K>& x, const double* p, const Stabilization& stab) noexcept {
  constexpr int n = K::nq;
  normalize_state<K>(x);
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
