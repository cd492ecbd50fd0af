// Radau IIA of order 5 (three stages) for stiff problems, with the step-size control of RADAU5
// (Hairer & Wanner, Solving ODEs II, §IV.8), written for the first-order state x = (q, q̇) of an
// eom model, whose exact Jacobian the generated forward_dynamics_derivatives kernel provides:
//     J = ∂(q̇, q̈)/∂(q, q̇) = [[0, I], [D_q, D_q̇]],   D_q = ∂q̈/∂q, D_q̇ = ∂q̈/∂q̇  (nq×nq).
// Why our own instead of SUNDIALS: the runtime stays header-only, dependency-free and
// allocation-free for fixed-size models, and it takes the generated Jacobian as it is.
//
// Method. The stages Zᵢ = Yᵢ − x₀ solve Z = h (A⊗I) F(Z), Fᵢ = f(t₀ + cᵢh, x₀ + Zᵢ); x₁ = x₀ + Z₃
// (stiffly accurate, L-stable). Simplified Newton with A⁻¹ = T Λ T⁻¹, Λ = γ ⊕ [[α, −β], [β, α]]:
// in W = (T⁻¹⊗I) Z the iteration splits into one real system with (γ/h)I − J and one complex
// system with ((α + iβ)/h)I − J, each of size 2nq. The block form of J reduces each further to
// nq unknowns: (cI − J)(x₁, x₂) = (b₁, b₂) ⇔ (c²I − c D_q̇ − D_q) x₁ = b₂ + (cI − D_q̇) b₁,
// x₂ = c x₁ − b₁. So a step factors one real and one complex nq×nq matrix instead of the 6nq×6nq
// of the plain stage system: ≈ (5/3) nq³ multiply-adds (a complex one counting 4) instead of
// 72 nq³, and nq² complex numbers of storage instead of 36 nq² doubles.
//
// Control (RADAU5's, re-derived, not copied):
//  * Newton: at most 7 iterations from the previous step's collocation polynomial, extrapolated;
//    stops when η‖ΔW‖ ≤ κ (η = θ/(1−θ) from the observed contraction θ, κ = max(10ε/rtol,
//    min(0.03, √rtol))); stops early as divergent (θ ≥ 0.99) or too slow for 7 iterations, and
//    the step is then retried smaller (×0.5, or the factor the contraction predicts).
//  * Error: err = (I − hγ₀J)⁻¹ [γ₀h f(x₀) + γ₀ Σ dᵢ Zᵢ] (γ₀ = 1/γ; the difference to an embedded
//    order-3 solution, filtered by (I − hγ₀J)⁻¹ so that it stays bounded for stiff components),
//    in the weighted RMS norm of adaptive.hpp; after a rejection or at the first step, an
//    estimate above 1 is recomputed once with f(x₀ + err) in place of f(x₀) (the filter alone
//    can let stiff error through at such steps).
//  * Step: h_new = h·min(8, max(0.2, fac·err^(−1/4))), fac = 0.9·(1 + 14)/(Newton iterations +
//    14) ≤ 0.9, and after the first accepted step Gustafsson's predictive controller may shrink it
//    further. No growth right after a rejection; a rejected first step is retried with h/10.
//  * Jacobian reuse: after an accepted step whose Newton contraction θ was ≤ 1e-3 the Jacobian
//    is kept for the next step, and if moreover h_new/h ∈ [1, 1.2], h is kept and so are the LU
//    factors. A failure (error test or Newton) with an old Jacobian evaluates it afresh.
//  * Tolerances: the estimate is O(h⁴) while the global error is O(h⁵), so the estimate is held
//    to rtol' = rtol^(4/5) (atol' = atol·rtol'/rtol), which makes the achieved global error
//    about proportional to the tolerance: measured 6–9 × tol from 1e-4 to 1e-11 on the spring
//    pendulum, against 0.6 → 0.04 × tol (∝ tol^1.2) with the tolerances as given. (RADAU5 maps
//    to 0.1·rtol^(2/3), tuned to its test set; ours follows from the orders.) κ uses rtol'.
//
// Cost accounting. AdaptiveResult::evaluations counts calls of the dynamics (forward_dynamics,
// or its Baumgarte form) only: 3 per Newton iteration, 1 per accepted step for f(x₁), 1 for an
// error estimate recomputed with f(x₀ + err), and 1–2 at the start. The Jacobian evaluations
// (calls of forward_dynamics_derivatives; for eom::Reference a forward-mode AD pass in 2nq + nu
// directions) are NOT in that count: there is one at the start, one after each accepted step
// whose Newton contraction was > 1e-3, and one after a failed attempt that used an older
// Jacobian — so at most accepted + rejected + 1. Wrap K to count them (tests/runtime/
// test_radau5.cpp does).
//
// Dense output (opt.output_times): the collocation polynomial through (t₀, x₀), (t₀ + cᵢh,
// x₀ + Zᵢ), of degree 3: uniformly O(h⁴) (the stage order is 3) against O(h⁵) at step ends, so
// its error grows like tol^(4/5): measured 9–75 × tol for tol = 1e-5 … 1e-11 (step ends 6–9).
//
// Constrained models: Stabilization as for dopri5; projection suits radau5 better. The Jacobian
// is that of forward_dynamics, without the Baumgarte terms (the kernels do not differentiate
// them): Newton still converges, more slowly — measured on the Cartesian pendulum (tol 1e-8,
// α = β = 10/s) 367 steps and 21 Newton rejections, against 322 and 2 with projection. With
// projection, dense output between step ends is the polynomial's state, projected.
//
// A free joint (eom/model/free_joint.hpp): the state is (q, v), nq + nv numbers, and J is taken in that
// embedding from the kernel's tangent-space derivatives (Radau5Matrices below); the quaternion
// is normalized after each accepted step and in every state handed out (state.hpp).
//
// Failures (Status): bad input → invalid_argument before any evaluation; f or its Jacobian
// failing at the start → singular_dynamics; the step limit (accepted + rejected attempts,
// Newton failures included) → step_limit. When h falls below 16ε|t| the status names why the
// last attempt failed: the error test → step_size_underflow, Newton → nonlinear_solve_failed,
// the dynamics at a stage → singular_dynamics. Five singular iteration matrices in a row →
// nonlinear_solve_failed. Never hangs: every pass of the step loop counts an attempt.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <concepts>
#include <limits>

#include "eom/integration/adaptive.hpp"
#include "eom/integration/state.hpp"
#include "eom/model/kernels.hpp"
#include "eom/numeric/linalg.hpp"

namespace eom {

namespace detail {

// Radau IIA, s = 3: nodes c = ((4 − √6)/10, (4 + √6)/10, 1); A from collocation. The constants
// below were computed from A at 40 digits (mpmath) and are checked against A, derived
// independently from the nodes, in tests/runtime/test_radau5.cpp.
struct Radau5Tableau {
  static constexpr double c1 = 0.15505102572168219018027159252941086,
                          c2 = 0.64494897427831780981972840747058914;
  // Eigenvalues of A⁻¹: γ and α ± iβ.
  static constexpr double gamma = 3.6378342527444957322084185135777758,
                          alpha = 2.6810828736277521338957907432111121,
                          beta = 3.0504301992474105694263776247875679;
  // T (row-major tij) with A⁻¹ T = T Λ, Λ = [[γ, 0, 0], [0, α, −β], [0, β, α]]: column 1 is the
  // real eigenvector scaled to last entry 1, columns 2 + i·3 the eigenvector of α − iβ scaled to
  // last entry 1. ti = T⁻¹.
  static constexpr double t11 = 0.094438762488975241487490080, t12 = -0.14125529502095420842799040,
                          t13 = -0.030029194105147424491861120, t21 = 0.25021312296533331137650910,
                          t22 = 0.20412935229379993199599080, t23 = 0.38294211275726193779543820,
                          t31 = 1.0, t32 = 1.0, t33 = 0.0;
  static constexpr double ti11 = 4.1787185915519047273464630, ti12 = 0.32768282076106238708253330,
                          ti13 = 0.52337644549944954803993090, ti21 = -4.1787185915519047273464630,
                          ti22 = -0.32768282076106238708253330, ti23 = 0.47662355450055045196006910,
                          ti31 = -0.50287263494578687595124730, ti32 = 2.5719269498556054291867850,
                          ti33 = -0.59603920482822492496882190;
  // Error estimate: x̂₁ − x₁ = γ₀h f(x₀) + γ₀ Σ dᵢ Zᵢ for the order-3 solution with weight γ₀ = 1/γ
  // on f(x₀): d = (−(13 + 7√6)/3, (−13 + 7√6)/3, −1/3).
  static constexpr double d1 = -10.048809399827415562460330, d2 = 1.3821427331607488957936630,
                          d3 = -1.0 / 3;
};

// RADAU5's control constants (Hairer & Wanner II, §IV.8, and the RADAU5 defaults).
struct Radau5Control {
  static constexpr int max_newton = 7;          // iterations per attempt
  static constexpr double keep_jacobian = 1e-3;  // contraction θ below which J is reused
  static constexpr double safety = 0.9;
  static constexpr double max_growth = 8, max_shrink = 5;  // h_new ∈ [h/5, 8h]
  static constexpr double keep_step_low = 1.0, keep_step_high = 1.2;  // keep h and LU in between
};

template <int nq, int nv = nq> using Radau5Stages = std::array<StateOf<nq, nv>, 3>;

// The Jacobian blocks and the two factored iteration matrices for one step size.
//
// A free joint (nv = nq − 1, eom/model/free_joint.hpp): the state is (q, v) and J = ∂(G(q) v, v̇)/∂(q, v)
// in the embedding is [[A, G], [E, D_v]], with A = ∂(G(q) v)/∂q (δq ↦ ½ δq ⊗ (0, ω) on the
// quaternion, 0 elsewhere), G itself, and E = D_q G⁺ (nv × nq): the kernel's tangent derivative
// D_q composed with G's left inverse G⁺ (δθ = 2 (q̄ ⊗ δq).vec on the quaternion at a unit q,
// the identity elsewhere). E is exact along the tangent directions and blind to the quaternion's
// norm direction, which G(q) v never moves: a simplified Newton needs a good iteration matrix,
// not the exact one. (cI − J)(x₁, x₂) = (b₁, b₂) then reduces to nv unknowns through
// R_c = (cI − A)⁻¹, in closed form since A is skew with A² = −|ω|²/4 on the quaternion:
// R_c = (cI + A)/(c² + |ω|²/4) there and 1/c elsewhere, and
//   (cI − D_v − E R_c G) x₂ = b₂ + E R_c b₁,   x₁ = R_c (b₁ + G x₂).
template <int nq, int nv = nq> struct Radau5Matrices {
  static constexpr bool free = nv != nq;
  std::array<double, nv * nv> dq{}, dqd{};  // ∂v̇/∂q (tangent), ∂v̇/∂v (column-major)
  std::array<double, nv * nv> real{};
  std::array<std::complex<double>, nv * nv> complex{};
  std::array<int, nv> real_pivots{}, complex_pivots{};
  double c_real = 0;                 // γ/h
  std::complex<double> c_complex{};  // (α + iβ)/h
  // A free joint's blocks at the Jacobian's point: G (nq × nv), E = D_q G⁺ (nv × nq), ω.
  std::array<double, free ? nq * nv : 0> g{};
  std::array<double, free ? nv * nq : 0> e{};
  std::array<double, 3> omega{};

  template <class K>
  bool evaluate_jacobian(double t, const StateOf<nq, nv>& x, const double* u,
                         const double* p) noexcept {
    std::array<double, nv * K::nu> dqdd_du;  // unused: u is held over a step
    if (!K::forward_dynamics_derivatives(t, x.data(), x.data() + nq, u, p, dq.data(), dqd.data(),
                                         dqdd_du.data())) {
      detail::note_dynamics_failure<K>(t, x.data(), x.data() + nq, u, p);
      return false;
    }
    for (int i = 0; i < nv * nv; ++i)
      if (!std::isfinite(dq[i]) || !std::isfinite(dqd[i])) return false;
    if constexpr (free) embed(x);
    return true;
  }

  // S(c) = c²I − c D_q̇ − D_q (free joint: cI − D_v − E R_c G), factored.
  template <class Scalar>
  bool factor_one(Scalar c, std::array<Scalar, nv * nv>& S,
                  std::array<int, nv>& piv) const noexcept {
    if constexpr (free) {
      std::array<Scalar, nq> column, rc;
      for (int j = 0; j < nv; ++j) {
        for (int k = 0; k < nq; ++k) column[k] = g[k + nq * j];
        resolvent(c, column.data(), rc.data());
        for (int i = 0; i < nv; ++i) {
          Scalar s(0);
          for (int k = 0; k < nq; ++k) s += e[i + nv * k] * rc[k];
          S[i + nv * j] = (i == j ? c : Scalar(0)) - dqd[i + nv * j] - s;
        }
      }
    } else {
      for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nv; ++i)
          S[i + nv * j] = (i == j ? c * c : Scalar(0)) - c * dqd[i + nv * j] - dq[i + nv * j];
    }
    return linalg::lu_factor<Scalar, nv>(S, piv);
  }

  bool factor(double h) noexcept {
    using R = Radau5Tableau;
    c_real = R::gamma / h;
    c_complex = {R::alpha / h, R::beta / h};
    return factor_one(c_real, real, real_pivots) && factor_one(c_complex, complex, complex_pivots);
  }

  // Solves (cI − J)(x₁, x₂) = (b₁, b₂) in place (b of length nq + nv) through S(c).
  template <class Scalar>
  void solve_one(Scalar c, const std::array<Scalar, nv * nv>& S, const std::array<int, nv>& piv,
                 Scalar* b) const noexcept {
    if constexpr (free) {
      std::array<Scalar, nq> y;
      std::array<Scalar, nv> x2;
      resolvent(c, b, y.data());
      for (int i = 0; i < nv; ++i) {
        Scalar s = b[nq + i];
        for (int k = 0; k < nq; ++k) s += e[i + nv * k] * y[k];
        x2[i] = s;
      }
      linalg::lu_solve<Scalar, nv>(S, piv, x2.data());
      for (int k = 0; k < nq; ++k) {
        Scalar s = b[k];
        for (int j = 0; j < nv; ++j) s += g[k + nq * j] * x2[j];
        y[k] = s;
      }
      resolvent(c, y.data(), b);
      for (int i = 0; i < nv; ++i) b[nq + i] = x2[i];
    } else {
      constexpr int n = nq;
      std::array<Scalar, n> x1;
      for (int i = 0; i < n; ++i) {
        Scalar s = b[n + i] + c * b[i];
        for (int j = 0; j < n; ++j) s -= dqd[i + n * j] * b[j];
        x1[i] = s;
      }
      linalg::lu_solve<Scalar, n>(S, piv, x1.data());
      for (int i = 0; i < n; ++i) {
        b[n + i] = c * x1[i] - b[i];
        b[i] = x1[i];
      }
    }
  }
  void solve_real(double* b) const noexcept { solve_one(c_real, real, real_pivots, b); }
  void solve_complex(std::complex<double>* b) const noexcept {
    solve_one(c_complex, complex, complex_pivots, b);
  }

 private:
  // The free joint's blocks at x: G's columns, G⁺, E = D_q G⁺, ω.
  void embed(const StateOf<nq, nv>& x) noexcept {
    const double* q = x.data();
    for (int j = 0; j < nv; ++j) configuration_direction(Layout(nq, nv), q, j, &g[nq * j]);
    std::array<double, nv * nq> left{};  // G⁺
    for (int k = 0; k < nq; ++k) {
      if (k < 3 || k >= free_joint_nq) {  // x, y, z, the joints: their own velocity
        left[(k < 3 ? k : k - 1) + nv * k] = 1;
        continue;
      }
      // 2 (q̄ ⊗ e_l).vec for the quaternion's unit direction e_l: q̄ = (w, −x, −y, −z), and
      // (a ⊗ b).vec = a₀ b.vec + b₀ a.vec + a.vec × b.vec
      const int l = k - 3;
      const double a0 = q[3], av[3] = {-q[4], -q[5], -q[6]};
      const double b0 = l == 0 ? 1.0 : 0.0;
      const double bv[3] = {l == 1 ? 1.0 : 0.0, l == 2 ? 1.0 : 0.0, l == 3 ? 1.0 : 0.0};
      const double r[3] = {a0 * bv[0] + b0 * av[0] + av[1] * bv[2] - av[2] * bv[1],
                           a0 * bv[1] + b0 * av[1] + av[2] * bv[0] - av[0] * bv[2],
                           a0 * bv[2] + b0 * av[2] + av[0] * bv[1] - av[1] * bv[0]};
      for (int i = 0; i < 3; ++i) left[3 + i + nv * k] = 2 * r[i];
    }
    for (int k = 0; k < nq; ++k)
      for (int i = 0; i < nv; ++i) {
        double s = 0;
        for (int j = 0; j < nv; ++j) s += dq[i + nv * j] * left[j + nv * k];
        e[i + nv * k] = s;
      }
    for (int i = 0; i < 3; ++i) omega[i] = x[nq + 3 + i];
  }
  // out = R_c y = (cI − A)⁻¹ y (nq entries; out may not alias y).
  template <class Scalar> void resolvent(Scalar c, const Scalar* y, Scalar* out) const noexcept {
    for (int k = 0; k < nq; ++k) out[k] = y[k] / c;
    const Scalar* z = y + 3;  // the quaternion's rows: (c z + ½ z ⊗ (0, ω)) / (c² + |ω|²/4)
    const double* w = omega.data();
    const Scalar a[4] = {-(z[1] * w[0] + z[2] * w[1] + z[3] * w[2]),
                         z[0] * w[0] + z[2] * w[2] - z[3] * w[1],
                         z[0] * w[1] + z[3] * w[0] - z[1] * w[2],
                         z[0] * w[2] + z[1] * w[1] - z[2] * w[0]};
    const Scalar d = c * c + 0.25 * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    for (int i = 0; i < 4; ++i) out[3 + i] = (c * z[i] + 0.5 * a[i]) / d;
  }
};

// What one simplified-Newton solve reports, and the contraction estimate it passes on.
struct Radau5Newton {
  enum class Outcome { converged, too_slow, diverged, dynamics_failed };
  double eta = 1;         // θ/(1 − θ) of the last solve: the first iteration's stopping factor
  double theta = 0;       // contraction factor observed in this solve
  int iterations = 0;
  double step_factor = 0.5;  // when not converged: the factor to retry with
};

// Solves the stage equations for the step (t, x, h) from the start values in z (overwritten by
// the solution). `mat` must be factored for h. Scale of the increments: atol + rtol·|x|.
template <class K>
Radau5Newton::Outcome radau5_solve_stages(double t, const StateFor<K>& x, double h,
                                          const double* u, const double* p,
                                          const Stabilization& stab,
                                          const Radau5Matrices<K::nq, nv_of<K>>& mat,
                                          const AdaptiveOptions& opt,
                                          Radau5Stages<K::nq, nv_of<K>>& z, Radau5Newton& newton,
                                          long& evaluations,
                                          int max_iterations = Radau5Control::max_newton) noexcept {
  using R = Radau5Tableau;
  using C = Radau5Control;
  using Outcome = Radau5Newton::Outcome;
  using State = StateFor<K>;
  constexpr int m = K::nq + nv_of<K>;
  constexpr double eps = std::numeric_limits<double>::epsilon();
  const double kappa = std::max(10 * eps / opt.rtol, std::min(0.03, std::sqrt(opt.rtol)));
  const double c[3] = {R::c1, R::c2, 1.0};

  State inv_scale;
  for (int i = 0; i < m; ++i) inv_scale[i] = 1 / (opt.atol + opt.rtol * std::abs(x[i]));
  Radau5Stages<K::nq, nv_of<K>> w, f;
  for (int i = 0; i < m; ++i) {
    w[0][i] = R::ti11 * z[0][i] + R::ti12 * z[1][i] + R::ti13 * z[2][i];
    w[1][i] = R::ti21 * z[0][i] + R::ti22 * z[1][i] + R::ti23 * z[2][i];
    w[2][i] = R::ti31 * z[0][i] + R::ti32 * z[1][i] + R::ti33 * z[2][i];
  }
  newton.eta = std::pow(std::max(newton.eta, eps), 0.8);
  newton.theta = C::keep_jacobian;
  newton.step_factor = 0.5;
  double previous_norm = 0, previous_ratio = 0;
  const double alpha_h = R::alpha / h, beta_h = R::beta / h;
  for (int it = 1; it <= max_iterations; ++it) {
    newton.iterations = it;
    for (int s = 0; s < 3; ++s) {
      State y;
      for (int i = 0; i < m; ++i) y[i] = x[i] + z[s][i];
      ++evaluations;
      if (!state_derivative<K>(t + c[s] * h, y, u, p, f[s], stab)) return Outcome::dynamics_failed;
    }
    // The transformed Newton right-hand sides (T⁻¹F − h⁻¹ΛW), solved in place.
    State real;
    std::array<std::complex<double>, m> cplx;
    for (int i = 0; i < m; ++i) {
      const double g1 = R::ti11 * f[0][i] + R::ti12 * f[1][i] + R::ti13 * f[2][i];
      const double g2 = R::ti21 * f[0][i] + R::ti22 * f[1][i] + R::ti23 * f[2][i];
      const double g3 = R::ti31 * f[0][i] + R::ti32 * f[1][i] + R::ti33 * f[2][i];
      real[i] = g1 - mat.c_real * w[0][i];
      cplx[i] = {g2 - alpha_h * w[1][i] + beta_h * w[2][i], g3 - beta_h * w[1][i] - alpha_h * w[2][i]};
    }
    mat.solve_real(real.data());
    mat.solve_complex(cplx.data());
    double sum = 0;
    for (int i = 0; i < m; ++i) {
      const double a = real[i] * inv_scale[i], b = cplx[i].real() * inv_scale[i],
                   d = cplx[i].imag() * inv_scale[i];
      sum += a * a + b * b + d * d;
    }
    const double norm = std::sqrt(sum / (3 * m));
    if (!std::isfinite(norm)) return Outcome::diverged;
    if (it > 1 && it < max_iterations) {
      const double ratio = norm / previous_norm;
      newton.theta = it == 2 ? ratio : std::sqrt(ratio * previous_ratio);
      previous_ratio = ratio;
      if (!(newton.theta < 0.99)) return Outcome::diverged;
      newton.eta = newton.theta / (1 - newton.theta);
      // The error left after the remaining iterations, in units of κ: too large → retry smaller,
      // by the factor that would bring it to κ (the contraction scales like h^(4 + remaining)).
      const int remaining = max_iterations - 1 - it;
      const double predicted = newton.eta * norm * std::pow(newton.theta, remaining) / kappa;
      if (predicted >= 1) {
        const double q = std::clamp(predicted, 1e-4, 20.0);
        newton.step_factor = 0.8 * std::pow(q, -1.0 / (4 + remaining));
        return Outcome::too_slow;
      }
    }
    previous_norm = std::max(norm, eps);
    for (int i = 0; i < m; ++i) {
      w[0][i] += real[i];
      w[1][i] += cplx[i].real();
      w[2][i] += cplx[i].imag();
      z[0][i] = R::t11 * w[0][i] + R::t12 * w[1][i] + R::t13 * w[2][i];
      z[1][i] = R::t21 * w[0][i] + R::t22 * w[1][i] + R::t23 * w[2][i];
      z[2][i] = R::t31 * w[0][i] + R::t32 * w[1][i] + R::t33 * w[2][i];
    }
    if (newton.eta * norm <= kappa) return Outcome::converged;
  }
  return Outcome::diverged;  // not converged within max_iterations
}

// One step of fixed size h from (t, x): fresh Jacobian, Newton from zero stages to the tolerance
// in opt (as given, untransformed), with up to 50 iterations so that no step is refused as slow.
// x is updated only on success (a free joint's quaternion normalized). For measuring the
// method's order with fixed steps (tests); radau5() below is the integrator.
template <class K>
bool radau5_fixed_step(double t, double h, StateFor<K>& x, const double* u, const double* p,
                       const AdaptiveOptions& opt, long& evaluations) noexcept {
  static_assert(layout_of<K>().free_joint_only(), "eom::radau5: ball joints are not supported yet");
  Radau5Matrices<K::nq, nv_of<K>> mat;
  if (!mat.template evaluate_jacobian<K>(t, x, u, p) || !mat.factor(h)) return false;
  Radau5Stages<K::nq, nv_of<K>> z{};
  Radau5Newton newton;
  if (radau5_solve_stages<K>(t, x, h, u, p, Stabilization{}, mat, opt, z, newton, evaluations,
                             50) != Radau5Newton::Outcome::converged)
    return false;
  for (int i = 0; i < K::nq + nv_of<K>; ++i) x[i] += z[2][i];
  normalize_state<K>(x);
  return true;
}

// The collocation polynomial of an accepted step [t, t + h], in Newton form about its end:
// x(t + θh) = x₁ + (θ − 1)(a₁ + (θ − c₂)(a₂ + (θ − c₁) a₃)), nodes 1, c₂, c₁, 0.
template <int nq, int nv = nq> struct Radau5Polynomial {
  static constexpr int m = nq + nv;
  double t = 0, h = 0;
  StateOf<nq, nv> x1{}, a1{}, a2{}, a3{};

  void fit(double t0, double step, const StateOf<nq, nv>& x0,
           const Radau5Stages<nq, nv>& z) noexcept {
    using R = Radau5Tableau;
    t = t0;
    h = step;
    for (int i = 0; i < m; ++i) {
      x1[i] = x0[i] + z[2][i];
      a1[i] = (z[2][i] - z[1][i]) / (1 - R::c2);
      const double d21 = (z[1][i] - z[0][i]) / (R::c2 - R::c1);  // [c₂, c₁]
      a2[i] = (a1[i] - d21) / (1 - R::c1);
      const double d210 = (d21 - z[0][i] / R::c1) / R::c2;  // [c₂, c₁, 0]
      a3[i] = a2[i] - d210;
    }
  }
  // Offset from x₁ at θ = 1 + s (s > 0 extrapolates into the next step).
  double offset(int i, double s) const noexcept {
    using R = Radau5Tableau;
    return s * (a1[i] + (s + 1 - R::c2) * (a2[i] + (s + 1 - R::c1) * a3[i]));
  }
  void at(double time, StateOf<nq, nv>& x) const noexcept {
    const double s = (time - t) / h - 1;
    for (int i = 0; i < m; ++i) x[i] = x1[i] + offset(i, s);
  }
};

// Why the last attempt failed: names the status if the step size underflows.
enum class Radau5Failure { error_test, newton, dynamics };

template <DifferentiableDynamics K, class Observer>
AdaptiveResult<K::nq, nv_of<K>> radau5_integrate(double t0, double t1, const StateFor<K>& x0,
                                                 const double* u, const double* p,
                                                 const AdaptiveOptions& opt, Observer& observer,
                                                 const Stabilization& stab) noexcept {
  using R = Radau5Tableau;
  using C = Radau5Control;
  using Outcome = Radau5Newton::Outcome;
  using Method = Stabilization::Method;
  using State = StateFor<K>;
  constexpr int n = K::nq, nv = nv_of<K>, m = n + nv;
  constexpr double eps = std::numeric_limits<double>::epsilon();
  AdaptiveResult<n, nv> r;
  r.t = t0;
  r.x = x0;
  if ((r.status = adaptive_start<K>(t0, t1, r.x, p, opt, stab)) != Status::ok) return r;

  // The tolerances the local error estimate (O(h⁴)) is held to: tol^(4/5), so that the global
  // error (O(h⁵)) comes out about proportional to tol; atol keeps its ratio to rtol.
  AdaptiveOptions tol = opt;
  tol.rtol = std::pow(opt.rtol, 0.8);
  tol.atol = opt.atol * (tol.rtol / opt.rtol);

  auto f = [&](double t, const State& x, State& dx) {
    ++r.evaluations;
    return state_derivative<K>(t, x, u, p, dx, stab);
  };
  auto rms = [&](const State& v, const State& a, const State& b) {
    return error_norm(v, a, b, tol);
  };

  State f0;  // f(t, x) at the current step's start
  Radau5Matrices<n, nv> mat;
  if (!f(r.t, r.x, f0) || !mat.template evaluate_jacobian<K>(r.t, r.x, u, p)) {
    r.status = Status::singular_dynamics;
    return r;
  }
  bool jacobian_current = true;  // evaluated at the current (r.t, r.x)
  bool need_jacobian = false;

  double h = std::min(opt.initial_step, t1 - t0);
  if (h == 0) {  // Hairer's starting rule (Solving ODEs I, §II.4) for an error estimate O(h⁴)
    const double d0 = rms(r.x, r.x, r.x), d1 = rms(f0, r.x, r.x);
    double h0 = d0 < 1e-5 || d1 < 1e-5 ? 1e-6 : 0.01 * d0 / d1;
    h0 = std::min(h0, t1 - t0);
    State y, f1, diff;
    for (int i = 0; i < m; ++i) y[i] = r.x[i] + h0 * f0[i];
    if (f(r.t + h0, y, f1)) {
      for (int i = 0; i < m; ++i) diff[i] = (f1[i] - f0[i]) / h0;
      const double d2 = rms(diff, r.x, r.x), dmax = std::max(d1, d2);
      const double h1 = dmax <= 1e-15 ? std::max(1e-6, h0 * 1e-3) : std::pow(0.01 / dmax, 0.25);
      h = std::min({100 * h0, h1, t1 - t0});
    } else {
      h = 1e-3 * h0;  // the probe left the domain of the dynamics: start well inside
    }
    if (!(h > 0)) h = 1e-6 * (t1 - t0);
  }

  constexpr bool monitored = StepMonitor<Observer, State>;
  OutputSchedule schedule(opt.output_times);
  if constexpr (monitored) {
    if (!observer.start(r.t, r.x)) return r;
  } else {
    schedule.start(r.t, r.x, observer);
  }

  Radau5Newton newton;
  Radau5Polynomial<n, nv> poly;
  bool have_poly = false;
  double h_factored = 0;  // the step size mat is factored for (0: none)
  int singular_in_a_row = 0;
  bool first = true, rejected_last = false;
  double h_accepted = 0, err_accepted = 0;  // the previous accepted step, for Gustafsson's rule
  Radau5Failure last_failure = Radau5Failure::error_test;
  Radau5Stages<n, nv> z;

  while (r.t < t1) {
    if (r.accepted + r.rejected >= opt.max_steps) {
      r.status = Status::step_limit;
      return r;
    }
    if (h < 16 * eps * std::max(1.0, std::abs(r.t))) {
      r.status = last_failure == Radau5Failure::newton     ? Status::nonlinear_solve_failed
                 : last_failure == Radau5Failure::dynamics ? Status::singular_dynamics
                                                           : Status::step_size_underflow;
      return r;
    }
    const bool last = r.t + h >= t1;
    if (last) h = t1 - r.t;
    const double t = r.t;

    if (need_jacobian) {
      if (!mat.template evaluate_jacobian<K>(t, r.x, u, p)) {
        r.status = Status::singular_dynamics;
        return r;
      }
      need_jacobian = false;
      jacobian_current = true;
      h_factored = 0;
    }
    if (h != h_factored) {
      if (!mat.factor(h)) {  // (γ/h)I − J singular: h hit an eigenvalue of J; move off it
        h_factored = 0;
        ++r.rejected;
        if (++singular_in_a_row >= 5) {
          r.status = Status::nonlinear_solve_failed;
          return r;
        }
        h *= 0.5;
        continue;
      }
      h_factored = h;
      singular_in_a_row = 0;
    }

    // Start values: the last collocation polynomial, extrapolated; zero at the first step.
    for (int s = 0; s < 3; ++s) {
      const double cs = s == 0 ? R::c1 : s == 1 ? R::c2 : 1.0;
      for (int i = 0; i < m; ++i) z[s][i] = have_poly ? poly.offset(i, cs * h / poly.h) : 0.0;
    }
    const Outcome outcome =
        radau5_solve_stages<K>(t, r.x, h, u, p, stab, mat, tol, z, newton, r.evaluations);

    double err = std::numeric_limits<double>::quiet_NaN();
    State estimate, lead, x1;
    if (outcome == Outcome::converged) {
      for (int i = 0; i < m; ++i) {
        lead[i] = (R::d1 * z[0][i] + R::d2 * z[1][i] + R::d3 * z[2][i]) / h;
        estimate[i] = f0[i] + lead[i];
        x1[i] = r.x[i] + z[2][i];
      }
      mat.solve_real(estimate.data());  // ((γ/h)I − J)⁻¹(f₀ + Σdᵢzᵢ/h) = the filtered estimate
      err = std::max(rms(estimate, r.x, x1), 1e-10);
      if (err >= 1 && (first || rejected_last)) {
        State y, fy;
        for (int i = 0; i < m; ++i) y[i] = r.x[i] + estimate[i];
        if (f(t, y, fy)) {
          for (int i = 0; i < m; ++i) estimate[i] = fy[i] + lead[i];
          mat.solve_real(estimate.data());
          err = std::max(rms(estimate, r.x, x1), 1e-10);
        }
      }
    }
    if (!std::isfinite(err)) {  // Newton failed (or produced a non-finite estimate): retry smaller
      ++r.rejected;
      rejected_last = true;
      last_failure = outcome == Outcome::dynamics_failed ? Radau5Failure::dynamics
                                                         : Radau5Failure::newton;
      h *= outcome == Outcome::too_slow ? newton.step_factor : 0.5;
      if (!jacobian_current) need_jacobian = true;
      continue;
    }

    // The next step size: the asymptotic rule, more cautious after many Newton iterations.
    const double fac =
        std::min(C::safety, C::safety * (1 + 2 * C::max_newton) / (newton.iterations + 2 * C::max_newton));
    double quot = std::clamp(std::pow(err, 0.25) / fac, 1 / C::max_growth, C::max_shrink);
    if (!(err < 1)) {
      ++r.rejected;
      last_failure = Radau5Failure::error_test;
      h = first ? 0.1 * h : h / quot;
      rejected_last = true;
      if (!jacobian_current) need_jacobian = true;
      continue;
    }

    // Accepted.
    if (!first) {  // Gustafsson's predictive controller (HW II, IV.8 (8.25))
      const double gus = std::clamp(
          h_accepted / h * std::pow(err * err / err_accepted, 0.25) / C::safety,
          1 / C::max_growth, C::max_shrink);
      quot = std::max(quot, gus);
    }
    h_accepted = h;
    err_accepted = std::max(1e-2, err);
    double h_new = std::min(h / quot, t1 - t0);
    if (rejected_last) h_new = std::min(h_new, h);

    poly.fit(t, h, r.x, z);
    have_poly = true;
    const State x_start = r.x;
    r.t = last ? t1 : t + h;
    r.x = x1;
    normalize_state<K>(r.x);  // after the error test: the method's own estimate, unchanged
    ++r.accepted;
    first = false;
    rejected_last = false;
    jacobian_current = false;
    if constexpr (K::nc > 0)
      if (stab.method == Method::projection &&
          !project<K>(r.x.data(), r.x.data() + n, p, stab.tolerance)) {
        r.status = Status::projection_failed;
        return r;
      }
    auto interpolate = [&](double time, State& x) {
      poly.at(time, x);
      project_output<K>(x, p, stab);
    };
    if constexpr (monitored) {
      if (!observer.step(t, x_start, r.t, r.x, interpolate)) return r;
    } else {
      schedule.step(r.t, r.x, last, interpolate, observer);
    }
    if (last) break;
    if (!f(r.t, r.x, f0)) {
      r.status = Status::singular_dynamics;
      return r;
    }
    // Keep J while Newton contracted fast; keep h too (and the LU) when it would change little.
    if (newton.theta <= C::keep_jacobian) {
      const double ratio = h_new / h;
      if (ratio >= C::keep_step_low && ratio <= C::keep_step_high) h_new = h;
    } else {
      need_jacobian = true;
    }
    h = h_new;
  }
  return r;
}

}  // namespace detail

// Integrates from t0 to t1 and calls observer(t, x) at t0 and after every accepted step, or
// (opt.output_times) at exactly the requested times. K must provide forward_dynamics_derivatives.
template <Dynamics K, class Observer>
AdaptiveResult<K::nq, nv_of<K>> radau5(double t0, double t1, const StateFor<K>& x0,
                                       const double* u, const double* p,
                                       const AdaptiveOptions& opt, Observer&& observer,
                                       const Stabilization& stab = {}) noexcept {
  static_assert(DifferentiableDynamics<K>,
                "eom::radau5 needs the exact Jacobian: K::forward_dynamics_derivatives(t, q, qd, "
                "u, p, dqdd_dq, dqdd_dqd, dqdd_du) is missing. Generate it (add "
                "forward_dynamics_derivatives to KERNELS in add_eom_model(), or leave KERNELS "
                "out), or use eom::Reference<Model>, which has it.");
  static_assert(layout_of<K>().free_joint_only(),
                "eom::radau5: ball joints are not supported yet (its Newton matrix's tangent map "
                "is the free joint's)");
  if constexpr (DifferentiableDynamics<K>)
    return detail::radau5_integrate<K>(t0, t1, x0, u, p, opt, observer, stab);
  else
    return {};
}

}  // namespace eom
