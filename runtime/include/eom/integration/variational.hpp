// A variational (symplectic) integrator for long runs: the midpoint discrete Lagrangian in
// position–momentum form, with holonomic constraints by SHAKE/RATTLE and non-conservative forces
// by the discrete Lagrange–d'Alembert principle (Marsden & West, "Discrete mechanics and
// variational integrators", Acta Numerica 2001, §1.6, §3.2, §3.4–3.5). Over any eom::Dynamics
// that also offers the kernels of docs/CONTRACT.md §3 named in eom::LagrangianDynamics below.
//
// Scheme. L_d(q0, q1) = h L(q̄, v), q̄ = (q0 + q1)/2, v = (q1 − q0)/h, with L = ½ q̇ᵀM(q)q̇ − V(q).
// Writing Ψ(q̄, v) = ∂T/∂q − ∂V/∂q + Q = Ṁv − c − ∂V/∂q + Q (docs/CONTRACT.md §2: ∂T/∂q = Ṁq̇ − c) and
// p̄ = M(q̄)v, the discrete Legendre transforms with forces F± = (h/2) Q(t_k + h/2, q̄, v) are
//     p_k     = −D1 L_d − F⁻ + Cᵀ(q_k) λ     ⇔   p̄ − (h/2) Ψ − p_k + Cᵀ(q_k) λ = 0
//     φ(q_{k+1}) = 0
//     p_{k+1} =  D2 L_d + F⁺ − Cᵀ(q_{k+1}) μ ⇔   p_{k+1} = p̄ + (h/2) Ψ − Cᵀ(q_{k+1}) μ,
//                                                 C(q_{k+1}) M(q_{k+1})⁻¹ p_{k+1} = 0.
// The first two lines (nq + nc equations in q_{k+1}, λ) are the implicit part (SHAKE); the third
// is explicit up to one linear range-space solve for μ (RATTLE's momentum projection, done with
// linalg::solve_constrained, which also yields q̇_{k+1} = M⁻¹ p_{k+1} on C q̇ = 0).
//
// Choices, and why:
//  * Position–momentum form: the state carried between steps is (q, p), never re-derived from
//    q̇, so the map (q_k, p_k) ↦ (q_{k+1}, p_{k+1}) is exactly the symplectic one (up to the
//    Newton tolerance and round-off). The observer still sees x = (q, q̇) with q̇ = M(q)⁻¹p,
//    the continuous Legendre transform at the node (second-order accurate like q).
//  * The constraint force of the position step acts through Cᵀ(q_k), not Cᵀ(q_{k+1}): that is
//    what the constrained discrete variational principle gives (the force h Cᵀ(q_k) λ_k of node k
//    is split between the two steps that meet there; the half before node k+1 is the −Cᵀμ term),
//    it is the classical symplectic, symmetric SHAKE/RATTLE pairing, and it keeps the implicit
//    system linear in λ.
//  * Newton: simplified Newton on z = (q_{k+1}, Λ), the momentum equation multiplied by h so its
//    block is ≈ M (the same scale as C):  G(q1) = h(p̄ − p_k − (h/2)Ψ) + Cᵀ(q_k)Λ,  φ(q1).
//    The iteration matrix [∂G/∂q1, Cᵀ(q_k); C(q1), 0] is formed once per step at the predictor
//    and LU-factored with partial pivoting. ∂G/∂q1 = M(q̄) + ½(B − Bᵀ) − (h/2)∂Q/∂v
//    − (h²/4)(∂²T/∂q² − ∂²V/∂q² + ∂Q/∂q) + …, where B = ∂(M(q)v)/∂q; the kernel set has no
//    Hessian of V, ∂Q/∂q̇ or second derivatives of M, and M(q̄) alone leaves a contraction factor
//    of ≈ h|q̇||∂M/∂q|/|M| + (hω)²/4 per iteration (1e-2 for the spring pendulum at h = 1 ms,
//    and divergence once hω > 2). So ∂G/∂q1 is taken by forward differences of G (nq extra
//    evaluations of G, step sqrt(ε)·max(|q1ⱼ|, 1)): the contraction factor is then the FD error
//    (~1e-8) plus the predictor's O(h³) distance from the solution, and a step needs two or three
//    iterations from the predictor q_k + h q̇_k + (h²/2) q̈_k (forward_dynamics; it falls back to
//    q_k + h q̇_k where forward_dynamics fails). Measured: 2 per step at h = 1 ms (Cartesian
//    pendulum), 2.98 at h = 10 ms (spring pendulum), at most 4 (closed chain, h = 5 ms).
//    (Reusing the factorization across steps would save the nq FD evaluations on big models at
//    the price of more iterations; not done.)
//    Convergence: ‖Δq‖∞ ≤ tolerance·(‖q_{k+1}‖∞ + ‖q_{k+1} − q_k‖∞), i.e. relative to the
//    precision q_{k+1} = q_k + increment can be held to; default 1e-12, so the error left after
//    the last update is ~1e-20 and the solve adds no systematic (drift-causing) error.
//    Cost per step: (nq + 3) evaluations of G (5 kernels each: mass_matrix, mass_matrix_dot,
//    coriolis, potential_gradient, generalized_forces), one forward_dynamics, one mass_matrix,
//    and, with constraints, constraint_jacobian ×2 and constraint_residual per G.
//  * Generalized forces (damping, drives, inputs u held constant) enter by the discrete
//    Lagrange–d'Alembert principle with (h/2)Q at either end, evaluated at the midpoint and
//    t_k + h/2. The scheme stays second order and consistent with dE/dt = q̇ᵀQ, but it is then no
//    longer symplectic: the no-drift property holds for Q = 0 only.
//
// Scope: T must be a quadratic form in q̇ (T = ½ q̇ᵀM(q)q̇, so p = M q̇): the kernel set has no
// ∂T/∂q̇. Every body-form model and every natural energy-form model is; a T with terms linear in
// q̇ (moving frames) is not and would be integrated wrongly.
//
// Not for a free joint (eom/model/free_joint.hpp): the discrete Lagrangian above lives on a vector space
// (q̄ = (q0 + q1)/2, v = (q1 − q0)/h), and on the quaternion's sphere a midpoint is no
// configuration and a difference no velocity; normalizing afterwards, as the other methods do,
// would break the discrete variational principle and with it the symplecticity this method is
// for. A free joint needs a Lie-group discretization (L_d on SO(3) × R³, q1 = q0 ⊗ exp(h ω/2))
// that this integrator does not implement: such a model is refused with
// Status::method_unavailable before any evaluation.
//
// Failures (Status): singular iteration matrix or momentum projection → singular_dynamics;
// Newton not converged within max_iterations → nonlinear_solve_failed (VariationalResult::failure
// tells the cases apart). Allocation-free for fixed-size models; noexcept.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "eom/integration/rk4.hpp"
#include "eom/model/kernels.hpp"
#include "eom/numeric/linalg.hpp"

namespace eom {

// The kernels the variational integrator needs: those of every model, plus the constraint
// residual and Jacobian when nc > 0.
template <class K>
concept LagrangianDynamics =
    Dynamics<K> && requires(double t, const double* x, double* y) {
      K::mass_matrix(x, x, y);
      K::mass_matrix_dot(x, x, x, y);
      K::coriolis(x, x, x, y);
      K::potential_gradient(x, x, y);
      K::generalized_forces(t, x, x, x, x, y);
    } && (K::nc == 0 || requires(const double* x, double* y) {
      K::constraint_residual(x, x, y);
      K::constraint_jacobian(x, x, y);
    });

struct VariationalOptions {
  // Newton stops when ‖Δq‖∞ ≤ tolerance·(‖q_{k+1}‖∞ + ‖q_{k+1} − q_k‖∞).
  double tolerance = 1e-12;
  int max_iterations = 10;  // per step
  // A constrained start farther than this from φ = 0 or C q̇ = 0 is refused.
  double initial_tolerance = 1e-8;
};

enum class VariationalFailure {
  none,
  singular_iteration_matrix,     // the Newton matrix lost rank (Status::singular_dynamics)
  no_convergence,                // Newton did not converge (Status::nonlinear_solve_failed)
  singular_momentum_projection,  // M or C M⁻¹Cᵀ singular at q_{k+1} (Status::singular_dynamics)
};

template <int nq, int nv = nq> struct VariationalResult {
  Status status = Status::ok;
  VariationalFailure failure = VariationalFailure::none;
  double t = 0;           // time reached (the failing step's start when status != ok)
  StateOf<nq, nv> x{};    // state (q, q̇) at t
  long steps = 0;         // steps taken
  long evaluations = 0;   // kernel calls of every kind
  long iterations = 0;    // Newton iterations, all steps together
  int max_step_iterations = 0;  // the most Newton iterations one step needed
};

namespace detail {

// One step of size h from (t, q, p) with q̇ = M(q)⁻¹p given; updates q, p, qd only on success.
template <LagrangianDynamics K>
VariationalFailure variational_step(double t, double h, double* q, double* p, double* qd,
                                    const double* u, const double* par,
                                    const VariationalOptions& opt, long& evaluations,
                                    long& iterations, int& step_iterations) noexcept {
  constexpr int n = K::nq, nc = K::nc, m = n + nc;
  using Vec = std::array<double, n>;
  using Mat = std::array<double, n * n>;
  const double tm = t + 0.5 * h;

  // G(q1) = h (p̄ − p_k − (h/2) Ψ) without the constraint term; p_end = p̄ + (h/2) Ψ.
  auto momentum_residual = [&](const Vec& q1, Vec& G, Vec* p_end) {
    Vec qm, v, c, dV, Q;
    Mat M, Md;
    for (int i = 0; i < n; ++i) {
      qm[i] = 0.5 * (q[i] + q1[i]);
      v[i] = (q1[i] - q[i]) / h;
    }
    K::mass_matrix(qm.data(), par, M.data());
    K::mass_matrix_dot(qm.data(), v.data(), par, Md.data());
    K::coriolis(qm.data(), v.data(), par, c.data());
    K::potential_gradient(qm.data(), par, dV.data());
    K::generalized_forces(tm, qm.data(), v.data(), u, par, Q.data());
    evaluations += 5;
    for (int i = 0; i < n; ++i) {
      double pbar = 0, psi = Q[i] - c[i] - dV[i];
      for (int j = 0; j < n; ++j) {
        pbar += M[i + n * j] * v[j];
        psi += Md[i + n * j] * v[j];
      }
      G[i] = h * (pbar - p[i] - 0.5 * h * psi);
      if (p_end) (*p_end)[i] = pbar + 0.5 * h * psi;
    }
  };

  // Predictor: q_k + h q̇_k + (h²/2) q̈_k.
  Vec q1, a;
  const bool have_a = K::forward_dynamics(t, q, qd, u, par, a.data());
  ++evaluations;
  for (int i = 0; i < n; ++i) q1[i] = q[i] + h * qd[i] + (have_a ? 0.5 * h * h * a[i] : 0.0);

  std::array<double, nc * n> C0{}, C1{};
  std::array<double, nc> Lambda{}, phi{};
  if constexpr (nc > 0) {
    K::constraint_jacobian(q, par, C0.data());
    K::constraint_jacobian(q1.data(), par, C1.data());
    K::constraint_residual(q1.data(), par, phi.data());
    evaluations += 3;
  }

  // Iteration matrix at the predictor.
  Vec G{}, Gd{}, p_end{};  // zeroed: every path writes them first, GCC cannot prove it
  momentum_residual(q1, G, nullptr);
  std::array<double, m * m> J{};
  std::array<int, m> piv{};
  for (int j = 0; j < n; ++j) {
    Vec qj = q1;
    const double delta = std::sqrt(std::numeric_limits<double>::epsilon()) * std::max(std::abs(q1[j]), 1.0);
    qj[j] += delta;
    const double step = qj[j] - q1[j];  // the representable perturbation
    momentum_residual(qj, Gd, nullptr);
    for (int i = 0; i < n; ++i) J[i + m * j] = (Gd[i] - G[i]) / step;
  }
  for (int k = 0; k < nc; ++k)
    for (int i = 0; i < n; ++i) {
      J[i + m * (n + k)] = C0[k + nc * i];  // Cᵀ(q_k)
      J[(n + k) + m * i] = C1[k + nc * i];  // C(q1)
    }
  if (!linalg::lu_factor<double, m>(J, piv)) return VariationalFailure::singular_iteration_matrix;

  bool converged = false;
  int it = 0;
  while (it < opt.max_iterations) {
    ++it;
    std::array<double, m> z;
    for (int i = 0; i < n; ++i) {
      double r = G[i];
      for (int k = 0; k < nc; ++k) r += C0[k + nc * i] * Lambda[k];
      z[i] = -r;
    }
    for (int k = 0; k < nc; ++k) z[n + k] = -phi[k];
    linalg::lu_solve<double, m>(J, piv, z.data());
    double dq = 0, qn = 0, inc = 0;
    for (int i = 0; i < n; ++i) {
      q1[i] += z[i];
      dq = std::max(dq, std::abs(z[i]));
      qn = std::max(qn, std::abs(q1[i]));
      inc = std::max(inc, std::abs(q1[i] - q[i]));
    }
    for (int k = 0; k < nc; ++k) Lambda[k] += z[n + k];
    if (!std::isfinite(dq)) break;
    momentum_residual(q1, G, &p_end);
    if constexpr (nc > 0) {
      K::constraint_residual(q1.data(), par, phi.data());
      ++evaluations;
    }
    if (dq <= opt.tolerance * (qn + inc)) {
      converged = true;
      break;
    }
  }
  iterations += it;
  step_iterations = it;
  if (!converged) return VariationalFailure::no_convergence;

  // RATTLE: p_{k+1} = p_end − Cᵀ(q1) μ with C(q1) M(q1)⁻¹ p_{k+1} = 0; q̇_{k+1} = M(q1)⁻¹ p_{k+1}.
  Mat M1;
  K::mass_matrix(q1.data(), par, M1.data());
  ++evaluations;
  if constexpr (nc > 0) {
    K::constraint_jacobian(q1.data(), par, C1.data());
    ++evaluations;
  }
  Vec v1;
  std::array<double, nc> mu{}, zero{};
  if (!linalg::solve_constrained<double, n, nc>(M1, p_end, C1, zero, v1.data(), mu.data()))
    return VariationalFailure::singular_momentum_projection;
  for (int i = 0; i < n; ++i) {
    double f = p_end[i];
    for (int k = 0; k < nc; ++k) f -= C1[k + nc * i] * mu[k];
    q[i] = q1[i];
    p[i] = f;
    qd[i] = v1[i];
  }
  return VariationalFailure::none;
}

}  // namespace detail

// Integrates from t0 to t1 in `steps` equal steps, calling observer(t, x) at t0 and after every
// step with x = (q, q̇). The observer is any callable (t, const StateOf<nq>&); pass
// [](auto&&...) {} for none. Input is validated before any step: a non-finite or non-positive
// step, t1 ≤ t0, a non-finite state or bad options → invalid_argument; a constrained model
// started off φ = 0 or C q̇ = 0 (beyond opt.initial_tolerance) → inconsistent_initial_state.
template <LagrangianDynamics K, class Observer>
  requires(nv_of<K> == K::nq)
VariationalResult<K::nq> variational(double t0, double t1, long steps, const StateOf<K::nq>& x0,
                                     const double* u, const double* p, Observer&& observer,
                                     const VariationalOptions& opt = {}) noexcept {
  constexpr int n = K::nq, nc = K::nc;
  VariationalResult<K::nq> r;
  r.t = t0;
  r.x = x0;
  bool finite = std::isfinite(t0) && std::isfinite(t1);
  for (double v : x0) finite = finite && std::isfinite(v);
  const double h = steps > 0 ? (t1 - t0) / static_cast<double>(steps) : 0.0;
  const bool options_ok = std::isfinite(opt.tolerance) && opt.tolerance > 0 &&
                          opt.max_iterations >= 1 && std::isfinite(opt.initial_tolerance) &&
                          opt.initial_tolerance >= 0;
  if (!finite || steps <= 0 || !(t1 > t0) || !std::isfinite(h) || !(h > 0) || !(t0 + h > t0) ||
      !options_ok) {
    r.status = Status::invalid_argument;
    return r;
  }
  std::array<double, n> q, qd, mom;
  for (int i = 0; i < n; ++i) {
    q[i] = x0[i];
    qd[i] = x0[n + i];
  }
  if constexpr (nc > 0) {
    const auto residuals = constraint_residuals<K>(q.data(), qd.data(), p);  // max |φ|, |C q̇|
    r.evaluations += 2;
    if (!(std::max(residuals[0], residuals[1]) <= opt.initial_tolerance)) {
      r.status = Status::inconsistent_initial_state;
      return r;
    }
  }
  {
    std::array<double, n * n> M;
    K::mass_matrix(q.data(), p, M.data());
    ++r.evaluations;
    for (int i = 0; i < n; ++i) {
      double s = 0;
      for (int j = 0; j < n; ++j) s += M[i + n * j] * qd[j];
      mom[i] = s;
    }
  }
  observer(r.t, r.x);
  for (long k = 0; k < steps; ++k) {
    const double t = t0 + static_cast<double>(k) * h;
    int step_iterations = 0;
    const auto failure = detail::variational_step<K>(t, h, q.data(), mom.data(), qd.data(), u, p, opt,
                                                     r.evaluations, r.iterations, step_iterations);
    r.max_step_iterations = std::max(r.max_step_iterations, step_iterations);
    if (failure != VariationalFailure::none) {
      r.failure = failure;
      r.status = failure == VariationalFailure::no_convergence ? Status::nonlinear_solve_failed
                                                               : Status::singular_dynamics;
      r.t = t;
      return r;
    }
    bool ok = true;
    for (int i = 0; i < n; ++i) ok = ok && std::isfinite(q[i]) && std::isfinite(qd[i]) && std::isfinite(mom[i]);
    if (!ok) {
      r.status = Status::non_finite_state;
      r.t = t + h;
      for (int i = 0; i < n; ++i) r.x[i] = q[i], r.x[n + i] = qd[i];
      return r;
    }
    for (int i = 0; i < n; ++i) r.x[i] = q[i], r.x[n + i] = qd[i];
    r.t = k + 1 == steps ? t1 : t + h;
    ++r.steps;
    observer(r.t, r.x);  if (detail::stop_requested(observer)) return r;
  }
  return r;
}

// A model with a free joint: Status::method_unavailable (see above), nothing evaluated.
template <LagrangianDynamics K, class Observer>
  requires(nv_of<K> != K::nq)
VariationalResult<K::nq, nv_of<K>> variational(double t0, double, long, const StateFor<K>& x0,
                                               const double*, const double*, Observer&&,
                                               const VariationalOptions& = {}) noexcept {
  VariationalResult<K::nq, nv_of<K>> r;
  r.status = Status::method_unavailable;
  r.t = t0;
  r.x = x0;
  return r;
}

}  // namespace eom
