// Dormand–Prince 5(4): the embedded explicit Runge–Kutta pair with standard error control
// (Hairer, Nørsett & Wanner, Solving ODEs I, §II.4–5), over any eom::Dynamics. The 5th-order
// solution is propagated (local extrapolation) and the last stage is reused as the next step's
// first (FSAL), so an accepted step costs six evaluations of forward_dynamics.
//
// Error norm: ‖e‖ = sqrt(mean((eᵢ / (atol + rtol·max(|xᵢ|, |x̃ᵢ|)))²)); a step is accepted when
// ‖e‖ ≤ 1 and the next step is h·min(5, max(0.2, 0.9·‖e‖^(−1/5))). Allocation-free; never
// hangs (step limit), never returns NaN silently (status).
//
// Dense output (AdaptiveOptions::output_times): Hairer's continuous extension of order 4
// (HNW I §II.6, the DOPRI5 code's d1…d7), built from the step's seven stages at no extra
// evaluation, so its local error is O(h⁵) — below the step's error tolerance.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "eom/integration/explicit_rk.hpp"

namespace eom {

namespace detail {
// Butcher tableau of DOPRI5 (Dormand & Prince 1980); stage j is k[j − 1].
struct Dopri5Tableau {
  static constexpr std::array<double, 7> c{0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1, 1};
  static constexpr std::array<std::array<double, 7>, 7> a{{
      {},
      {1.0 / 5},
      {3.0 / 40, 9.0 / 40},
      {44.0 / 45, -56.0 / 15, 32.0 / 9},
      {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729},
      {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656},
      {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84},
  }};
  // 5th-order weights: the 7th stage's row (FSAL: stage 7 is f at the new solution)
  static constexpr const std::array<double, 7>& b = a[6];
  // b − b̂: the difference to the embedded 4th-order weights
  static constexpr std::array<double, 7> e{
      35.0 / 384 - 5179.0 / 57600, 0, 500.0 / 1113 - 7571.0 / 16695, 125.0 / 192 - 393.0 / 640,
      -2187.0 / 6784 + 92097.0 / 339200, 11.0 / 84 - 187.0 / 2100, -1.0 / 40};
  // The continuous extension's last coefficient (Hairer's DOPRI5 code: d1…d7)
  static constexpr std::array<double, 7> d{
      -12715105075.0 / 11282082432, 0, 87487479700.0 / 32700410799,
      -10690763975.0 / 1880347072, 701980252875.0 / 199316789632,
      -1453857185.0 / 822651844, 69997945.0 / 29380423};
};

// One DOPRI5 step and its dense output, over any f(t, x, ẋ) → bool on fixed-size states.
template <std::size_t m> struct Dopri5Step {
  using Vec = std::array<double, m>;
  static constexpr int order = 5;
  static constexpr std::size_t fsal = 6;
  static constexpr double exponent = -0.2, min_factor = 0.2, max_factor = 5.0;
  static constexpr bool cap_after_rejection = false;

  std::array<Vec, 7> k;  // k[0] = f(t, x) on entry; k[6] = f(t + h, x_new) after attempt
  Vec x_new, error;      // the 5th-order solution and h·Σ eⱼkⱼ
  std::array<Vec, 5> dense;

  // Stages 2–7 of the step from (t, x) of size h; its error norm, ∞ when f fails.
  template <class F>
  double attempt(F&& f, double t, double h, const Vec& x, const AdaptiveOptions& opt) noexcept {
    using T = Dopri5Tableau;
    Vec y;
    bool ok = true;
    [&]<std::size_t... s>(std::index_sequence<s...>) {
      ((ok = ok && (advance<T::a[s + 1]>(x, h, k, y), f(t + T::c[s + 1] * h, y, k[s + 1]))), ...);
    }(std::make_index_sequence<5>{});
    if (!ok) return std::numeric_limits<double>::infinity();
    advance<T::b>(x, h, k, x_new);
    if (!f(t + h, x_new, k[6])) return std::numeric_limits<double>::infinity();
    scaled_sum<T::e>(h, k, error);
    return error_norm(error, x, x_new, opt);
  }

  // An accepted step needs no more evaluations: FSAL is stage 7, and the continuous extension
  // comes from the stages.
  template <class F> bool complete(F&&, double, double h, const Vec& x, bool dense_output) noexcept {
    if (dense_output) prepare_dense(x, h);
    return true;
  }

  // The coefficients of the continuous extension of the attempted step from x (Hermite-like
  // form: value and slope match at both ends, the d-term adds the 4th-order correction).
  void prepare_dense(const Vec& x, double h) noexcept {
    scaled_sum<Dopri5Tableau::d>(h, k, dense[4]);
    for (std::size_t i = 0; i < m; ++i) {
      dense[0][i] = x[i];
      dense[1][i] = x_new[i] - x[i];
      dense[2][i] = h * k[0][i] - dense[1][i];
      dense[3][i] = dense[1][i] - h * k[6][i] - dense[2][i];
    }
  }

  // The state at t + θh, θ ∈ [0, 1]: x + θ(Δ + (1−θ)(r₃ + θ(r₄ + (1−θ) r₅))).
  void interpolate(double theta, Vec& out) const noexcept {
    const double rest = 1 - theta;
    for (std::size_t i = 0; i < m; ++i)
      out[i] = dense[0][i] +
               theta * (dense[1][i] +
                        rest * (dense[2][i] + theta * (dense[3][i] + rest * dense[4][i])));
  }
};
}  // namespace detail

// Integrates from t0 to t1, calling observer(t, x) at t0 and after every accepted step, or with
// opt.output_times at exactly those times (dense output). Stabilization (constrained models) as
// for rk4: Baumgarte inside the right-hand side, projection after each accepted step (and of every
// dense-output state, which the continuous extension alone leaves off the constraints). A free
// joint's quaternion is normalized likewise (state.hpp).
template <Dynamics K, class Observer>
AdaptiveResult<K::nq, nv_of<K>> dopri5(double t0, double t1, const StateFor<K>& x0,
                                       const double* u, const double* p,
                                       const AdaptiveOptions& opt, Observer&& observer,
                                       const Stabilization& stab = {}) noexcept {
  return detail::explicit_rk<detail::Dopri5Step, K>(t0, t1, x0, u, p, opt,
                                                    std::forward<Observer>(observer), stab);
}

}  // namespace eom
