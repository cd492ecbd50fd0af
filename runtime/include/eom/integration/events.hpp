// Events and hybrid motion for eom::integrate (integrate.hpp): event functions g(t, q, v[, u, p])
// whose zeros are located on each step's own continuous extension, with an action at each:
// record, terminate, or reset the state through a map (q, v) → (q⁺, v⁺) and continue. (v = q̇
// without a free joint; with one, v has nv = nq − 1 entries, eom/model/free_joint.hpp.)
//
//   auto height = [](double, const double* q, const double*) { return q[0]; };
//   auto bounce = [](double, double*, double* qd) { qd[0] *= -0.9; return true; };
//   const eom::Event events[]{{.g = height, .direction = eom::EventDirection::falling,
//                              .action = eom::EventAction::reset, .reset = bounce}};
//   std::array<eom::EventRecord<1>, 100> storage;   // the log: caller-owned, at most 100 kept
//   eom::EventLog<1> log(storage);
//   auto r = eom::integrate<K>(t0, t1, x0, u, p, opt, events, log, observer);
//   for (const auto& e : log.records()) ... e.index, e.t, e.x (before the action), e.x_after ...
//
// Location. After every accepted step [ta, tb] each g is sampled at EventSettings::samples
// equal subintervals of the step's continuous extension (the RK dense output, the Taylor
// polynomial, Radau's collocation polynomial, cubic Hermite for rk4 and variational; projected
// onto the constraints with Stabilization::projection), so that two sign changes inside one step
// are missed only when they fall between two samples. A sign change in the event's direction is
// then bracketed between two samples and located by Brent's method (zeroin: bisection
// safeguarded, so it converges for every continuous g) on g(t, x(t)) to a bracket of width
// ≤ 4ε|t| + 1e-300: the event time is then as exact as the continuous extension allows.
// The earliest crossing in a step acts first; the step is cut there when it terminates or resets.
//
// Signs. A crossing is a change of the sign of g between values that are not zero: g = 0 at a
// sample is not an event (it fires when g goes on to the other side). At t0, g(t0) = 0 is
// therefore no event (documented choice; the first definite sign after t0 is taken as g's sign),
// and g(t0) ≠ 0 starts the watch. After an event fires, g counts as being on the side it
// crossed to, even when the located time leaves g(t_event) a few ulps on the old side; a reset
// that leaves g within round-off of 0 does not fire the same event again at once.
//
// Simultaneous events: all events whose crossings lie within 2(4ε|T| + 1e-300) of the earliest,
// T, fire at T, each logged (in index order) with the same state. If any of them terminates, the
// integration stops at T with the state before any reset (Status::ok, result.event = the
// lowest-indexed terminating event). Otherwise their reset maps are applied in index order, each
// to the previous one's output, and the method restarts from (T, x⁺): a fresh start for the
// adaptive methods (their step-size choice included), equal steps of at most opt.step over
// [T, t1] for the fixed-step methods. Constrained models with projection project x⁺.
//
// Observer: without output_times it sees (t0, x0), every accepted step's end up to an event
// that cuts a step, (T, x⁻) there and, after a reset, (T, x⁺) as the next start. With
// output_times it sees exactly those times up to a terminating event (times at a reset instant
// get x⁺). Record-only events cut nothing: they are in the log only.
//
// Failures (result.status, result.event = the event, result.t = the time):
//  * g not finite at a sample or during location → Status::event_not_finite, at that time;
//  * a reset map returning false or a non-finite state, or a quaternion (free joint) it moved
//    off the unit sphere by more than quaternion_norm_tolerance → Status::event_reset_failed,
//    result.x the state before it (a quaternion within the tolerance is normalized);
//  * chattering: more than EventSettings::chattering_resets resets within
//    chattering_resets / max_reset_rate units of time (a Zeno bounce, or a reset that fires the
//    event again at once) → Status::event_chattering at the last of them;
//  * more than max_events_per_step events located in one step → event_chattering too.
// None of them hangs: every loop is bounded.
//
// Memory: nothing is allocated. The events are the caller's (std::span<const Event>, at most
// max_events of them); their functions are held by reference (EventFunction, ResetMap: a named
// callable must outlive the call; a captureless lambda may be a temporary); the log is the
// caller's storage with its size as the stated maximum: events beyond it still act and are
// counted by EventLog::dropped().
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <span>
#include <type_traits>
#include <utility>

#include "eom/integration/adaptive.hpp"
#include "eom/integration/state.hpp"

namespace eom {

enum class EventDirection {
  rising,   // g goes from < 0 to > 0
  falling,  // g goes from > 0 to < 0
  both,
};

enum class EventAction {
  record,     // log it and go on
  terminate,  // log it and stop there
  reset,      // log it, map the state through Event::reset, and go on from there
};

// A non-owning reference to an event function: any callable g(t, q, q̇, u, p) → double or
// g(t, q, q̇) → double. Held by reference (it must outlive the integration), except a
// captureless lambda or a function, which is held as a function pointer and may be a temporary.
class EventFunction {
 public:
  EventFunction() = default;
  template <class F>
    requires(!std::same_as<std::remove_cvref_t<F>, EventFunction>)
  EventFunction(F&& f) noexcept {  // NOLINT: implicit by design
    using D = std::remove_cvref_t<F>;
    if constexpr (std::is_convertible_v<D, double (*)(double, const double*, const double*,
                                                      const double*, const double*)>) {
      fp5_ = f;
    } else if constexpr (std::is_convertible_v<D, double (*)(double, const double*, const double*)>) {
      fp3_ = f;
    } else {
      static_assert(std::is_lvalue_reference_v<F>,
                    "an event function that captures must be a named object that outlives the "
                    "integration (it is held by reference)");
      object_ = const_cast<void*>(static_cast<const void*>(std::addressof(f)));
      call_ = [](void* o, double t, const double* q, const double* qd, const double* u,
                 const double* p) -> double {
        D& g = *static_cast<D*>(o);
        if constexpr (std::is_invocable_v<D&, double, const double*, const double*, const double*,
                                          const double*>)
          return g(t, q, qd, u, p);
        else
          return g(t, q, qd);
      };
    }
  }
  explicit operator bool() const noexcept { return fp5_ || fp3_ || call_; }
  double operator()(double t, const double* q, const double* qd, const double* u,
                    const double* p) const noexcept {
    if (fp5_) return fp5_(t, q, qd, u, p);
    if (fp3_) return fp3_(t, q, qd);
    return call_(object_, t, q, qd, u, p);
  }

 private:
  double (*fp5_)(double, const double*, const double*, const double*, const double*) = nullptr;
  double (*fp3_)(double, const double*, const double*) = nullptr;
  double (*call_)(void*, double, const double*, const double*, const double*, const double*) = nullptr;
  void* object_ = nullptr;
};

// A non-owning reference to a reset map: any callable reset(t, q, v, u, p) → bool or
// reset(t, q, v) → bool that overwrites q and v (nq and nv values) with q⁺, v⁺; false = failed.
// Held like EventFunction.
class ResetMap {
 public:
  ResetMap() = default;
  template <class F>
    requires(!std::same_as<std::remove_cvref_t<F>, ResetMap>)
  ResetMap(F&& f) noexcept {  // NOLINT: implicit by design
    using D = std::remove_cvref_t<F>;
    if constexpr (std::is_convertible_v<D, bool (*)(double, double*, double*, const double*,
                                                    const double*)>) {
      fp5_ = f;
    } else if constexpr (std::is_convertible_v<D, bool (*)(double, double*, double*)>) {
      fp3_ = f;
    } else {
      static_assert(std::is_lvalue_reference_v<F>,
                    "a reset map that captures must be a named object that outlives the "
                    "integration (it is held by reference)");
      object_ = const_cast<void*>(static_cast<const void*>(std::addressof(f)));
      call_ = [](void* o, double t, double* q, double* qd, const double* u, const double* p) -> bool {
        D& g = *static_cast<D*>(o);
        if constexpr (std::is_invocable_v<D&, double, double*, double*, const double*, const double*>)
          return g(t, q, qd, u, p);
        else
          return g(t, q, qd);
      };
    }
  }
  explicit operator bool() const noexcept { return fp5_ || fp3_ || call_; }
  bool operator()(double t, double* q, double* qd, const double* u, const double* p) const noexcept {
    if (fp5_) return fp5_(t, q, qd, u, p);
    if (fp3_) return fp3_(t, q, qd);
    return call_(object_, t, q, qd, u, p);
  }

 private:
  bool (*fp5_)(double, double*, double*, const double*, const double*) = nullptr;
  bool (*fp3_)(double, double*, double*) = nullptr;
  bool (*call_)(void*, double, double*, double*, const double*, const double*) = nullptr;
  void* object_ = nullptr;
};

struct Event {
  EventFunction g;
  EventDirection direction = EventDirection::both;
  EventAction action = EventAction::record;
  ResetMap reset{};  // EventAction::reset only
};

// Settings of the event handling (IntegrationOptions::event_settings).
struct EventSettings {
  int samples = 8;                 // subintervals of each step at which every g is sampled (>= 1)
  double max_reset_rate = 1e6;     // resets per unit of time beyond which the motion chatters
  int chattering_resets = 10;      // ... measured over this many resets (2..64)
  int max_events_per_step = 1000;  // events located in one step before giving up (chattering)
};

inline constexpr std::size_t max_events = 64;  // events per integration

// One event: which (the index into the events given), when, the state there (before the
// action) and after all actions at that instant (x_after = x unless an event there resets).
template <int nq, int nv = nq> struct EventRecord {
  int index = -1;
  double t = 0;
  StateOf<nq, nv> x{}, x_after{};
};

// The caller's storage for the events of one integration; its size is the stated maximum.
// Events beyond it are not stored but still act, and are counted.
template <int nq, int nv = nq> class EventLog {
 public:
  using Record = EventRecord<nq, nv>;
  EventLog() = default;
  explicit EventLog(std::span<Record> storage) noexcept : storage_(storage) {}
  std::span<const Record> records() const noexcept { return storage_.first(size_); }
  std::size_t size() const noexcept { return size_; }
  std::size_t capacity() const noexcept { return storage_.size(); }
  std::size_t dropped() const noexcept { return dropped_; }
  void clear() noexcept { size_ = dropped_ = 0; }
  // Appends; a pointer to the stored record, or null when full (then counted as dropped).
  Record* add(const Record& e) noexcept {
    if (size_ < storage_.size()) {
      storage_[size_] = e;
      return &storage_[size_++];
    }
    ++dropped_;
    return nullptr;
  }

 private:
  std::span<Record> storage_{};
  std::size_t size_ = 0, dropped_ = 0;
};

namespace detail {

// The width to which an event time is located: 4ε|t| + tiny.
inline double event_time_tolerance(double t) noexcept {
  return 4 * std::numeric_limits<double>::epsilon() * std::abs(t) + 1e-300;
}

// Brent's zeroin (Brent 1973, ch. 4) for a root of f in [a, b] with f(a), f(b) of opposite
// signs (neither zero): inverse quadratic or secant steps, bisection whenever they would not
// shrink the bracket fast enough, so it converges for every continuous f. Stops when the bracket
// is ≤ 4ε|b| + tol wide (or f(b) = 0), or after max_iterations, returning the bracket's end with
// the smaller |f|. f returns false (with a non-finite value) to abort: returns false.
template <class F>
bool brent_root(F&& f, double a, double fa, double b, double fb, double tol, double& root,
                int max_iterations = 200) noexcept {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  double c = a, fc = fa, d = b - a, e = d;
  for (int it = 0; it < max_iterations; ++it) {
    if ((fb > 0) == (fc > 0)) {  // keep the root between b and c
      c = a, fc = fa;
      d = e = b - a;
    }
    if (std::abs(fc) < std::abs(fb)) {  // b is the best estimate
      a = b, b = c, c = a;
      fa = fb, fb = fc, fc = fa;
    }
    const double tol1 = 2 * eps * std::abs(b) + 0.5 * tol, m = 0.5 * (c - b);
    if (std::abs(m) <= tol1 || fb == 0) {
      root = b;
      return true;
    }
    if (std::abs(e) >= tol1 && std::abs(fa) > std::abs(fb)) {  // interpolate
      double pp, q, s = fb / fa;
      if (a == c) {  // secant
        pp = 2 * m * s;
        q = 1 - s;
      } else {  // inverse quadratic
        const double qa = fa / fc, r = fb / fc;
        pp = s * (2 * m * qa * (qa - r) - (b - a) * (r - 1));
        q = (qa - 1) * (r - 1) * (s - 1);
      }
      if (pp > 0) q = -q; else pp = -pp;
      if (2 * pp < std::min(3 * m * q - std::abs(tol1 * q), std::abs(e * q))) {
        e = d;
        d = pp / q;
      } else {
        d = e = m;  // bisect
      }
    } else {
      d = e = m;
    }
    a = b, fa = fb;
    b += std::abs(d) > tol1 ? d : (m > 0 ? tol1 : -tol1);
    if (!f(b, fb)) {
      root = b;
      return false;
    }
  }
  root = b;
  return true;
}

inline int sign_of(double v) noexcept { return v > 0 ? 1 : v < 0 ? -1 : 0; }

inline bool direction_matches(EventDirection d, int new_sign) noexcept {
  return d == EventDirection::both || (d == EventDirection::rising) == (new_sign > 0);
}

// Watches the events over the steps of one method run (or several, after resets), owns the
// output to the user's observer, and tells the method when to stop (StepMonitor in
// adaptive.hpp). integrate() reads the outcome: stop reason, time, state, event.
template <Dynamics K, class Observer> class EventMonitor {
 public:
  static constexpr int n = K::nq;
  using State = StateFor<K>;
  enum class Outcome { running, finished, terminated, reset, failed };

  EventMonitor(std::span<const Event> events, EventLog<n, nv_of<K>>& log,
               const EventSettings& settings,
               std::span<const double> output_times, double t1, const double* u, const double* p,
               Observer& observer) noexcept
      : events_(events), log_(log), settings_(settings), times_(output_times), t1_(t1), u_(u),
        p_(p), observer_(observer) {}

  Outcome outcome() const noexcept { return outcome_; }
  Status status() const noexcept { return status_; }
  int event() const noexcept { return event_; }
  double t() const noexcept { return t_stop_; }
  const State& x() const noexcept { return x_stop_; }
  void clear_reset() noexcept { outcome_ = Outcome::running; }

  // The start of a run: the first (t0) or a restart after a reset (the signs are set already).
  bool start(double t, const State& x) noexcept {
    emit_through(t, x);
    observer_plain(t, x);
    if (started_) return true;
    started_ = true;
    for (std::size_t i = 0; i < events_.size(); ++i) {
      const double v = g(i, t, x);
      if (!std::isfinite(v)) return fail(Status::event_not_finite, static_cast<int>(i), t, x);
      sign_[i] = sign_of(v);
      value_[i] = v;
    }
    return true;
  }

  // After an accepted step [ta, tb]; interpolate(t, x) is its continuous extension.
  template <class Interpolate>
  bool step(double ta, const State&, double tb, const State& xb, Interpolate&& interpolate) noexcept {
    double from = ta;
    auto state_at = [&](double s, State& x) {
      if (s >= tb) x = xb; else interpolate(s, x);
    };
    for (int round = 0;; ++round) {
      if (round >= settings_.max_events_per_step)
        return fail(Status::event_chattering, last_fired_, from, xb);
      // Sample [from, tb] until a subinterval holds a crossing in an event's direction.
      const int k_max = std::max(1, settings_.samples);
      std::array<int, max_events> walk_sign;
      std::array<double, max_events> left_t, left_v, right_t, right_v;
      std::array<bool, max_events> bracketed{};
      bool any = false;
      for (std::size_t i = 0; i < events_.size(); ++i) {
        walk_sign[i] = sign_[i];
        left_t[i] = from;
        left_v[i] = value_[i];
      }
      State xs;
      for (int k = 1; k <= k_max && !any; ++k) {
        const double s = k == k_max ? tb : from + (tb - from) * k / k_max;
        state_at(s, xs);
        for (std::size_t i = 0; i < events_.size(); ++i) {
          const double v = g(i, s, xs);
          if (!std::isfinite(v)) return fail(Status::event_not_finite, static_cast<int>(i), s, xs);
          const int sv = sign_of(v);
          if (sv == 0) continue;
          if (k == 1 && zoom_[i] && sv == walk_sign[i]) {
            // g fired here and the state was reset: an excursion to the old side that ends
            // before the first sample (the next bounce of a ball late in a Zeno sequence) is
            // looked for by halving towards `from`, down to 8 location tolerances.
            const double floor = 8 * event_time_tolerance(from);
            State xz;
            for (double d = 0.5 * (s - from); d > floor; d *= 0.5) {
              state_at(from + d, xz);
              const double vz = g(i, from + d, xz);
              if (!std::isfinite(vz)) return fail(Status::event_not_finite, static_cast<int>(i), from + d, xz);
              if (sign_of(vz) == -sv) {
                left_t[i] = from + d, left_v[i] = vz, walk_sign[i] = -sv;
                break;
              }
            }
          }
          if (walk_sign[i] != 0 && sv != walk_sign[i] && sign_of(left_v[i]) == walk_sign[i] &&
              direction_matches(events_[i].direction, sv)) {
            bracketed[i] = true;
            right_t[i] = s, right_v[i] = v;
            any = true;
          } else {
            left_t[i] = s, left_v[i] = v;
          }
          walk_sign[i] = sv;
        }
        if (k == 1) zoom_.fill(false);
      }
      if (!any) {  // nothing fires in [from, tb]: the step stands
        for (std::size_t i = 0; i < events_.size(); ++i) {
          sign_[i] = walk_sign[i];
          value_[i] = left_v[i];
        }
        emit_before(tb, interpolate);
        emit_through(tb, xb);
        observer_plain(tb, xb);
        return true;
      }
      // Locate each bracketed crossing; the earliest (and those simultaneous with it) fire.
      std::array<double, max_events> root;
      double first = tb;
      for (std::size_t i = 0; i < events_.size(); ++i) {
        if (!bracketed[i]) continue;
        bool finite = true;
        double bad_t = 0;
        auto f = [&](double s, double& v) {
          State x;
          state_at(s, x);
          v = g(i, s, x);
          finite = std::isfinite(v);
          bad_t = s;
          return finite;
        };
        const bool ok = brent_root(f, left_t[i], left_v[i], right_t[i], right_v[i], 1e-300, root[i]);
        if (!ok || !finite) {
          State x;
          state_at(bad_t, x);
          return fail(Status::event_not_finite, static_cast<int>(i), bad_t, x);
        }
        first = std::min(first, root[i]);
      }
      const double T = first, width = 2 * event_time_tolerance(T);
      State xT;
      state_at(T, xT);
      emit_before(T, interpolate);
      bool terminate = false, reset = false;
      int terminating = -1;
      std::array<bool, max_events> fires{};
      for (std::size_t i = 0; i < events_.size(); ++i) {
        fires[i] = bracketed[i] && root[i] <= T + width;
        if (!fires[i]) continue;
        last_fired_ = static_cast<int>(i);
        if (events_[i].action == EventAction::terminate && !terminate) {
          terminate = true;
          terminating = static_cast<int>(i);
        }
        reset = reset || events_[i].action == EventAction::reset;
      }
      // The state after the actions (terminate: none; else the resets in index order).
      State after = xT;
      int failed_reset = -1;
      if (!terminate && reset)
        for (std::size_t i = 0; i < events_.size() && failed_reset < 0; ++i)
          if (fires[i] && events_[i].action == EventAction::reset) {
            const bool ok = events_[i].reset && events_[i].reset(T, after.data(), after.data() + n, u_, p_);
            bool finite = ok && unit_quaternion<K>(after);
            for (double v : after) finite = finite && std::isfinite(v);
            if (!finite) failed_reset = static_cast<int>(i);
            normalize_state<K>(after);
          }
      for (std::size_t i = 0; i < events_.size(); ++i)
        if (fires[i]) log_.add({static_cast<int>(i), T, xT, failed_reset >= 0 ? xT : after});
      if (failed_reset >= 0) return fail(Status::event_reset_failed, failed_reset, T, xT);
      if (terminate) {
        emit_through(T, xT);
        observer_plain(T, xT);
        outcome_ = Outcome::terminated, event_ = terminating, t_stop_ = T, x_stop_ = xT;
        return false;
      }
      // The signs at T: the fired events are on the side they crossed to; the others as g says.
      for (std::size_t i = 0; i < events_.size(); ++i) {
        const double v = g(i, T, after);
        if (!std::isfinite(v)) return fail(Status::event_not_finite, static_cast<int>(i), T, after);
        if (fires[i]) {  // g(T) may still be a few ulps on the old side: then it is not a bracket end
          sign_[i] = sign_of(right_v[i]);
          value_[i] = v;
        } else if (v != 0) {
          sign_[i] = sign_of(v);
          value_[i] = v;
        }
      }
      if (reset) {
        for (std::size_t i = 0; i < events_.size(); ++i) zoom_[i] = fires[i];
        if (chattering(T)) return fail(Status::event_chattering, last_fired_, T, after);
        observer_plain(T, xT);
        outcome_ = Outcome::reset, t_stop_ = T, x_stop_ = after;
        return false;
      }
      from = T;  // record only: look on in the rest of the step
    }
  }

  // Outputs at the end of the integration (a reset exactly at t1 leaves no run to make them).
  void finish(double t, const State& x) noexcept {
    emit_through(t, x);
    observer_plain(t, x);
  }

 private:
  double g(std::size_t i, double t, const State& x) const noexcept {
    return events_[i].g(t, x.data(), x.data() + n, u_, p_);
  }
  bool fail(Status s, int event, double t, const State& x) noexcept {
    outcome_ = Outcome::failed, status_ = s, event_ = event, t_stop_ = t, x_stop_ = x;
    return false;
  }
  // More than chattering_resets resets within chattering_resets / max_reset_rate?
  bool chattering(double t) noexcept {
    const int count = std::clamp(settings_.chattering_resets, 2, 64);
    recent_[resets_ % 64] = t;
    ++resets_;
    if (resets_ <= count) return false;
    const double oldest = recent_[(resets_ - 1 - count) % 64];
    return t - oldest < count / settings_.max_reset_rate;
  }
  // Without output times: the observer sees the step ends and event instants.
  void observer_plain(double t, const State& x) noexcept {
    if (times_.empty()) observer_(t, x);
  }
  // Output times before t from the continuous extension; at or before t from x.
  template <class Interpolate> void emit_before(double t, Interpolate& interpolate) noexcept {
    State x;
    for (; next_ < times_.size() && times_[next_] < t; ++next_) {
      interpolate(times_[next_], x);
      observer_(times_[next_], x);
    }
  }
  void emit_through(double t, const State& x) noexcept {
    const bool end = t >= t1_;
    for (; next_ < times_.size() && (times_[next_] <= t || end); ++next_) observer_(times_[next_], x);
  }

  std::span<const Event> events_;
  EventLog<n, nv_of<K>>& log_;
  const EventSettings& settings_;
  std::span<const double> times_;
  std::size_t next_ = 0;
  double t1_;
  const double *u_, *p_;
  Observer& observer_;
  std::array<int, max_events> sign_{};
  std::array<double, max_events> value_{};
  std::array<bool, max_events> zoom_{};
  std::array<double, 64> recent_{};
  long resets_ = 0;
  bool started_ = false;
  int last_fired_ = -1;
  Outcome outcome_ = Outcome::running;
  Status status_ = Status::ok;
  int event_ = -1;
  double t_stop_ = 0;
  State x_stop_{};
};

}  // namespace detail
}  // namespace eom
