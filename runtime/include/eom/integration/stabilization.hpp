// Constraint stabilization for integrating constrained models (index-3 DAEs written at index 1):
// the forward_dynamics kernel enforces only C q̈ = −γ, so round-off and truncation make φ(q) and
// C q̇ drift. Two remedies, both integrator options (docs/CONTRACT.md §2: none inside the kernel):
//
//  * Baumgarte: enforce C q̈ = −γ − 2α C q̇ − β² φ instead, which turns the drift into a damped
//    oscillation. Cheap; the residual stays bounded but not small (O(h^p) of the method).
//  * Projection after each step: Newton steps that move q onto φ = 0 along M⁻¹Cᵀ (the smallest
//    correction in the kinetic-energy metric), then the velocity onto C q̇ = 0 the same way.
//
// Both solve with the range-space method of linalg.hpp, so they need the kernels below.
//
// With a free joint (eom/model/free_joint.hpp) the velocity is v (nv = nq − 1) and C = ∂φ/∂q G is
// nc × nv: both act in the tangent space as they stand, and projection moves q by q ⊕ Δ
// (integrate_configuration, the exact rotation for the quaternion) rather than q + Δ, which keeps
// the quaternion on the unit sphere. Without one, q ⊕ Δ is q + Δ.
#pragma once

#include <array>
#include <cmath>

#include "eom/model/free_joint.hpp"
#include "eom/model/kernels.hpp"
#include "eom/numeric/linalg.hpp"

namespace eom {

// The kernels a constrained integrator needs besides forward_dynamics.
template <class K>
concept ConstrainedDynamics =
    Dynamics<K> && (K::nc > 0) && requires(double t, const double* x, double* y) {
      K::mass_matrix(x, x, y);
      K::coriolis(x, x, x, y);
      K::potential_gradient(x, x, y);
      K::generalized_forces(t, x, x, x, x, y);
      K::constraint_residual(x, x, y);
      K::constraint_jacobian(x, x, y);
      K::constraint_bias(x, x, x, y);
    };

struct Stabilization {
  enum class Method { none, baumgarte, projection };
  Method method = Method::none;
  // Baumgarte gains [1/s]: critically damped (α = β) at a rate well below 1/h but fast against
  // the motion. 10/s suits the paper's examples at h = 1-5 ms.
  double alpha = 10.0, beta = 10.0;
  // Projection: stop the Newton iteration when max |φ| ≤ tolerance (after at most 8 steps).
  double tolerance = 1e-13;
  // Without projection, a start farther than this from φ = 0 or C q̇ = 0 is refused.
  double initial_tolerance = 1e-8;
};

// C v for C (nc×nv, column-major).
template <int nc, int nv>
void jacobian_times(const std::array<double, nc * nv>& C, const double* qd, double* v) noexcept {
  for (int i = 0; i < nc; ++i) {
    double s = 0;
    for (int j = 0; j < nv; ++j) s += C[i + nc * j] * qd[j];
    v[i] = s;
  }
}

// max |φ(q)| and max |C v|: the position and velocity constraint residuals.
template <ConstrainedDynamics K>
std::array<double, 2> constraint_residuals(const double* q, const double* qd, const double* p) noexcept {
  constexpr int nv = nv_of<K>, nc = K::nc;
  std::array<double, nc> phi, v;
  std::array<double, nc * nv> C;
  K::constraint_residual(q, p, phi.data());
  K::constraint_jacobian(q, p, C.data());
  jacobian_times<nc, nv>(C, qd, v.data());
  double rp = 0, rv = 0;
  for (int i = 0; i < nc; ++i) {
    rp = std::max(rp, std::abs(phi[i]));
    rv = std::max(rv, std::abs(v[i]));
  }
  return {rp, rv};
}

// v̇ with Baumgarte terms: C v̇ = −γ − 2α C v − β² φ. False, as forward_dynamics, when singular.
template <ConstrainedDynamics K>
bool baumgarte_dynamics(double t, const double* q, const double* qd, const double* u, const double* p,
                        double alpha, double beta, double* qdd) noexcept {
  constexpr int nv = nv_of<K>, nc = K::nc;
  std::array<double, nv * nv> M;
  std::array<double, nv> f, dV, Q;
  std::array<double, nc * nv> C;
  std::array<double, nc> gamma, phi, v;
  K::mass_matrix(q, p, M.data());
  K::coriolis(q, qd, p, f.data());
  K::potential_gradient(q, p, dV.data());
  K::generalized_forces(t, q, qd, u, p, Q.data());
  K::constraint_residual(q, p, phi.data());
  K::constraint_jacobian(q, p, C.data());
  K::constraint_bias(q, qd, p, gamma.data());
  for (int i = 0; i < nv; ++i) f[i] = Q[i] - f[i] - dV[i];
  jacobian_times<nc, nv>(C, qd, v.data());
  for (int i = 0; i < nc; ++i) gamma[i] += 2 * alpha * v[i] + beta * beta * phi[i];
  return linalg::solve_constrained<double, nv, nc>(M, f, C, gamma, qdd);
}

// Moves (q, v) onto φ = 0 and C v = 0 (M-orthogonal corrections). False when the Newton
// iteration does not reach the tolerance or meets a singular C M⁻¹Cᵀ; then q, qd are unchanged.
template <ConstrainedDynamics K>
bool project(double* q, double* qd, const double* p, double tolerance) noexcept {
  constexpr int nq = K::nq, nv = nv_of<K>, nc = K::nc;
  std::array<double, nq> q1;
  std::array<double, nv> dq, v1;
  std::array<double, nv * nv> M;
  std::array<double, nc * nv> C;
  std::array<double, nc> r;
  const std::array<double, nv> zero{};
  for (int i = 0; i < nq; ++i) q1[i] = q[i];
  bool converged = false;
  for (int iteration = 0; iteration < 8; ++iteration) {
    K::constraint_residual(q1.data(), p, r.data());
    double worst = 0;
    for (double v : r) worst = std::max(worst, std::abs(v));
    if (!std::isfinite(worst)) return false;
    if (worst <= tolerance) {
      converged = true;
      break;
    }
    K::mass_matrix(q1.data(), p, M.data());
    K::constraint_jacobian(q1.data(), p, C.data());
    // [M Cᵀ; C 0][Δq; μ] = [0; −φ]  ⇒  C Δq = −φ with the smallest Δqᵀ M Δq.
    if (!linalg::solve_constrained<double, nv, nc>(M, zero, C, r, dq.data())) return false;
    integrate_configuration(layout_of<K>(), q1.data(), dq.data(), 1.0, q1.data());  // q1 ⊕ Δq
  }
  if (!converged) return false;
  K::mass_matrix(q1.data(), p, M.data());
  K::constraint_jacobian(q1.data(), p, C.data());
  jacobian_times<nc, nv>(C, qd, r.data());
  if (!linalg::solve_constrained<double, nv, nc>(M, zero, C, r, v1.data())) return false;
  for (int i = 0; i < nq; ++i) q[i] = q1[i];
  for (int i = 0; i < nv; ++i) qd[i] += v1[i];
  return true;
}

}  // namespace eom
