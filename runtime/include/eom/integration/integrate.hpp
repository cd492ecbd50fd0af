// One integration API over every method and anything that satisfies eom::Dynamics (generated
// Kernels or eom::Reference):
//
//   eom::IntegrationOptions opt;            // method, tolerances or step, stabilization, output
//   opt.method = eom::Method::dopri5;
//   auto r = eom::integrate<K>(t0, t1, x0, u, p, opt, observer);
//   if (r.status != eom::Status::ok) ... eom::to_string(r.status) ...
//
// The observer, any callable (t, const StateFor<K>& x), sees the state after every step, or with
// opt.output_times (dense output) at exactly those times. Every method validates its input before
// the first step, stops with a Status instead of returning NaN, and is bounded by max_steps. The
// per-method functions (rk4, dopri5, variational, ...) stay available for finer control; this is
// a thin dispatcher over them that adds dense output to the fixed-step methods.
//
// A method whose kernels the model was not generated with (variational needs mass_matrix,
// mass_matrix_dot, coriolis, potential_gradient and generalized_forces; radau5 needs
// forward_dynamics_derivatives; taylor and taylor_paper need taylor_coefficients) gives
// Status::method_unavailable, naming nothing else missing at run time; call the method's own
// function to get the compile-time error that names the kernel.
//
// A model with a free joint (eom/model/free_joint.hpp) runs on x = (q, v), nq + nv numbers, with
// q̇ = G(q) v and the quaternion normalized after every step and in every state handed out
// (state.hpp); an initial quaternion off the unit sphere by more than quaternion_norm_tolerance
// is Status::invalid_argument. Every method runs it except the variational one
// (Status::method_unavailable, see variational.hpp).
#pragma once

#include <cmath>
#include <limits>
#include <span>
#include <type_traits>

#include "eom/integration/adaptive.hpp"
#include "eom/integration/dop853.hpp"
#include "eom/integration/dopri5.hpp"
#include "eom/integration/events.hpp"
#include "eom/integration/radau5.hpp"
#include "eom/integration/rk4.hpp"
#include "eom/integration/stabilization.hpp"
#include "eom/integration/taylor.hpp"
#include "eom/integration/variational.hpp"

namespace eom {

enum class Method {
  rk4,          // classical Runge–Kutta, fixed step (the paper's method)
  dopri5,       // Dormand–Prince 5(4), adaptive, 4th-order dense output
  dop853,       // Dormand–Prince 8(5,3), adaptive, 7th-order dense output
  radau5,       // Radau IIA order 5, implicit, for stiff systems (needs forward_dynamics_derivatives)
  taylor,       // Taylor series, order and step from the tolerance (Jorba–Zou; needs taylor_coefficients)
  taylor_paper, // Taylor series, the paper's scheme: order 4, step from the exact 5th-order term
  variational,  // midpoint variational (symplectic) integrator with SHAKE/RATTLE, fixed step
};

constexpr const char* to_string(Method m) {
  switch (m) {
    case Method::rk4: return "rk4";
    case Method::dopri5: return "dopri5";
    case Method::dop853: return "dop853";
    case Method::radau5: return "radau5";
    case Method::taylor: return "taylor";
    case Method::taylor_paper: return "taylor_paper";
    case Method::variational: return "variational";
  }
  return "unknown";
}

constexpr bool is_fixed_step(Method m) { return m == Method::rk4 || m == Method::variational; }

struct IntegrationOptions {
  Method method = Method::dopri5;
  double step = 0;                   // fixed-step methods: required, > 0 (rounded so the steps
                                     // divide [t0, t1] evenly); adaptive: the initial step (0: auto)
  double rtol = 1e-8, atol = 1e-10;  // adaptive methods
  long max_steps = 1000000;          // steps (accepted + rejected) before Status::step_limit
  int taylor_order = 0;              // Method::taylor: a fixed order, or 0 to choose it from the tolerance
  Stabilization stabilization{};     // constrained models, explicit methods (see stabilization.hpp)
  // Dense output: when not empty, the observer is called at exactly these times (ascending,
  // within [t0, t1]) instead of after every step. Fixed-step methods interpolate by cubic
  // Hermite polynomials from the states and derivatives at the step ends (4th order, the order
  // of RK4; two extra evaluations per step that holds an output time).
  std::span<const double> output_times{};
  VariationalOptions variational{};  // Newton tolerance and iterations of the variational method
  // Method::taylor, taylor_paper: the kernel's workspace, so that nothing is allocated (see
  // "Memory" in taylor.hpp; eom::taylor_workspace_size<K> gives the size). Empty: allocated per
  // call.
  std::span<double> taylor_workspace{};
  // Event handling (the integrate() overload that takes events; see events.hpp).
  EventSettings event_settings{};
};

template <int nq, int nv = nq> using IntegrationResult = AdaptiveResult<nq, nv>;
template <class K> using IntegrationResultFor = AdaptiveResult<K::nq, nv_of<K>>;

namespace detail {

// x(s) on [ta, tb] from x, ẋ at both ends: the cubic Hermite interpolant (4th order).
template <int m>
void hermite(double ta, const std::array<double, m>& xa, const std::array<double, m>& fa, double tb,
             const std::array<double, m>& xb, const std::array<double, m>& fb, double s,
             std::array<double, m>& out) noexcept {
  const double h = tb - ta, th = (s - ta) / h;
  const double h00 = (1 + 2 * th) * (1 - th) * (1 - th), h10 = th * (1 - th) * (1 - th);
  const double h01 = th * th * (3 - 2 * th), h11 = th * th * (th - 1);
  for (int i = 0; i < m; ++i) out[i] = h00 * xa[i] + h10 * h * fa[i] + h01 * xb[i] + h11 * h * fb[i];
}

// The stabilization whose projection the fixed-step methods' interpolated states get: the one
// asked for, or for the variational method (which keeps the constraints itself and refuses
// one) projection at the default tolerance on a constrained model.
template <Dynamics K> Stabilization output_stabilization(Method method, const Stabilization& stab) noexcept {
  Stabilization s = stab;
  if constexpr (K::nc > 0)
    if (method == Method::variational) s.method = Stabilization::Method::projection;
  return s;
}

// Wraps an observer so that a fixed-step method's step ends become dense output at the requested
// times: x(t) on [ta, tb] from x, ẋ at both ends (cubic Hermite).
template <Dynamics K, class Observer> class HermiteOutput {
 public:
  static constexpr int m = K::nq + nv_of<K>;
  using State = StateFor<K>;
  HermiteOutput(std::span<const double> times, const double* u, const double* p,
                const Stabilization& stab, const Stabilization& output_stab, Observer& observer,
                long& evaluations) noexcept
      : schedule_(times), u_(u), p_(p), stab_(stab), output_stab_(output_stab), observer_(observer),
        evaluations_(evaluations) {}

  void operator()(double t, const State& x) noexcept {
    if (!started_) {
      started_ = true;
      schedule_.start(t, x, observer_);
    } else {
      bool have_derivatives = false;
      State fa, fb;
      auto interpolate = [&](double s, State& out) {
        if (!have_derivatives) {
          evaluations_ += 2;
          have_derivatives = true;
          // A failed evaluation leaves NaN in the interpolant, never a plausible wrong value.
          if (!state_derivative<K>(t_, x_, u_, p_, fa, stab_)) fa.fill(std::numeric_limits<double>::quiet_NaN());
          if (!state_derivative<K>(t, x, u_, p_, fb, stab_)) fb.fill(std::numeric_limits<double>::quiet_NaN());
        }
        hermite<m>(t_, x_, fa, t, x, fb, s, out);
        project_output<K>(out, p_, output_stab_);
      };
      schedule_.step(t, x, last_ && t >= t_end_, interpolate, observer_);
    }
    t_ = t;
    x_ = x;
  }
  void set_end(double t1) noexcept { last_ = true, t_end_ = t1; }

 private:
  OutputSchedule schedule_;
  const double *u_, *p_;
  const Stabilization& stab_;
  Stabilization output_stab_;
  Observer& observer_;
  long& evaluations_;
  bool started_ = false, last_ = false;
  double t_ = 0, t_end_ = 0;
  State x_{};
};

// Hands a fixed-step method's steps to an event monitor (events.hpp) with the cubic Hermite
// interpolant of each step (one extra evaluation per step: ẋ at the step's end, which is the
// next step's start), and stops the method (rk4.hpp: StoppingObserver) when the monitor says so.
template <Dynamics K, class Monitor> class FixedStepMonitor {
 public:
  static constexpr int m = K::nq + nv_of<K>;
  using State = StateFor<K>;
  FixedStepMonitor(Monitor& monitor, const double* u, const double* p, const Stabilization& stab,
                   const Stabilization& output_stab, long& evaluations) noexcept
      : monitor_(monitor), u_(u), p_(p), stab_(stab), output_stab_(output_stab),
        evaluations_(evaluations) {}

  void operator()(double t, const State& x) noexcept {
    State f;
    ++evaluations_;
    // A failed evaluation leaves NaN in the interpolant, never a plausible wrong value.
    if (!state_derivative<K>(t, x, u_, p_, f, stab_)) f.fill(std::numeric_limits<double>::quiet_NaN());
    if (!started_) {
      started_ = true;
      stopped_ = !monitor_.start(t, x);
    } else {
      auto interpolate = [&](double s, State& out) {
        hermite<m>(t_, x_, f_, t, x, f, s, out);
        project_output<K>(out, p_, output_stab_);
      };
      stopped_ = !monitor_.step(t_, x_, t, x, interpolate);
    }
    t_ = t, x_ = x, f_ = f;
  }
  bool stopped() const noexcept { return stopped_; }

 private:
  Monitor& monitor_;
  const double *u_, *p_;
  const Stabilization& stab_;
  Stabilization output_stab_;
  long& evaluations_;
  bool started_ = false, stopped_ = false;
  double t_ = 0;
  State x_{}, f_{};
};

// The number of equal steps of at most `step` that cover [t0, t1]; 0 when impossible.
inline long fixed_step_count(double t0, double t1, double step) noexcept {
  if (!(std::isfinite(step) && step > 0 && t1 > t0)) return 0;
  const double count = std::ceil((t1 - t0) / step * (1 - 1e-12));
  return count >= 1 && count < 9e15 ? static_cast<long>(count) : 0;
}

}  // namespace detail

namespace detail {
template <Dynamics K, class Observer>
IntegrationResultFor<K> integrate_with(double t0, double t1, const StateFor<K>& x0, const double* u,
                                       const double* p, const IntegrationOptions& opt,
                                       Observer&& observer) noexcept {
  using State = StateFor<K>;
  IntegrationResultFor<K> r;
  r.t = t0;
  r.x = x0;
  AdaptiveOptions adaptive;
  adaptive.rtol = opt.rtol;
  adaptive.atol = opt.atol;
  adaptive.initial_step = opt.step;
  adaptive.max_steps = opt.max_steps;
  adaptive.output_times = opt.output_times;

  if (is_fixed_step(opt.method)) {
    if (opt.method == Method::variational && nv_of<K> != K::nq) {
      r.status = Status::method_unavailable;  // a free joint: see variational.hpp
      return r;
    }
    // Validate like the adaptive methods (tolerances are unused but must not be nonsense), then
    // the step itself.
    const long steps = detail::fixed_step_count(t0, t1, opt.step);
    if (!detail::adaptive_input_ok<K>(t0, t1, x0, adaptive) || steps == 0) {
      r.status = Status::invalid_argument;
      return r;
    }
    if (steps > opt.max_steps) {  // refuse up front rather than run out mid-way
      r.status = Status::step_limit;
      return r;
    }
    long evaluations = 0;
    const Stabilization output_stab = detail::output_stabilization<K>(opt.method, opt.stabilization);
    detail::HermiteOutput<K, Observer> dense(opt.output_times, u, p, opt.stabilization, output_stab,
                                             observer, evaluations);
    dense.set_end(t1);
    using Monitor = std::remove_reference_t<Observer>;
    auto step_observer = [&] {
      if constexpr (detail::StepMonitor<Monitor, State>)  // events: see events.hpp
        return detail::FixedStepMonitor<K, Monitor>(observer, u, p, opt.stabilization, output_stab,
                                                    evaluations);
      else
        return [&](double t, const State& x) {
          if (opt.output_times.empty())
            observer(t, x);
          else
            dense(t, x);
        };
    }();
    if (opt.method == Method::rk4) {
      const auto s = rk4<K>(t0, t1, steps, x0, u, p, step_observer, opt.stabilization);
      r.status = s.status, r.t = s.t, r.x = s.x, r.accepted = s.steps;
      r.evaluations = 4 * s.steps + evaluations;
      return r;
    }
    if constexpr (LagrangianDynamics<K>) {
      if (opt.stabilization.method != Stabilization::Method::none) {
        r.status = Status::invalid_argument;  // it keeps the constraints itself (SHAKE/RATTLE)
        return r;
      }
      const auto s = variational<K>(t0, t1, steps, x0, u, p, step_observer, opt.variational);
      r.status = s.status, r.t = s.t, r.x = s.x, r.accepted = s.steps;
      r.evaluations = s.evaluations + evaluations;
    } else {
      r.status = Status::method_unavailable;
    }
    return r;
  }
  switch (opt.method) {
    case Method::dopri5:
      return dopri5<K>(t0, t1, x0, u, p, adaptive, observer, opt.stabilization);
    case Method::dop853:
      return dop853<K>(t0, t1, x0, u, p, adaptive, observer, opt.stabilization);
    case Method::radau5:
      // its Newton matrix's tangent map is the free joint's: not yet for ball joints
      if constexpr (DifferentiableDynamics<K> && layout_of<K>().free_joint_only())
        return radau5<K>(t0, t1, x0, u, p, adaptive, observer, opt.stabilization);
      r.status = Status::method_unavailable;
      return r;
    case Method::taylor:
    case Method::taylor_paper:
      if constexpr (TaylorDynamics<K>) {
        TaylorOptions t;
        t.scheme = opt.method == Method::taylor ? TaylorOptions::Scheme::jorba_zou
                                                : TaylorOptions::Scheme::paper;
        t.order = opt.taylor_order;
        t.workspace = opt.taylor_workspace;
        return eom::taylor<K>(t0, t1, x0, u, p, adaptive, t, observer, opt.stabilization);
      }
      r.status = Status::method_unavailable;
      return r;
    default:
      r.status = Status::invalid_argument;
      return r;
  }
}
}  // namespace detail

// Why eom::integrate<K> refuses these arguments (Status::invalid_argument): which argument and
// what is wrong with it, as a string literal ("step: rk4 takes a fixed step: give step > 0"), or
// nullptr when it takes them. eom::integrate puts it in its result's `message`; the Python
// module raises ValueError with it.
template <Dynamics K>
const char* integration_argument_problem(double t0, double t1, const StateFor<K>& x0,
                                         const IntegrationOptions& opt) noexcept {
  using Stab = Stabilization::Method;
  switch (opt.method) {
    case Method::rk4: case Method::dopri5: case Method::dop853: case Method::radau5:
    case Method::taylor: case Method::taylor_paper: case Method::variational: break;
    default: return "method: not one of eom::Method's values";
  }
  AdaptiveOptions adaptive;
  adaptive.rtol = opt.rtol, adaptive.atol = opt.atol, adaptive.initial_step = opt.step;
  adaptive.max_steps = opt.max_steps, adaptive.output_times = opt.output_times;
  if (const char* problem = detail::adaptive_input_problem<K>(t0, t1, x0, adaptive)) return problem;
  if (K::nc == 0 && opt.stabilization.method != Stab::none)
    return "stabilization: the model has no constraints (nc = 0): give none";
  if (is_fixed_step(opt.method)) {
    if (!(opt.step > 0))
      return opt.method == Method::rk4
                 ? "step: rk4 takes a fixed step: give step > 0 (e.g. 1e-3), or an adaptive method"
                 : "step: variational takes a fixed step: give step > 0 (e.g. 1e-3)";
    if (detail::fixed_step_count(t0, t1, opt.step) == 0)
      return "step: too small for the time span [t0, t1] (more than 9e15 steps)";
    if (opt.method == Method::variational) {
      if (opt.stabilization.method != Stab::none)
        return "stabilization: the variational method keeps the constraints itself: give none";
      const VariationalOptions& v = opt.variational;
      if (!(std::isfinite(v.tolerance) && v.tolerance > 0 && v.max_iterations >= 1 &&
            std::isfinite(v.initial_tolerance) && v.initial_tolerance >= 0))
        return "variational: tolerance must be > 0, max_iterations >= 1, initial_tolerance >= 0";
      const double h = (t1 - t0) / static_cast<double>(detail::fixed_step_count(t0, t1, opt.step));
      if (!(t0 + h > t0)) return "step: too small to advance t0";
    }
  }
  if (opt.method == Method::taylor || opt.method == Method::taylor_paper) {
    if (opt.stabilization.method == Stab::baumgarte)
      return "stabilization: the Taylor methods take projection, not baumgarte";
    if constexpr (TaylorDynamics<K>) {
      const int fixed = opt.taylor_order, max_order = K::taylor_max_order;
      if (opt.method == Method::taylor_paper ? !(fixed >= 0 && fixed + 1 <= max_order)
                                             : !(fixed == 0 || (fixed >= 2 && fixed <= max_order)))
        return opt.method == Method::taylor_paper
                   ? "taylor_order: taylor_paper takes 0 (its order 4) or an order below the "
                     "model's taylor_max_order"
                   : "taylor_order: taylor takes 0 (chosen from the tolerance) or 2 ... the "
                     "model's taylor_max_order";
      if (!opt.taylor_workspace.empty()) {
        TaylorOptions t;
        t.scheme = opt.method == Method::taylor ? TaylorOptions::Scheme::jorba_zou
                                                : TaylorOptions::Scheme::paper;
        t.order = fixed;
        if (opt.taylor_workspace.size() < taylor_workspace_size<K>(adaptive, t))
          return "taylor_workspace: smaller than eom::taylor_workspace_size<K>(options) doubles";
      }
    }
  }
  return nullptr;
}

// With Status::singular_dynamics or step_size_underflow the result says why the dynamics failed
// (failure, failure_velocity; AdaptiveResult): the diagnosis of their last failure during this
// call (since the last accepted step of an adaptive method; eom/model/diagnosis.hpp). With
// Status::invalid_argument, `message` says which argument was refused and why
// (integration_argument_problem).
template <Dynamics K, class Observer>
IntegrationResultFor<K> integrate(double t0, double t1, const StateFor<K>& x0, const double* u,
                                  const double* p, const IntegrationOptions& opt,
                                  Observer&& observer) noexcept {
  detail::last_dynamics_failure() = {};
  IntegrationResultFor<K> r = detail::integrate_with<K>(t0, t1, x0, u, p, opt, observer);
  if (r.status == Status::singular_dynamics || r.status == Status::step_size_underflow) {
    r.failure = detail::last_dynamics_failure().failure;
    r.failure_velocity = detail::last_dynamics_failure().velocity;
  }
  if (r.status == Status::invalid_argument && r.message == nullptr) {
    r.message = integration_argument_problem<K>(t0, t1, x0, opt);
    if (r.message == nullptr) r.message = "an argument was refused (eom::integrate found no reason to name)";
  }
  return r;
}

// Without an observer: the result alone.
template <Dynamics K>
IntegrationResultFor<K> integrate(double t0, double t1, const StateFor<K>& x0, const double* u,
                                  const double* p, const IntegrationOptions& opt) noexcept {
  return integrate<K>(t0, t1, x0, u, p, opt, [](double, const StateFor<K>&) {});
}

namespace detail {
inline bool events_ok(std::span<const Event> events, const EventSettings& s) noexcept {
  bool ok = events.size() <= max_events && s.samples >= 1 && s.samples <= 1000 &&
            std::isfinite(s.max_reset_rate) && s.max_reset_rate > 0 && s.chattering_resets >= 2 &&
            s.chattering_resets <= 64 && s.max_events_per_step >= 1;
  for (const Event& e : events)
    ok = ok && static_cast<bool>(e.g) && (e.action != EventAction::reset || static_cast<bool>(e.reset)) &&
         (e.direction == EventDirection::rising || e.direction == EventDirection::falling ||
          e.direction == EventDirection::both) &&
         (e.action == EventAction::record || e.action == EventAction::terminate ||
          e.action == EventAction::reset);
  return ok;
}
}  // namespace detail

// With events (events.hpp): as above, and each event of `events` is located on the steps'
// continuous extensions and acts (record, terminate, reset); every event is appended to `log`
// (the caller's storage). A terminating event ends the integration with Status::ok at its time
// (result.t, result.x, result.event); a reset restarts the method from the event with the state
// the reset map returns. Bad events or settings (a missing function or reset map, more than
// max_events, settings out of range) → Status::invalid_argument before any step. Without
// events this is the overload above. Allocation-free like it.
template <Dynamics K, class Observer>
IntegrationResultFor<K> integrate(double t0, double t1, const StateFor<K>& x0, const double* u,
                                  const double* p, const IntegrationOptions& opt,
                                  std::span<const Event> events,
                                  EventLog<K::nq, nv_of<K>>& log, Observer&& observer) noexcept {
  if (events.empty()) return integrate<K>(t0, t1, x0, u, p, opt, observer);
  IntegrationResultFor<K> total;
  total.t = t0;
  total.x = x0;
  AdaptiveOptions check;
  check.output_times = opt.output_times;
  if (const char* problem = detail::adaptive_input_problem<K>(t0, t1, x0, check)) {
    total.status = Status::invalid_argument, total.message = problem;
    return total;
  }
  if (!detail::events_ok(events, opt.event_settings)) {
    total.status = Status::invalid_argument;
    total.message = "events, event_settings: an event without its function (or a reset without "
                    "its map), more than max_events events, or settings out of range (events.hpp)";
    return total;
  }
  using O = std::remove_reference_t<Observer>;
  using Monitor = detail::EventMonitor<K, O>;
  Monitor monitor(events, log, opt.event_settings, opt.output_times, t1, u, p, observer);
  IntegrationOptions run = opt;
  run.output_times = {};  // the monitor makes the output
  double t = t0;
  StateFor<K> x = x0;
  for (;;) {
    run.max_steps = opt.max_steps - (total.accepted + total.rejected);
    if (run.max_steps <= 0) {
      total.status = Status::step_limit;
      return total;
    }
    const auto r = integrate<K>(t, t1, x, u, p, run, monitor);
    total.accepted += r.accepted;
    total.rejected += r.rejected;
    total.evaluations += r.evaluations;
    total.status = r.status, total.t = r.t, total.x = r.x;
    total.failure = r.failure, total.failure_velocity = r.failure_velocity;
    total.message = r.message;
    switch (monitor.outcome()) {
      case Monitor::Outcome::running:
      case Monitor::Outcome::finished:
        return total;  // the end, or the method's own failure
      case Monitor::Outcome::terminated:
        total.status = Status::ok, total.t = monitor.t(), total.x = monitor.x();
        total.event = monitor.event();
        return total;
      case Monitor::Outcome::failed:
        total.status = monitor.status(), total.t = monitor.t(), total.x = monitor.x();
        total.event = monitor.event();
        return total;
      case Monitor::Outcome::reset:
        break;
    }
    monitor.clear_reset();
    t = monitor.t();
    x = monitor.x();
    total.t = t, total.x = x;
    // A reset at (or within round-off of) the end leaves no time to integrate: x⁺ is the end.
    if (t1 - t <= 64 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::abs(t1))) {
      monitor.finish(t1, x);
      total.status = Status::ok, total.t = t1;
      return total;
    }
  }
}

// With events, without an observer.
template <Dynamics K>
IntegrationResultFor<K> integrate(double t0, double t1, const StateFor<K>& x0, const double* u,
                                  const double* p, const IntegrationOptions& opt,
                                  std::span<const Event> events,
                                  EventLog<K::nq, nv_of<K>>& log) noexcept {
  return integrate<K>(t0, t1, x0, u, p, opt, events, log, [](double, const StateFor<K>&) {});
}

}  // namespace eom
