// eom::Reference<Model>: every kernel of docs/CONTRACT.md §3, with the generated signatures, computed at run
// time by operator-overloading AD (the OCEA way: one embedded evaluation of T over x = (q, q̇)
// yields ∂T/∂q, M and the mixed block ∂²T/∂q̇∂q of eq. 8). It is the oracle every generated kernel
// is tested against and the baseline it is benchmarked against, so it favours the direct reading
// of the definitions over speed.
//
// Real is the arithmetic type (double by default; long double or qd's dd_real give
// high-precision reference trajectories from the very same model source).
#pragma once

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <span>
#include <string_view>

#include "eom/ad.hpp"
#include "eom/body_check.hpp"
#include "eom/jet.hpp"
#include "eom/kernels.hpp"
#include "eom/linalg.hpp"
#include "eom/model.hpp"

namespace eom {

template <class Model, class Real = double>
struct Reference {
  using Info = ModelInfo<Model>;
  static_assert(Info::valid);
  static constexpr int nq = Info::nq, np = Info::np, nu = Info::nu, nc = Info::nc;
  using model_type = Model;
  using real_type = Real;

  static constexpr std::array<std::string_view, np> parameter_names = [] {
    std::array<std::string_view, np> n{};
    if constexpr (np > 0)
      for (int i = 0; i < np; ++i) n[i] = Model::parameters[i];
    return n;
  }();
  static constexpr std::array<double, np> parameter_values = Info::default_parameters();

  // ---- kernels (docs/CONTRACT.md §3) --------------------------------------------------------------------

  static Real kinetic_energy(const Real* q, const Real* qd, const Real* p) noexcept {
    debug_check_bodies(q, p, "kinetic_energy");
    return kinetic_energy_of<Model, Real>(in(q, nq), in(qd, nq), in(p, np));
  }
  static Real potential_energy(const Real* q, const Real* p) noexcept {
    return Model::template potential_energy<Real>(in(q, nq), in(p, np));
  }

  // M = ∂²T/∂q̇² (eq. 7), column-major; T is quadratic in q̇, so it is evaluated at q̇ = 0.
  static void mass_matrix(const Real* q, const Real* p, Real* M) noexcept {
    debug_check_bodies(q, p, "mass_matrix");
    using A = Embedded<nq, Real, 2>;
    const std::array<Real, nq> zero{};
    const A T = kinetic_energy_of<Model, A>(lift<A, nq>(q), seed<A, nq>(zero.data(), 0),
                                                  lift<A, np>(p));
    for (int i = 0; i < nq; ++i)
      for (int j = 0; j < nq; ++j) M[i + nq * j] = T.hessian(i, j);
  }

  // Ṁ = Σₖ ∂M/∂qₖ q̇ₖ: the Hessian over q̇ carried as a directional derivative along q̇ in q.
  static void mass_matrix_dot(const Real* q, const Real* qd, const Real* p, Real* Mdot) noexcept {
    debug_check_bodies(q, p, "mass_matrix_dot");
    using D = Embedded<1, Real, 1>;
    using A = Embedded<nq, D, 2>;
    std::array<A, nq> qa, qda;
    for (int i = 0; i < nq; ++i) {
      D qi(q[i]);
      qi.g[0] = qd[i];
      qa[i] = A(qi);
      qda[i] = A::variable(D(Real(0)), i);
    }
    const A T = kinetic_energy_of<Model, A>(qa, qda, lift<A, np>(p));
    for (int i = 0; i < nq; ++i)
      for (int j = 0; j < nq; ++j) Mdot[i + nq * j] = T.hessian(i, j).g[0];
  }

  // c = Ṁ q̇ − ∂T/∂q (eqs. 6, 8, 11), from one embedded evaluation of T over (q, q̇).
  static void coriolis(const Real* q, const Real* qd, const Real* p, Real* c) noexcept {
    debug_check_bodies(q, p, "coriolis");
    std::array<Real, nq * nq> M;
    mass_and_coriolis(q, qd, p, M.data(), c);
  }

  static void potential_gradient(const Real* q, const Real* p, Real* dVdq) noexcept {
    gradient_of_potential(q, p, dVdq);
  }

  static void generalized_forces(Real t, const Real* q, const Real* qd, const Real* u,
                                 const Real* p, Real* Q) noexcept {
    forces(t, q, qd, u, p, Q);
  }

  static void constraint_residual(const Real* q, const Real* p, Real* phi) noexcept
    requires(nc > 0)
  {
    Model::template constraints<Real>(in(q, nq), in(p, np), std::span<Real>(phi, nc));
  }

  // C = ∂φ/∂q (eq. 10), nc×nq column-major.
  static void constraint_jacobian(const Real* q, const Real* p, Real* C) noexcept
    requires(nc > 0)
  {
    using A = Embedded<nq, Real, 1>;
    std::array<A, nc> phi;
    Model::template constraints<A>(seed<A, nq>(q, 0), lift<A, np>(p), phi);
    for (int i = 0; i < nc; ++i)
      for (int j = 0; j < nq; ++j) C[i + nc * j] = phi[i].g[j];
  }

  // γ = Ċ q̇ = q̇ᵀ (∂²φᵢ/∂q²) q̇.
  static void constraint_bias(const Real* q, const Real* qd, const Real* p, Real* gamma) noexcept
    requires(nc > 0)
  {
    std::array<Real, nc * nq> C;
    jacobian_and_bias(q, qd, p, C.data(), gamma);
  }

  // q̈ from [M Cᵀ; C 0][q̈; μ] = [Q − c − ∂V/∂q; −γ] (range-space method). False, with qdd set to
  // NaN, when an input is not finite or M or C M⁻¹ Cᵀ is not positive definite.
  static bool forward_dynamics(Real t, const Real* q, const Real* qd, const Real* u,
                               const Real* p, Real* qdd) noexcept {
    debug_check_bodies(q, p, "forward_dynamics");
    return dynamics<Real>(t, q, qd, u, p, qdd);
  }

  // ∂q̈/∂q, ∂q̈/∂q̇ (nq×nq) and ∂q̈/∂u (nq×nu), column-major: forward_dynamics run on first-order
  // AD numbers over (q, q̇, u).
  static bool forward_dynamics_derivatives(Real t, const Real* q, const Real* qd, const Real* u,
                                           const Real* p, Real* dqdd_dq, Real* dqdd_dqd,
                                           Real* dqdd_du) noexcept {
    constexpr int nx = 2 * nq + nu;
    using A = Embedded<nx, Real, 1>;
    const auto qa = seed<A, nq>(q, 0), qda = seed<A, nq>(qd, nq);
    const auto ua = seed<A, nu>(u, 2 * nq);
    const auto pa = lift<A, np>(p);
    std::array<A, nq> qdd;
    const bool ok = dynamics<A>(A(t), qa.data(), qda.data(), ua.data(), pa.data(), qdd.data());
    const Real bad = std::numeric_limits<Real>::quiet_NaN();
    for (int i = 0; i < nq; ++i) {
      for (int j = 0; j < nq; ++j) {
        dqdd_dq[i + nq * j] = ok ? qdd[i].g[j] : bad;
        dqdd_dqd[i + nq * j] = ok ? qdd[i].g[nq + j] : bad;
      }
      for (int j = 0; j < nu; ++j) dqdd_du[i + nq * j] = ok ? qdd[i].g[2 * nq + j] : bad;
    }
    return ok;
  }

  // ∂q̈/∂p (nq×np, column-major; column k along parameter k), for parameter identification:
  // forward_dynamics run on first-order AD numbers over p. False, all NaN, exactly when
  // forward_dynamics is false (the pivot tests see the values, not the derivatives).
  static bool forward_dynamics_parameter_derivatives(Real t, const Real* q, const Real* qd,
                                                     const Real* u, const Real* p,
                                                     Real* dqdd_dp) noexcept {
    using A = Embedded<np, Real, 1>;
    const auto qa = lift<A, nq>(q), qda = lift<A, nq>(qd);
    const auto ua = lift<A, nu>(u);
    const auto pa = seed<A, np>(p, 0);
    std::array<A, nq> qdd;
    const bool ok = dynamics<A>(A(t), qa.data(), qda.data(), ua.data(), pa.data(), qdd.data());
    const Real bad = std::numeric_limits<Real>::quiet_NaN();
    for (int i = 0; i < nq; ++i)
      for (int k = 0; k < np; ++k) dqdd_dp[i + nq * k] = ok ? qdd[i].g[k] : bad;
    return ok;
  }

  // τ = M q̈ + c + ∂V/∂q − Q: the extra generalized force that q̈ needs (constraints ignored).
  static void inverse_dynamics(Real t, const Real* q, const Real* qd, const Real* qdd,
                               const Real* u, const Real* p, Real* tau) noexcept {
    std::array<Real, nq * nq> M;
    std::array<Real, nq> c, dV, Q;
    mass_and_coriolis(q, qd, p, M.data(), c.data());
    potential_gradient(q, p, dV.data());
    generalized_forces(t, q, qd, u, p, Q.data());
    for (int i = 0; i < nq; ++i) {
      Real s = c[i] + dV[i] - Q[i];
      for (int j = 0; j < nq; ++j) s += M[i + nq * j] * qdd[j];
      tau[i] = s;
    }
  }

  // ---- Taylor coefficients (contract: generator/README.md, "Taylor mode") ------------
  // qk[k·nq + i] = q_i⁽ᵏ⁾(t)/k!, qdk[k·nq + i] = q̇_i⁽ᵏ⁾(t)/k! for k = 0..order of the solution of
  // q̈ = forward_dynamics through (t, q, q̇), u held constant and t advancing. Computed the direct
  // way: for k = 0..order−1 the templated dynamics run on jets that know q and q̇ to order k (and
  // t + τ), and coefficient k of q̈ gives q̇'s coefficient k+1 (q's comes from q̇'s coefficient k).
  // Order k costs one evaluation on (k+1)-coefficient jets, O(order³) in all: the oracle, not
  // the fast path. Branches and pivot tests see order-0 values (Jet compares those), so the
  // result is false exactly when forward_dynamics is false at (t, q, q̇) — or, beyond the
  // contract's list, when a higher coefficient overflows to Inf/NaN. On false every output of
  // orders 0..order is NaN (nothing is written when order < 0). No workspace: work may be null.
  static constexpr int taylor_max_order = 32;
  static constexpr int taylor_workspace = 0;

  static bool taylor_coefficients(int order, Real t, const Real* q, const Real* qd, const Real* u,
                                  const Real* p, Real* qk, Real* qdk, Real* /*work*/) noexcept {
    using J = Jet<Real, taylor_max_order + 1>;
    const auto fail = [&] {
      const Real bad(std::numeric_limits<double>::quiet_NaN());
      for (int k = 0; k < (order + 1) * nq; ++k) qk[k] = qdk[k] = bad;
      return false;
    };
    if (order < 1 || order > taylor_max_order) return fail();
    for (int i = 0; i < nq; ++i) {
      qk[i] = q[i];
      qdk[i] = qd[i];
    }
    std::array<J, nq> qj, qdj, qddj;
    std::array<J, nu> uj;
    std::array<J, np> pj;
    for (int i = 0; i < nu; ++i) uj[i] = J(u[i]);
    for (int i = 0; i < np; ++i) pj[i] = J(p[i]);
    std::array<Real, taylor_max_order + 1> series;
    for (int k = 0; k < order; ++k) {
      const int known = k + 1;  // coefficients 0..k of q and q̇ are known
      for (int i = 0; i < nq; ++i) {
        for (int j = 0; j < known; ++j) series[j] = qk[j * nq + i];
        qj[i] = J::truncated(series.data(), known);
        for (int j = 0; j < known; ++j) series[j] = qdk[j * nq + i];
        qdj[i] = J::truncated(series.data(), known);
      }
      series[0] = t;
      if (known > 1) series[1] = Real(1);
      for (int j = 2; j < known; ++j) series[j] = Real(0);
      const J tj = J::truncated(series.data(), known);
      if (!dynamics<J>(tj, qj.data(), qdj.data(), uj.data(), pj.data(), qddj.data())) return fail();
      for (int i = 0; i < nq; ++i) {
        const Real a = qddj[i].c[k];  // coefficient k of q̈ (a constant q̈ stores zeros)
        if (!linalg::is_finite(a)) return fail();
        qdk[(k + 1) * nq + i] = a / Real(k + 1);
        qk[(k + 1) * nq + i] = qdk[k * nq + i] / Real(k + 1);
      }
    }
    return true;
  }

 private:
  template <class S> static In<S> in(const S* x, int n) { return In<S>(x, x ? n : 0); }

  // Without NDEBUG, the calls that evaluate T first check the bodies' physical consistency
  // (eom/body_check.hpp) and, like assert, print what is wrong and abort.
  static void debug_check_bodies([[maybe_unused]] const Real* q, [[maybe_unused]] const Real* p,
                                 [[maybe_unused]] const char* function) noexcept {
#ifndef NDEBUG
    if constexpr (detail::declares_bodies<Model> && std::is_floating_point_v<Real>) {
      std::array<double, nq> qv;
      std::array<double, np> pv;
      for (int i = 0; i < nq; ++i) qv[i] = static_cast<double>(q[i]);
      for (int i = 0; i < np; ++i) pv[i] = static_cast<double>(p[i]);
      const std::string problem = body_problem<Model>(qv, pv);
      if (!problem.empty()) {
        std::fprintf(stderr, "eom::Reference<Model>::%s: bodies: %s\n", function, problem.c_str());
        std::abort();
      }
    }
#endif
  }

  // x as AD constants, or as the independent variables offset, offset+1, ...
  template <class A, int n, class R> static std::array<A, n> lift(const R* x) {
    std::array<A, n> a;
    for (int i = 0; i < n; ++i) a[i] = A(x[i]);
    return a;
  }
  template <class A, int n, class R> static std::array<A, n> seed(const R* x, int offset) {
    std::array<A, n> a;
    for (int i = 0; i < n; ++i) a[i] = A::variable(x[i], offset + i);
    return a;
  }

  // ∂V/∂q by first-order AD over q, on any real type R (Real, or AD numbers for derivatives).
  template <class R> static void gradient_of_potential(const R* q, const R* p, R* dVdq) {
    using A = Embedded<nq, R, 1>;
    const A V = Model::template potential_energy<A>(seed<A, nq>(q, 0), lift<A, np>(p));
    for (int i = 0; i < nq; ++i) dVdq[i] = V.g[i];
  }

  // The model's generalized forces, or zeros when it has none.
  template <class R>
  static void forces(const R& t, const R* q, const R* qd, const R* u, const R* p, R* Q) {
    for (int i = 0; i < nq; ++i) Q[i] = R(0);
    if constexpr (Info::has_generalized_forces)
      Model::template generalized_forces<R>(t, in(q, nq), in(qd, nq), in(u, nu), in(p, np),
                                            std::span<R>(Q, nq));
  }

  // One evaluation of T over x = (q, q̇) gives M (q̇q̇ block), ∂T/∂q and the mixed block.
  template <class R>
  static void mass_and_coriolis(const R* q, const R* qd, const R* p, R* M, R* c) {
    using A = Embedded<2 * nq, R, 2>;
    const A T = kinetic_energy_of<Model, A>(seed<A, nq>(q, 0), seed<A, nq>(qd, nq),
                                                  lift<A, np>(p));
    for (int i = 0; i < nq; ++i) {
      R s = -T.g[i];
      for (int j = 0; j < nq; ++j) {
        s += T.hessian(nq + i, j) * qd[j];
        M[i + nq * j] = T.hessian(nq + i, nq + j);
      }
      c[i] = s;
    }
  }

  template <class R>
  static void jacobian_and_bias(const R* q, const R* qd, const R* p, R* C, R* gamma) {
    using A = Embedded<nq, R, 2>;
    std::array<A, nc> phi;
    Model::template constraints<A>(seed<A, nq>(q, 0), lift<A, np>(p), phi);
    for (int i = 0; i < nc; ++i) {
      R g(0);
      for (int j = 0; j < nq; ++j) {
        C[i + nc * j] = phi[i].g[j];
        for (int k = 0; k < nq; ++k) g += qd[j] * phi[i].hessian(j, k) * qd[k];
      }
      gamma[i] = g;
    }
  }

  template <class R>
  static bool dynamics(R t, const R* q, const R* qd, const R* u, const R* p, R* qdd) {
    auto fail = [&] {
      for (int i = 0; i < nq; ++i) qdd[i] = R(std::numeric_limits<double>::quiet_NaN());
      return false;
    };
    if (!linalg::is_finite(t)) return fail();
    for (int i = 0; i < nq; ++i)
      if (!linalg::is_finite(q[i]) || !linalg::is_finite(qd[i])) return fail();
    for (int i = 0; i < nu; ++i)
      if (!linalg::is_finite(u[i])) return fail();
    for (int i = 0; i < np; ++i)
      if (!linalg::is_finite(p[i])) return fail();

    std::array<R, nq * nq> M;
    std::array<R, nq> f, dV, Q;
    mass_and_coriolis(q, qd, p, M.data(), f.data());  // f = c for now
    gradient_of_potential(q, p, dV.data());
    forces(t, q, qd, u, p, Q.data());
    for (int i = 0; i < nq; ++i) f[i] = Q[i] - f[i] - dV[i];

    std::array<R, nc * nq> C{};
    std::array<R, nc> gamma{};
    if constexpr (nc > 0) jacobian_and_bias(q, qd, p, C.data(), gamma.data());
    std::array<R, nq> out;
    if (!linalg::solve_constrained<R, nq, nc>(M, f, C, gamma, out.data())) return fail();
    for (int i = 0; i < nq; ++i)
      if (!linalg::is_finite(out[i])) return fail();
    for (int i = 0; i < nq; ++i) qdd[i] = out[i];
    return true;
  }
};

}  // namespace eom
