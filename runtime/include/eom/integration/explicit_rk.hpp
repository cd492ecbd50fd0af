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

#include "eom/integration/adaptive.hpp"

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

// An embedded explicit pair as the stepper of adaptive_steps (adaptive.hpp). Step<m> holds the
// stages k (k[0] = f at the step's start) and the new solution x_new, and says:
//   order                          of the propagated solution (Hairer's starting step)
//   fsal                           the stage that is f at x_new (the next step's k[0])
//   exponent, min_factor, max_factor, cap_after_rejection
//                                  the controller: h·min(max, max(min, 0.9‖e‖^exponent)), not
//                                  growing right after a rejection when cap_after_rejection
//   attempt(f, t, h, x, opt)       the step's error norm (∞ when a stage fails)
//   complete(f, t, h, x, dense)    what an acceptable step still needs (continuous extension when
//                                  dense); false rejects it
//   interpolate(θ, x)              the continuous extension at t + θh
template <template <std::size_t> class Step, Dynamics K> class RungeKuttaStepper {
 public:
  static constexpr int n = K::nq;
  using State = StateFor<K>;
  using S = Step<n + nv_of<K>>;

  RungeKuttaStepper(const double* u, const double* p, const AdaptiveOptions& opt,
                    const Stabilization& stab) noexcept
      : u_(u), p_(p), opt_(opt), stab_(stab) {}

  long evaluations = 0;

  bool start(double t, const State& x, double span, double& h) noexcept {
    h = opt_.initial_step;
    return f(t, x, s_.k[0]) && (h > 0 || starting_step(S::order, *this, t, span, x, s_.k[0], opt_, h));
  }
  double attempt(double t, double h, const State& x) noexcept {
    t_ = t;
    h_ = h;
    x_ = x;
    return s_.attempt(*this, t, h, x, opt_);
  }
  const State& solution() const noexcept { return s_.x_new; }
  bool complete(double t, double h, const State&, bool, bool dense) noexcept {
    return s_.complete(*this, t, h, x_, dense);
  }
  // The FSAL stage is f at the unprojected solution: after a projection, f again. (Not after a
  // free joint's normalization: that moves the state by about the local error, so the stale
  // stage changes the next step by h times it, an order below the local error; one evaluation
  // saved per step.)
  Status restart(double t, const State& x) noexcept {
    s_.k[0] = s_.k[S::fsal];
    if constexpr (K::nc > 0)
      if (stab_.method == Stabilization::Method::projection && !f(t, x, s_.k[0]))
        return Status::singular_dynamics;
    return Status::ok;
  }
  void interpolate(double t_out, State& x) const noexcept { s_.interpolate((t_out - t_) / h_, x); }
  double shrink(double e) const noexcept { return std::max(S::min_factor, 0.9 * std::pow(e, S::exponent)); }
  double next(double h, double e, bool after_rejection, const State&) const noexcept {
    const double growth = std::min(S::max_factor, std::max(S::min_factor, 0.9 * std::pow(std::max(e, 1e-10), S::exponent)));
    return h * (S::cap_after_rejection && after_rejection ? std::min(1.0, growth) : growth);
  }

  // f(t, x, ẋ): the stages' right-hand side, counted.
  bool operator()(double t, const State& x, State& dx) noexcept {
    ++evaluations;
    return state_derivative<K>(t, x, u_, p_, dx, stab_);
  }

 private:
  bool f(double t, const State& x, State& dx) noexcept { return (*this)(t, x, dx); }

  S s_;
  const double *u_, *p_;
  const AdaptiveOptions& opt_;
  const Stabilization& stab_;
  double t_ = 0, h_ = 0;  // the attempted step
  State x_{};             // its start
};

// dopri5 and dop853: validation and the constrained start, then the shared step loop.
template <template <std::size_t> class Step, Dynamics K, class Observer>
AdaptiveResult<K::nq, nv_of<K>> explicit_rk(double t0, double t1, const StateFor<K>& x0,
                                            const double* u, const double* p,
                                            const AdaptiveOptions& opt, Observer&& observer,
                                            const Stabilization& stab) noexcept {
  AdaptiveResult<K::nq, nv_of<K>> r;
  r.t = t0;
  r.x = x0;
  if ((r.status = adaptive_start<K>(t0, t1, r.x, p, opt, stab)) != Status::ok) return r;
  RungeKuttaStepper<Step, K> s(u, p, opt, stab);
  return adaptive_steps<K>(s, t0, t1, r.x, p, opt, observer, stab);
}

}  // namespace eom::detail
