// The state transition matrix Φ(t, t0) = ∂x(t)/∂x(t0), x = (q, q̇), integrated alongside the
// state by the variational equations Φ̇ = A Φ, A = [0 I; ∂q̈/∂q ∂q̈/∂q̇], Φ(t0) = I.
//
// The trick that makes every integrator of eom/integrate.hpp integrate Φ unchanged: split
// Φ = [Φq; Φv] into its position and velocity rows (each nq × 2nq). Then Φ̇q = Φv and
// Φ̇v = (∂q̈/∂q) Φq + (∂q̈/∂q̇) Φv, so (q, Φq) is again a "position" whose derivative is the
// "velocity" (q̇, Φv): eom::Sensitivity<K> is itself a second-order model, with
//   nq' = nq (1 + 2 nq),  q' = (q, vec Φq),  q̇' = (q̇, vec Φv),
//   q̈' = (q̈, vec((∂q̈/∂q) Φq + (∂q̈/∂q̇) Φv)),
// the derivatives coming from the forward_dynamics_derivatives kernel (exact, generated or
// eom::Reference). Step-size control then also watches Φ, as it should: the sensitivities are
// integrated to the same tolerance as the state.
//
// Scope: unconstrained models (nc = 0). For a constrained model the variational equations of the
// index-1 dynamics would drift off the tangent space and projection would have to act on Φ too;
// not offered. Inputs u are held as given (∂x/∂u and ∂x/∂p are not computed).
#pragma once

#include <array>

#include "eom/kernels.hpp"
#include "eom/rk4.hpp"

namespace eom {

template <DifferentiableDynamics K> struct Sensitivity {
  static_assert(K::nc == 0, "eom::Sensitivity: the state transition matrix is offered for "
                            "unconstrained models only (nc = 0)");
  static constexpr int base_nq = K::nq;
  static constexpr int nq = base_nq * (1 + 2 * base_nq), np = K::np, nu = K::nu, nc = 0;
  static constexpr int n = base_nq, m = 2 * base_nq;  // Φ is m × m, column-major

  // ---- packing between (x, Φ) and the augmented state ------------------------------------------

  // The augmented initial state for x0 with Φ(t0) = I.
  static StateOf<nq> start(const StateOf<base_nq>& x0) noexcept {
    StateOf<nq> y{};
    for (int i = 0; i < n; ++i) y[i] = x0[i], y[nq + i] = x0[n + i];
    for (int j = 0; j < m; ++j) {
      if (j < n)
        y[n + j * n + j] = 1;  // Φq(j, j) = 1 for the position columns
      else
        y[nq + n + j * n + (j - n)] = 1;  // Φv(j − n, j) = 1 for the velocity columns
    }
    return y;
  }
  static StateOf<base_nq> state(const StateOf<nq>& y) noexcept {
    StateOf<base_nq> x;
    for (int i = 0; i < n; ++i) x[i] = y[i], x[n + i] = y[nq + i];
    return x;
  }
  // Φ (m × m, column-major): rows 0..n−1 from Φq, rows n..m−1 from Φv.
  static std::array<double, m * m> transition(const StateOf<nq>& y) noexcept {
    std::array<double, m * m> phi;
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < n; ++i) {
        phi[i + m * j] = y[n + j * n + i];
        phi[n + i + m * j] = y[nq + n + j * n + i];
      }
    return phi;
  }

  // ---- the kernels the integrators need (eom::Dynamics) ----------------------------------------

  static bool forward_dynamics(double t, const double* q, const double* qd, const double* u,
                               const double* p, double* qdd) noexcept {
    std::array<double, n * n> dq, dqd;
    std::array<double, (nu > 0 ? n * nu : 1)> du;
    if (!K::forward_dynamics(t, q, qd, u, p, qdd)) return false;
    if (!K::forward_dynamics_derivatives(t, q, qd, u, p, dq.data(), dqd.data(), du.data()))
      return false;
    const double *phi_q = q + n, *phi_v = qd + n;
    double* out = qdd + n;
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < n; ++i) {
        double s = 0;
        for (int k = 0; k < n; ++k)
          s += dq[i + n * k] * phi_q[j * n + k] + dqd[i + n * k] * phi_v[j * n + k];
        out[j * n + i] = s;
      }
    return true;
  }
  // The energies of the underlying state (what observers of a run usually want).
  static double kinetic_energy(const double* q, const double* qd, const double* p) noexcept {
    return K::kinetic_energy(q, qd, p);
  }
  static double potential_energy(const double* q, const double* p) noexcept {
    return K::potential_energy(q, p);
  }
};

}  // namespace eom
