// What every adaptive integrator shares: its options, its result, the weighted error norm of the
// step-size control, the validation of its input, the delivery of output to the observer — at
// every accepted step, or (dense output) at exactly the times the user asked for — and the step
// loop itself (adaptive_steps), which dopri5, dop853 and taylor run with their own stepper.
// radau5 keeps its own loop: a Newton iteration's failure and the Jacobian's reuse are part of
// its step control.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <span>
#include <type_traits>

#include "eom/integration/state.hpp"

namespace eom {

struct AdaptiveOptions {
  double rtol = 1e-8, atol = 1e-10;
  double initial_step = 0;   // 0: chosen by the method (for Runge–Kutta, Hairer's starting rule)
  long max_steps = 1000000;  // accepted + rejected steps before Status::step_limit
  // Dense output: when not empty, the observer is called at exactly these times (ascending,
  // within [t0, t1]), with states from the method's continuous extension, instead of after every
  // accepted step. Stepping is not affected: the steps are those the tolerance asks for.
  std::span<const double> output_times{};
};

template <int nq, int nv = nq> struct AdaptiveResult {
  Status status = Status::ok;
  double t = 0;         // time reached
  StateOf<nq, nv> x{};  // state at t
  long accepted = 0, rejected = 0;
  long evaluations = 0;  // calls of the dynamics (forward_dynamics or its stabilized form)
  // With events (events.hpp): the event that terminated the integration, or whose failure the
  // status reports (event_not_finite, event_reset_failed, event_chattering); −1 otherwise.
  int event = -1;
  // From eom::integrate, with Status::singular_dynamics, or step_size_underflow (an adaptive
  // method retries a step whose stage failed smaller, down to underflow): why the dynamics failed
  // (eom/model/diagnosis.hpp: an indefinite or singular M, singular constraints, ...), at their last
  // failure since the last accepted step, and for M's failures the velocity of the failing pivot
  // (−1 otherwise). none when they did not fail (an underflow of another cause), or where the
  // method failed without evaluating them (the variational method's own Newton matrix).
  DynamicsFailure failure = DynamicsFailure::none;
  int failure_velocity = -1;
  // From eom::integrate, with Status::invalid_argument: which argument was refused and why
  // ("step: rk4 takes a fixed step: give step > 0"; eom::integration_argument_problem), a string
  // literal; nullptr otherwise.
  const char* message = nullptr;
};

namespace detail {

// True when the options, the time span and the initial state can be integrated (a free joint's
// quaternion within quaternion_norm_tolerance of the unit sphere, state.hpp).
// adaptive_input_problem: nullptr when they can, else which argument is refused and why (a string
// literal naming it as eom::integrate's arguments and IntegrationOptions' fields do).
template <Dynamics K>
const char* adaptive_input_problem(double t0, double t1, const StateFor<K>& x0,
                                   const AdaptiveOptions& opt) noexcept {
  if (!std::isfinite(t0) || !std::isfinite(t1)) return "t0, t1: the time span must be finite";
  if (!(t1 > t0)) return "t1: must be greater than t0 (the integration runs forward in time)";
  for (double v : x0)
    if (!std::isfinite(v)) return "x0: the initial state has a value that is not finite";
  if (!unit_quaternion<K>(x0))
    return layout_of<K>().free_joint_only()
               ? "x0: the free joint's quaternion (q[3:7]) is not of unit norm (within 1e-6): "
                 "give a rotation, normalized"
               : "x0: a quaternion (of a free or ball joint, K::quaternions) is not of unit norm "
                 "(within 1e-6): give rotations, normalized";
  if (!(std::isfinite(opt.rtol) && opt.rtol > 0)) return "rtol: must be finite and > 0";
  if (!(std::isfinite(opt.atol) && opt.atol > 0)) return "atol: must be finite and > 0";
  if (!(std::isfinite(opt.initial_step) && opt.initial_step >= 0))
    return "step: must be finite and >= 0 (an adaptive method's initial step; 0: its own choice)";
  if (!(opt.max_steps > 0)) return "max_steps: must be > 0";
  double previous = t0;
  for (double t : opt.output_times) {  // ascending, inside [t0, t1]
    if (!(std::isfinite(t) && t >= previous && t <= t1))
      return "output_times (t_eval): must be finite, ascending and inside [t0, t1]";
    previous = t;
  }
  return nullptr;
}

template <Dynamics K>
bool adaptive_input_ok(double t0, double t1, const StateFor<K>& x0,
                       const AdaptiveOptions& opt) noexcept {
  return adaptive_input_problem<K>(t0, t1, x0, opt) == nullptr;
}

// The start every adaptive method shares: bad input → invalid_argument (stabilization only
// for constrained models), then the constrained start (projected or checked, see state.hpp).
template <Dynamics K>
Status adaptive_start(double t0, double t1, StateFor<K>& x, const double* p,
                      const AdaptiveOptions& opt, const Stabilization& stab) noexcept {
  if (!adaptive_input_ok<K>(t0, t1, x, opt) ||
      (K::nc == 0 && stab.method != Stabilization::Method::none))
    return Status::invalid_argument;
  return constrained_start<K>(x, p, stab);
}

// Before each attempted step: the step budget, and a step h (NaN included) too small to advance
// t. Status::ok means the attempt may go ahead.
template <int nq, int nv>
Status step_allowed(const AdaptiveResult<nq, nv>& r, double h, const AdaptiveOptions& opt) noexcept {
  if (r.accepted + r.rejected >= opt.max_steps) return Status::step_limit;
  const double h_min = 16 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::abs(r.t));
  return h >= h_min ? Status::ok : Status::step_size_underflow;
}

// A state handed out between step ends (dense output, event location) comes from the step's
// continuous extension, which is neither normalized nor projected: a free joint's quaternion is
// normalized here (state.hpp) and, with Stabilization::projection, the state projected, so that
// every state the integrator hands out has a unit quaternion and lies on φ = 0 and C v = 0 to
// the projection's tolerance. A failed projection (never seen near the manifold) leaves it as
// it is.
template <Dynamics K>
void project_output(StateFor<K>& x, const double* p, const Stabilization& stab) noexcept {
  normalize_state<K>(x);
  if constexpr (ConstrainedDynamics<K>)
    if (stab.method == Stabilization::Method::projection) {
      StateFor<K> y = x;
      if (project<K>(y.data(), y.data() + K::nq, p, stab.tolerance)) x = y;
    }
}

// An observer that takes over the output of an adaptive method and may end it early (the event
// handling of events.hpp): the method calls o.start(t0, x0) instead of the first output, and after
// every accepted step [ta, tb] o.step(ta, xa, tb, xb, interpolate), with interpolate(t, x) the
// step's continuous extension (projected as above), always prepared; false from either ends the
// integration with Status::ok at the step's end (the monitor knows where it really stopped).
// output_times are then the monitor's business.
template <class O, class State>
concept StepMonitor = requires(std::remove_cvref_t<O>& o, const State& x,
                               void (*interpolate)(double, State&)) {
  { o.start(0.0, x) } -> std::same_as<bool>;
  { o.step(0.0, x, 0.0, x, interpolate) } -> std::same_as<bool>;
};

// ‖e‖ = sqrt(mean((eᵢ / (atol + rtol·max(|aᵢ|, |bᵢ|)))²)): the standard weighted RMS norm.
template <std::size_t m>
double error_norm(const std::array<double, m>& e, const std::array<double, m>& a,
                  const std::array<double, m>& b, const AdaptiveOptions& opt) noexcept {
  double s = 0;
  for (std::size_t i = 0; i < m; ++i) {
    const double w = e[i] / (opt.atol + opt.rtol * std::max(std::abs(a[i]), std::abs(b[i])));
    s += w * w;
  }
  return std::sqrt(s / static_cast<double>(m));
}

// Hairer's starting step (HNW I, §II.4) for a method of the given order, from the state x and its
// derivative dx at t0: h0 = 0.01·‖x‖/‖ẋ‖ (1e-6 when either is tiny), then one explicit Euler
// step of h0 estimates ‖ẍ‖, and h1 = (0.01 / max(‖ẋ‖, ‖ẍ‖))^(1/order) makes the leading error
// term about 0.01 in the error norm; h = min(100·h0, h1). False when f fails at the probe.
template <std::size_t m, class F>
bool starting_step(int order, F&& f, double t0, double span, const std::array<double, m>& x,
                   const std::array<double, m>& dx, const AdaptiveOptions& opt, double& h) noexcept {
  const double d0 = error_norm(x, x, x, opt), d1 = error_norm(dx, x, x, opt);
  const double h0 = std::min(d0 < 1e-5 || d1 < 1e-5 ? 1e-6 : 0.01 * d0 / d1, span);
  std::array<double, m> probe, dx_probe;
  for (std::size_t i = 0; i < m; ++i) probe[i] = x[i] + h0 * dx[i];
  if (!f(t0 + h0, probe, dx_probe)) return false;
  for (std::size_t i = 0; i < m; ++i) probe[i] = (dx_probe[i] - dx[i]) / h0;  // ≈ ẍ
  const double d2 = error_norm(probe, x, x, opt), dmax = std::max(d1, d2);
  const double h1 = dmax <= 1e-15 ? std::max(1e-6, h0 * 1e-3) : std::pow(0.01 / dmax, 1.0 / order);
  h = std::min(100 * h0, h1);
  return true;
}

// Hands the observer its output. Without output times: (t, x) at the start and after every
// accepted step. With them: after the step [t, t + h] is accepted, every requested time in
// (t, t + h] (and t0 itself at the start) through `interpolate(t_out, x_out)`.
class OutputSchedule {
 public:
  explicit OutputSchedule(std::span<const double> times) noexcept : times_(times) {}
  bool dense() const noexcept { return !times_.empty(); }

  // True when a requested time lies before t_end, so that step() will interpolate in the step
  // ending there: a method prepares its continuous extension only then.
  bool interpolates_before(double t_end) const noexcept {
    return next_ < times_.size() && times_[next_] < t_end;
  }

  template <class State, class Observer>
  void start(double t0, const State& x0, Observer& observer) noexcept {
    if (!dense()) return observer(t0, x0);
    for (; next_ < times_.size() && times_[next_] <= t0; ++next_) observer(times_[next_], x0);
  }

  // After an accepted step that ended at t_end with state x_end; interpolate(t, x) fills x.
  template <class State, class Interpolate, class Observer>
  void step(double t_end, const State& x_end, bool last, Interpolate&& interpolate,
            Observer& observer) noexcept {
    if (!dense()) return observer(t_end, x_end);
    State x;
    for (; next_ < times_.size() && (times_[next_] < t_end || last); ++next_) {
      if (times_[next_] >= t_end) {  // the end time itself (or beyond by round-off): exact
        observer(times_[next_], x_end);
        continue;
      }
      interpolate(times_[next_], x);
      observer(times_[next_], x);
    }
    for (; next_ < times_.size() && times_[next_] == t_end; ++next_) observer(t_end, x_end);
  }

 private:
  std::span<const double> times_;
  std::size_t next_ = 0;
};

// The step loop every adaptive method shares (dopri5, dop853: explicit_rk.hpp; taylor:
// taylor.hpp): step budget and underflow, the step to the end time, accept or reject, projection
// of the accepted state, and output (every accepted step, output times, or a StepMonitor).
// What differs between methods is the stepper s, over states x = (q, v):
//   start(t, x, span, h)        what the first step needs at (t, x) and its size h; false when
//                               the dynamics fail there (Status::singular_dynamics)
//   attempt(t, h, x)            the step's error norm: ≤ 1 acceptable, ∞ when it failed
//   solution()                  the attempted step's end state
//   complete(t, h, x_end, last, dense)
//                               what an acceptable step still needs before it is taken, at the
//                               (projected) end state: the continuous extension when dense, the
//                               next step's coefficients; false rejects the step
//   restart(t_end, x_end)       the accepted step's end as the next step's start (FSAL stage, or
//                               f again at a projected state); a failure ends the integration
//   interpolate(t_out, x)       the step's continuous extension at t_out
//   shrink(e)                   the factor of the retry after an error norm e > 1 (finite)
//   next(h, e, after_rejection, x_end)
//                               the step after an acceptance (not after the last step)
//   evaluations                 calls of the dynamics (or of the Taylor kernel) so far
template <Dynamics K, class Stepper, class Observer>
AdaptiveResult<K::nq, nv_of<K>> adaptive_steps(Stepper& s, double t0, double t1,
                                               const StateFor<K>& x0, const double* p,
                                               const AdaptiveOptions& opt, Observer& observer,
                                               const Stabilization& stab) noexcept {
  using State = StateFor<K>;
  AdaptiveResult<K::nq, nv_of<K>> r;
  r.t = t0;
  r.x = x0;
  auto end = [&](Status status) {
    r.status = status;
    r.evaluations = s.evaluations;
    return r;
  };
  double h = 0;
  if (!s.start(r.t, r.x, t1 - t0, h)) return end(Status::singular_dynamics);
  constexpr bool monitored = StepMonitor<Observer, State>;
  OutputSchedule schedule(opt.output_times);
  if constexpr (monitored) {
    if (!observer.start(r.t, r.x)) return end(Status::ok);
  } else {
    schedule.start(r.t, r.x, observer);
  }
  bool after_rejection = false;
  while (r.t < t1) {
    if (const Status st = step_allowed(r, h, opt); st != Status::ok) return end(st);
    const bool last = r.t + h >= t1;
    if (last) h = t1 - r.t;
    const double t = r.t, t_end = last ? t1 : t + h;
    const double e = s.attempt(t, h, r.x);
    State x_end = s.solution();
    if (e <= 1.0) {
      normalize_state<K>(x_end);  // after the error estimate: the method's own, unchanged
      if constexpr (K::nc > 0)
        if (stab.method == Stabilization::Method::projection &&
            !project<K>(x_end.data(), x_end.data() + K::nq, p, stab.tolerance)) {
          r.t = t_end;
          r.x = x_end;
          return end(Status::projection_failed);
        }
    }
    // A step that failed (a stage, or the evaluations after it) or produced Inf/NaN is retried
    // smaller, which also steps around a singularity a large step jumped into; underflow stops it.
    if (!(e <= 1.0 && s.complete(t, h, x_end, last, monitored || schedule.interpolates_before(t_end)))) {
      ++r.rejected;
      after_rejection = true;
      h *= e <= 1.0 || !std::isfinite(e) ? 0.25 : s.shrink(e);
      continue;
    }
    const State x_start = r.x;
    r.t = t_end;
    r.x = x_end;
    if (const Status st = s.restart(r.t, r.x); st != Status::ok) return end(st);
    ++r.accepted;
    last_dynamics_failure() = {};  // a failure before this step was stepped around
    auto interpolate = [&](double t_out, State& x_out) {
      s.interpolate(t_out, x_out);
      project_output<K>(x_out, p, stab);
    };
    if constexpr (monitored) {
      if (!observer.step(t, x_start, r.t, r.x, interpolate)) return end(Status::ok);
    } else {
      schedule.step(r.t, r.x, last, interpolate, observer);
    }
    if (last) break;
    h = s.next(h, e, after_rejection, r.x);
    after_rejection = false;
  }
  return end(Status::ok);
}

}  // namespace detail
}  // namespace eom
