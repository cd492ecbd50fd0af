// Dormand–Prince 5(4): the embedded explicit Runge–Kutta pair with standard error control
// (Hairer, Nørsett & Wanner, Solving ODEs I, §II.4–5), over any eom::Dynamics. The 5th-order
// solution is propagated (local extrapolation) and the last stage is reused as the next step's
// first (FSAL), so an accepted step costs six evaluations of forward_dynamics.
//
// Error norm: ‖e‖ = sqrt(mean((eᵢ / (atol + rtol·max(|xᵢ|, |x̃ᵢ|)))²)); a step is accepted when
// ‖e‖ ≤ 1 and the next step is h·min(5, max(0.2, 0.9·‖e‖^(−1/5))). Allocation-free; never
// hangs (step limit), never returns NaN silently (status).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "eom/adaptive.hpp"
#include "eom/rk4.hpp"

namespace eom {

namespace detail {
// Butcher tableau of DOPRI5 (Dormand & Prince 1980).
struct Dopri5Tableau {
  static constexpr double c2 = 1.0 / 5, c3 = 3.0 / 10, c4 = 4.0 / 5, c5 = 8.0 / 9;
  static constexpr double a21 = 1.0 / 5;
  static constexpr double a31 = 3.0 / 40, a32 = 9.0 / 40;
  static constexpr double a41 = 44.0 / 45, a42 = -56.0 / 15, a43 = 32.0 / 9;
  static constexpr double a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561,
                          a54 = -212.0 / 729;
  static constexpr double a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247,
                          a64 = 49.0 / 176, a65 = -5103.0 / 18656;
  // 5th-order weights (also the 7th stage's coefficients: FSAL)
  static constexpr double b1 = 35.0 / 384, b3 = 500.0 / 1113, b4 = 125.0 / 192,
                          b5 = -2187.0 / 6784, b6 = 11.0 / 84;
  // b − b̂: the difference to the embedded 4th-order weights
  static constexpr double e1 = 35.0 / 384 - 5179.0 / 57600, e3 = 500.0 / 1113 - 7571.0 / 16695,
                          e4 = 125.0 / 192 - 393.0 / 640, e5 = -2187.0 / 6784 + 92097.0 / 339200,
                          e6 = 11.0 / 84 - 187.0 / 2100, e7 = -1.0 / 40;
};
}  // namespace detail

// Integrates from t0 to t1, calling observer(t, x) at t0 and after every accepted step.
// Stabilization (constrained models) as for rk4: Baumgarte inside the right-hand side,
// projection after each accepted step.
template <Dynamics K, class Observer>
AdaptiveResult<K::nq> dopri5(double t0, double t1, const StateOf<K::nq>& x0, const double* u,
                             const double* p, const AdaptiveOptions& opt, Observer&& observer,
                             const Stabilization& stab = {}) noexcept {
  using T = detail::Dopri5Tableau;
  constexpr int n = K::nq, m = 2 * n;
  using Method = Stabilization::Method;
  AdaptiveResult<K::nq> r;
  r.t = t0;
  r.x = x0;
  if (!detail::adaptive_input_ok<n>(t0, t1, x0, opt) || (K::nc == 0 && stab.method != Method::none)) {
    r.status = Status::invalid_argument;
    return r;
  }
  if ((r.status = constrained_start<K>(r.x, p, stab)) != Status::ok) return r;

  auto f = [&](double t, const StateOf<n>& x, StateOf<n>& dx) {
    ++r.evaluations;
    return state_derivative<K>(t, x, u, p, dx, stab);
  };
  auto rms = [&](const StateOf<n>& v, const StateOf<n>& a, const StateOf<n>& b) {
    return detail::error_norm(v, a, b, opt);
  };

  StateOf<n> k1, k2, k3, k4, k5, k6, k7, y, xn, err;
  if (!f(r.t, r.x, k1)) {
    r.status = Status::singular_dynamics;
    return r;
  }
  double h = opt.initial_step;
  if (h == 0) {  // Hairer's rule: h ~ 0.01 ‖x‖/‖ẋ‖, refined by one Euler step's curvature.
    const double d0 = rms(r.x, r.x, r.x), d1 = rms(k1, r.x, r.x);
    double h0 = d0 < 1e-5 || d1 < 1e-5 ? 1e-6 : 0.01 * d0 / d1;
    h0 = std::min(h0, t1 - t0);
    for (int i = 0; i < m; ++i) y[i] = r.x[i] + h0 * k1[i];
    if (!f(r.t + h0, y, k2)) {
      r.status = Status::singular_dynamics;
      return r;
    }
    for (int i = 0; i < m; ++i) err[i] = (k2[i] - k1[i]) / h0;
    const double d2 = rms(err, r.x, r.x), dmax = std::max(d1, d2);
    const double h1 = dmax <= 1e-15 ? std::max(1e-6, h0 * 1e-3) : std::pow(0.01 / dmax, 0.2);
    h = std::min(100 * h0, h1);
  }
  observer(r.t, r.x);
  while (r.t < t1) {
    if (r.accepted + r.rejected >= opt.max_steps) {
      r.status = Status::step_limit;
      return r;
    }
    const double h_min = 16 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::abs(r.t));
    if (h < h_min) {
      r.status = Status::step_size_underflow;
      return r;
    }
    const bool last = r.t + h >= t1;
    if (last) h = t1 - r.t;
    const double t = r.t;
    bool ok = true;
    for (int i = 0; i < m; ++i) y[i] = r.x[i] + h * T::a21 * k1[i];
    ok = ok && f(t + T::c2 * h, y, k2);
    for (int i = 0; i < m && ok; ++i) y[i] = r.x[i] + h * (T::a31 * k1[i] + T::a32 * k2[i]);
    ok = ok && f(t + T::c3 * h, y, k3);
    for (int i = 0; i < m && ok; ++i)
      y[i] = r.x[i] + h * (T::a41 * k1[i] + T::a42 * k2[i] + T::a43 * k3[i]);
    ok = ok && f(t + T::c4 * h, y, k4);
    for (int i = 0; i < m && ok; ++i)
      y[i] = r.x[i] + h * (T::a51 * k1[i] + T::a52 * k2[i] + T::a53 * k3[i] + T::a54 * k4[i]);
    ok = ok && f(t + T::c5 * h, y, k5);
    for (int i = 0; i < m && ok; ++i)
      y[i] = r.x[i] + h * (T::a61 * k1[i] + T::a62 * k2[i] + T::a63 * k3[i] + T::a64 * k4[i] +
                           T::a65 * k5[i]);
    ok = ok && f(t + h, y, k6);
    for (int i = 0; i < m && ok; ++i)
      xn[i] = r.x[i] + h * (T::b1 * k1[i] + T::b3 * k3[i] + T::b4 * k4[i] + T::b5 * k5[i] +
                            T::b6 * k6[i]);
    ok = ok && f(t + h, xn, k7);
    double e = std::numeric_limits<double>::infinity();
    if (ok) {
      for (int i = 0; i < m; ++i)
        err[i] = h * (T::e1 * k1[i] + T::e3 * k3[i] + T::e4 * k4[i] + T::e5 * k5[i] +
                      T::e6 * k6[i] + T::e7 * k7[i]);
      e = rms(err, r.x, xn);
    }
    // A stage that failed or produced Inf/NaN counts as a rejected step: retry smaller, which
    // also steps around a singularity that a large step jumped into; underflow stops it.
    if (!(e <= 1.0)) {
      ++r.rejected;
      h *= std::isfinite(e) ? std::max(0.2, 0.9 * std::pow(e, -0.2)) : 0.25;
      continue;
    }
    r.t = last ? t1 : t + h;
    r.x = xn;
    k1 = k7;
    if constexpr (K::nc > 0)
      if (stab.method == Method::projection) {
        if (!project<K>(r.x.data(), r.x.data() + n, p, stab.tolerance)) {
          r.status = Status::projection_failed;
          return r;
        }
        if (!f(r.t, r.x, k1)) {  // the projected state needs its own derivative
          r.status = Status::singular_dynamics;
          return r;
        }
      }
    ++r.accepted;
    observer(r.t, r.x);
    h *= std::min(5.0, std::max(0.2, 0.9 * std::pow(std::max(e, 1e-10), -0.2)));
  }
  return r;
}

}  // namespace eom
