// What the explicit Runge–Kutta pairs (dopri5.hpp, dop853.hpp) share: the linear combinations of
// stage derivatives k[j] that make up stage inputs, solutions, error estimates and dense output,
// and the step loop (explicit_rk below). The weights are a tableau's constexpr rows, passed as
// template arguments, so which of them vanish is known at compile time and the zeros of a sparse
// tableau cost nothing.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>

#include "eom/adaptive.hpp"

namespace eom::detail {

// Σⱼ w[j]·k[j][i], in the order of j, over the nonzero weights only.
template <const auto& w, std::size_t m, std::size_t S>
double weighted_sum(const std::array<std::array<double, m>, S>& k, std::size_t i) noexcept {
  constexpr std::size_t terms = std::min(S, std::size(w));
  double sum = 0;
  [&]<std::size_t... j>(std::index_sequence<j...>) {
    ((w[j] != 0 ? void(sum += w[j] * k[j][i]) : void()), ...);
  }(std::make_index_sequence<terms>{});
  return sum;
}

// out = x + h·Σⱼ w[j]·k[j]: a stage input or a solution.
template <const auto& w, std::size_t m, std::size_t S>
void advance(const std::array<double, m>& x, double h, const std::array<std::array<double, m>, S>& k,
             std::array<double, m>& out) noexcept {
  for (std::size_t i = 0; i < m; ++i) out[i] = x[i] + h * weighted_sum<w>(k, i);
}

// out = h·Σⱼ w[j]·k[j]: an error estimate or a dense-output coefficient.
template <const auto& w, std::size_t m, std::size_t S>
void scaled_sum(double h, const std::array<std::array<double, m>, S>& k,
                std::array<double, m>& out) noexcept {
  for (std::size_t i = 0; i < m; ++i) out[i] = h * weighted_sum<w>(k, i);
}

template <std::size_t m> bool all_finite(const std::array<double, m>& v) noexcept {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

// The step loop of an embedded explicit pair over any eom::Dynamics: start, stepping with error
// control, FSAL, projection, output (every accepted step, output times, or a StepMonitor such as
// the event handling of events.hpp). Step<m> holds the stages k (k[0] = f at the step's start)
// and the new solution x_new, and says:
//   order                          of the propagated solution (Hairer's starting step)
//   fsal                           the stage that is f at x_new (the next step's k[0])
//   exponent, min_factor, max_factor, cap_after_rejection
//                                  the controller: h·min(max, max(min, 0.9‖e‖^exponent)), not
//                                  growing right after a rejection when cap_after_rejection
//   attempt(f, t, h, x, opt)       the step's error norm (∞ when a stage fails)
//   complete(f, t, h, x, dense)    what an acceptable step still needs (FSAL stage, continuous
//                                  extension when dense); false rejects it
//   interpolate(θ, x)              the continuous extension at t + θh
template <template <std::size_t> class Step, Dynamics K, class Observer>
AdaptiveResult<K::nq> explicit_rk(double t0, double t1, const StateOf<K::nq>& x0, const double* u,
                                  const double* p, const AdaptiveOptions& opt, Observer&& observer,
                                  const Stabilization& stab) noexcept {
  constexpr int n = K::nq;
  using S = Step<2 * n>;
  AdaptiveResult<K::nq> r;
  r.t = t0;
  r.x = x0;
  if ((r.status = adaptive_start<K>(t0, t1, r.x, p, opt, stab)) != Status::ok) return r;

  auto f = [&](double t, const StateOf<n>& x, StateOf<n>& dx) {
    ++r.evaluations;
    return state_derivative<K>(t, x, u, p, dx, stab);
  };

  S s;
  double h = opt.initial_step;
  if (!f(r.t, r.x, s.k[0]) || (h == 0 && !starting_step(S::order, f, r.t, t1 - t0, r.x, s.k[0], opt, h))) {
    r.status = Status::singular_dynamics;
    return r;
  }
  constexpr bool monitored = StepMonitor<Observer, StateOf<n>>;
  OutputSchedule schedule(opt.output_times);
  if constexpr (monitored) {
    if (!observer.start(r.t, r.x)) return r;
  } else {
    schedule.start(r.t, r.x, observer);
  }
  bool after_rejection = false;
  while (r.t < t1) {
    if ((r.status = step_allowed(r, h, opt)) != Status::ok) return r;
    const bool last = r.t + h >= t1;
    if (last) h = t1 - r.t;
    const double t = r.t, t_end = last ? t1 : t + h;
    const double e = s.attempt(f, t, h, r.x, opt);
    // A step that failed (a stage, or the evaluations after it) or produced Inf/NaN is retried
    // smaller, which also steps around a singularity a large step jumped into; underflow stops it.
    if (!(e <= 1.0 && s.complete(f, t, h, r.x, monitored || schedule.interpolates_before(t_end)))) {
      ++r.rejected;
      after_rejection = true;
      h *= e <= 1.0 || !std::isfinite(e) ? 0.25 : std::max(S::min_factor, 0.9 * std::pow(e, S::exponent));
      continue;
    }
    const StateOf<n> x_start = r.x;
    r.t = t_end;
    r.x = s.x_new;
    s.k[0] = s.k[S::fsal];
    if ((r.status = project_accepted<K>(r.t, r.x, p, stab, f, s.k[0])) != Status::ok) return r;
    ++r.accepted;
    auto interpolate = [&](double t_out, StateOf<n>& x_out) {
      s.interpolate((t_out - t) / h, x_out);
      project_output<K>(x_out, p, stab);
    };
    if constexpr (monitored) {
      if (!observer.step(t, x_start, r.t, r.x, interpolate)) return r;
    } else {
      schedule.step(r.t, r.x, last, interpolate, observer);
    }
    const double growth = std::min(S::max_factor, std::max(S::min_factor, 0.9 * std::pow(std::max(e, 1e-10), S::exponent)));
    h *= S::cap_after_rejection && after_rejection ? std::min(1.0, growth) : growth;
    after_rejection = false;
  }
  return r;
}

}  // namespace eom::detail
