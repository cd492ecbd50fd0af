// High-precision reference trajectories: the very same model source evaluated in a wider type
// (long double, qd's dd_real or qd_real, ...) by eom::Reference<Model, Real>, integrated by
// Gragg–Bulirsch–Stoer extrapolation. Double-precision integrators are measured against it.
//
// Why extrapolation: its coefficients are rational (the step counts), so it reaches any
// precision the type offers — unlike a Runge–Kutta tableau typed in double, whose order
// conditions hold only to 1e-16 — and its order (2k for k columns) is high enough that a
// tolerance of 1e-28 costs hundreds of steps, not millions.
//
// One step of size H: the modified midpoint rule with n_j = 2j substeps (Gragg) for j = 1..k,
// whose results expand in even powers of H/n_j, combined by Aitken–Neville extrapolation in
// (H/n_j)². The error estimate is the difference of the last two diagonal entries, in the norm
// max |eᵢ| / (1 + |xᵢ|) (mixed absolute/relative), and the step adapts to
// H·0.9·(tol/err)^(1/(2k−1)). Steps end exactly at every requested output time, so no
// interpolation error enters the reference.
//
// A free joint (eom/model/free_joint.hpp): the state is (q, v), nq + nv numbers in Real, with
// q̇ = G(q) v; the quaternion is normalized in Real at the start and after each accepted step
// (state.hpp), and an initial one off the unit sphere by more than quaternion_norm_tolerance is
// Status::invalid_argument.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <span>

#include "eom/integration/state.hpp"
#include "eom/reference/reference.hpp"

namespace eom {

struct ExtrapolationOptions {
  double tolerance = 1e-28;  // per step, in max |eᵢ| / (1 + |xᵢ|)
  int columns = 10;          // k: extrapolation order 2k
  long max_steps = 200000;   // accepted + rejected
};

template <class Real, int nq, int nv = nq> struct ExtrapolationResult {
  Status status = Status::ok;
  Real t{};                           // time reached
  std::array<Real, nq + nv> x{};      // state (q, v) at t
  long accepted = 0, rejected = 0, evaluations = 0;
};

// Integrates Model in Real from (t0, x0) through the ascending output `times` (each > t0),
// calling observer(t, x) at each of them with the state in Real. u and p are in Real (null when
// the model has none).
template <class Model, class Real, class Observer>
ExtrapolationResult<Real, ModelInfo<Model>::nq, ModelInfo<Model>::nv> extrapolate(
    double t0, const std::array<Real, ModelInfo<Model>::nq + ModelInfo<Model>::nv>& x0,
    std::span<const double> times, const Real* u, const Real* p,
    const ExtrapolationOptions& opt, Observer&& observer) {
  using R = Reference<Model, Real>;
  using std::abs;
  constexpr int n = R::nq, nv = R::nv, m = n + nv;
  using State = std::array<Real, m>;
  constexpr int max_columns = 16;
  ExtrapolationResult<Real, n, nv> r;
  r.t = Real(t0);
  r.x = x0;
  bool ok = std::isfinite(t0) && std::isfinite(opt.tolerance) && opt.tolerance > 0 &&
            opt.columns >= 2 && opt.columns <= max_columns && opt.max_steps > 0;
  for (const Real& v : x0) ok = ok && std::isfinite(as_double(v));
  ok = ok && as_double(quaternion_norm_error(layout_of<R>(), x0.data())) <= quaternion_norm_tolerance;
  double previous = t0;
  for (double t : times) ok = ok && std::isfinite(t) && t > previous, previous = t;
  if (!ok) {
    r.status = Status::invalid_argument;
    return r;
  }
  normalize_configuration(layout_of<R>(), r.x.data());

  auto f = [&](const Real& t, const State& x, State& dx) {
    ++r.evaluations;
    configuration_rate(layout_of<R>(), x.data(), x.data() + n, dx.data());
    return R::forward_dynamics(t, x.data(), x.data() + n, u, p, dx.data() + n);
  };
  // The modified midpoint rule over [t, t + H] in `steps` substeps (steps even), from the
  // current state whose derivative is f0.
  auto midpoint = [&](const Real& t, const Real& H, int steps, const State& f0, State& out) {
    const Real h = H / Real(steps);
    State z0 = r.x, z1, dz;
    for (int i = 0; i < m; ++i) z1[i] = z0[i] + h * f0[i];
    for (int s = 1; s < steps; ++s) {
      if (!f(t + Real(s) * h, z1, dz)) return false;
      for (int i = 0; i < m; ++i) {
        const Real z2 = z0[i] + Real(2) * h * dz[i];
        z0[i] = z1[i];
        z1[i] = z2;
      }
    }
    out = z1;
    return true;
  };

  const int k = opt.columns;
  double H = 0.01;  // adapted from the first step on; the first estimate corrects it at once
  std::array<State, max_columns> T;  // T[j]: the current row of the extrapolation tableau
  for (double t_out : times) {
    const Real target(t_out);
    while (r.t < target) {
      if (r.accepted + r.rejected >= opt.max_steps) {
        r.status = Status::step_limit;
        return r;
      }
      const double remaining = as_double(target - r.t);
      const bool last = H >= remaining;
      const Real step = last ? target - r.t : Real(H);
      // Singular where we stand: stop. A failure inside the step (a too-long step can reach
      // wild states, e.g. an unstable midpoint chain on a stiff model) only rejects the step.
      State f0;
      if (!f(r.t, r.x, f0)) {
        r.status = Status::singular_dynamics;
        return r;
      }
      double err = std::numeric_limits<double>::infinity();
      bool solved = true;
      for (int j = 0; j < k && solved; ++j) {
        State y;
        solved = midpoint(r.t, step, 2 * (j + 1), f0, y);
        // Aitken–Neville, row j: T[l] holds T_{j−1,l} and becomes T_{j,l}, column by column;
        // T_{j,l} = T_{j,l−1} + (T_{j,l−1} − T_{j−1,l−1}) / ((n_j / n_{j−l})² − 1).
        for (int l = 1; l <= j && solved; ++l) {
          const Real ratio = Real(j + 1) / Real(j - l + 1);
          const Real factor = ratio * ratio - Real(1);
          for (int c = 0; c < m; ++c) {
            const Real next = y[c] + (y[c] - T[l - 1][c]) / factor;
            T[l - 1][c] = y[c];
            y[c] = next;
          }
        }
        T[j] = y;  // the diagonal T_{j,j}
        if (j == k - 1 && solved) {
          err = 0;
          for (int c = 0; c < m; ++c) {
            const double e = as_double(abs(T[j][c] - T[j - 1][c])) /
                             (1 + std::abs(as_double(T[j][c])));
            err = std::max(err, e / opt.tolerance);
          }
        }
      }
      if (!solved || !(err <= 1)) {
        ++r.rejected;
        H *= solved && std::isfinite(err) ? std::max(0.1, 0.9 * std::pow(err, -1.0 / (2 * k - 1)))
                                          : 0.25;
        if (H < 1e-12 * std::max(1.0, std::abs(t_out))) {
          r.status = Status::step_size_underflow;
          return r;
        }
        continue;
      }
      r.x = T[k - 1];
      normalize_configuration(layout_of<R>(), r.x.data());
      r.t = last ? target : r.t + step;
      ++r.accepted;
      // Grow moderately; a short last step says nothing about the next.
      if (!last) H *= std::min(4.0, std::max(0.2, 0.9 * std::pow(std::max(err, 1e-12), -1.0 / (2 * k - 1))));
    }
    observer(t_out, r.x);
  }
  return r;
}

}  // namespace eom
