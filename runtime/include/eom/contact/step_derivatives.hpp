// One contact step and its Jacobians (docs/CONTRACT.md §1, "Step derivatives"): MuJoCo's Euler
// step as eom::contact_step takes it, and ∂x⁺/∂x, ∂x⁺/∂u at the state it started from, x = (δq,
// v) with δq along the tangent directions (a quaternion's in its moving axes: q ⊕ δq), as
// MuJoCo's mjd_transitionFD lays out its A and B.
//
// The solver is differentiated, not run again: at its solution a* the primal gradient
//   g(a; q, v, u) = M (a − a₀) − Jᵀ f(J a − aref)
// is zero, so H da*/dθ = −∂g/∂θ with H = M + Jᵀ C J its Hessian at a* (C the rows' curvature:
// D where quadratic, the elliptic cone's blocks), one Cholesky factor for all 2 nv + nu
// directions. ∂g/∂θ by central differences of g at a* held: per q direction the kernels and the
// rows (collision included) at q ⊕ ±ε e_k, per v or u direction the kernels' a₀ (aref is affine
// in v: B J v moved exactly); no solve per direction, so no Newton iterations' rounding or zone
// changes of the solver inside a difference. Where the rows at one side of a q direction differ
// from the state's (a contact made or lost, a limit reached) the other side's one-sided
// difference is taken. The step's chain rule is exact: implicit damping a = (M + hB)⁻¹ M a*,
// v⁺ = v + h a, q⁺ = q ⊕ h v⁺ (a quaternion turned by Exp(δ), δ = h ω⁺: ∂q⁺/∂q = Exp(δ)ᵀ,
// ∂q⁺/∂δ = the right Jacobian Jr(δ)).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <span>

#include "eom/contact/step.hpp"

namespace eom {

// The Jacobians of a step and their workspace (caller-owned, as eom::ContactStepper).
template <class K, class Model> struct StepDerivatives {
  static constexpr int nv = K::nv, nu = K::nu, n = 2 * nv;
  std::array<double, n * n> A;                   // ∂x⁺/∂x, 2nv × 2nv, column-major
  std::array<double, n * std::max(nu, 1)> B;     // ∂x⁺/∂u, 2nv × nu, column-major

  // Workspace: the rows at a perturbed state, the residuals and forces there, the directions'
  // right-hand sides (q, v, u columns) and ∂M/∂q_k (a* − a).
  ConstraintRows<Model> rows;
  std::array<double, ConstraintRows<Model>::capacity> jar, force;
  std::array<double, nv * (2 * nv + nu)> rhs;
  std::array<double, nv * nv> dM;
};

namespace detail {

// Whether two sets of rows are the same constraints (kind, what each row is of, and for a
// contact its pair), so that a difference of g across them is smooth.
template <class Model>
bool same_rows(const ConstraintRows<Model>& a, const ConstraintRows<Model>& b) {
  if (a.rows != b.rows) return false;
  for (int r = 0; r < a.rows; ++r) {
    if (a.kind[r] != b.kind[r] || a.id[r] != b.id[r]) return false;
    const bool contact = a.kind[r] == RowKind::frictionless || a.kind[r] == RowKind::pyramidal ||
                         a.kind[r] == RowKind::elliptic;
    if (contact && a.contact_pair[a.id[r]] != b.contact_pair[b.id[r]]) return false;
  }
  return true;
}

// Exp(δ)ᵀ and the right Jacobian Jr(δ) of a rotation vector δ (3 × 3, column-major): Exp(δ + x)
// = Exp(δ) Exp(Jr(δ) x) to first order in x. Series below θ = 1e-4 (their next terms are θ⁴).
inline void rotation_tangents(const double* d, std::array<double, 9>& Rt, std::array<double, 9>& Jr) {
  const double t2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], t = std::sqrt(t2);
  const bool small = t < 1e-4;
  const double s1 = small ? 1 - t2 / 6 : std::sin(t) / t;             // sin θ / θ
  const double c2 = small ? 0.5 - t2 / 24 : (1 - std::cos(t)) / t2;   // (1 − cos θ) / θ²
  const double s3 = small ? 1.0 / 6 - t2 / 120 : (t - std::sin(t)) / (t2 * t);  // (θ − sin θ)/θ³
  const std::array<double, 9> X{0, d[2], -d[1], -d[2], 0, d[0], d[1], -d[0], 0};  // [δ]×
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double I = i == j ? 1 : 0, x = X[i + 3 * j];
      const double X2 = d[i] * d[j] - I * t2;  // [δ]×² = δ δᵀ − θ² I
      Rt[i + 3 * j] = I - s1 * x + c2 * X2;
      Jr[i + 3 * j] = I - c2 * x + s3 * X2;
    }
}

}  // namespace detail

// One step as eom::contact_step (the state advanced bitwise alike) and, in d, its Jacobians at
// the state it started from. MuJoCo's Euler integrator only (a model stating RK4 stops the
// build). On a status other than ok the state is left as it was and d's Jacobians are not
// written.
template <class K, class Model>
StepStatus contact_step_derivatives(ContactStepper<K, Model>& s, StepDerivatives<K, Model>& d,
                                    double& t, std::span<double, K::nq> q,
                                    std::span<double, K::nv> v, const double* u, const double* p) {
  static_assert(Model::solver_options.integrator == 0,
                "eom::contact_step_derivatives: MuJoCo's Euler integrator only; the model states "
                "RK4 (<option integrator=\"RK4\">)");
  constexpr int nq = K::nq, nv = K::nv, nu = K::nu, nc = std::max(K::nc, 1);
  constexpr int n = 2 * nv, columns = 2 * nv + nu;
  const double h = Model::solver_options.timestep;
  const Layout layout = layout_of<K>();
  // Central differences' steps. g is quadratic in v and affine in u but in the elliptic cone's
  // curved zone; in q the impedance bends over its solimp width (MuJoCo's default 1 mm), so
  // ε_q is far below it: truncation (ε_q / width)² beside rounding's u |g's terms| / ε_q.
  constexpr double eps = 0x1p-20, eps_q = 0x1p-24;

  std::array<double, nv * nv> M;
  std::array<double, nv> a0;
  if (const StepStatus status = detail::constrained_acceleration(s, t, q.data(), v.data(), u, p, M, a0);
      status != StepStatus::ok)
    return status;
  std::array<double, nv> a;  // with implicit damping, what the step takes
  if (!detail::damped_acceleration(s, M, a0, a)) return StepStatus::solver_failed;
  const std::array<double, nv>& a_star = s.solution.qacc;
  bool damped = false;
  for (double b : Model::damping) damped |= b > 0;

  // Newton's matrix at a*, factored (the solver's workspace is free once it has solved).
  ConstraintSolution<Model>& w = s.solution;
  detail::residuals<Model>(s.rows, a_star.data(), w.jar.data());
  detail::row_costs<Model>(s.rows, w.jar.data(), w.trial_force.data(), w.curvature.data(), &w.cone);
  alignas(64) std::array<double, nv * nv> H;
  detail::newton_hessian<Model>(M, s.rows, w.curvature.data(), w.cone, H);
  if (!linalg::cholesky<double, nv>(H)) return StepStatus::solver_failed;

  // g at a* for M', a₀' and the rows `rows` (aref: theirs or moved), and M'(a* − a).
  std::array<double, nv> a_minus;
  for (int i = 0; i < nv; ++i) a_minus[i] = a_star[i] - a[i];
  auto gradient = [&](const std::array<double, nv * nv>& M1, const std::array<double, nv>& a01,
                      const ConstraintRows<Model>& rows, const double* aref, double* g, double* Mx) {
    detail::primal_gradient<Model>(M1, a01, rows, aref, a_star, d.jar.data(), d.force.data(), g);
    if (damped) detail::M_times<nv>(M1, a_minus.data(), Mx);
  };
  std::array<double, nv> g0, Mx0;
  gradient(M, a0, s.rows, s.rows.aref.data(), g0.data(), Mx0.data());

  // q directions: the kernels and rows at q ⊕ ±ε e_k.
  std::array<double, nq> q1;
  std::array<double, nv> e{}, a01, g[2], Mx[2];
  std::array<double, nv * nv> M1;
  std::array<double, nc> phi{};
  std::array<double, nc * nv> C{};
  for (int k = 0; k < nv; ++k) {
    bool same[2];
    e[k] = 1;
    for (int side = 0; side < 2; ++side) {
      integrate_configuration(layout, q.data(), e.data(), side == 0 ? eps_q : -eps_q, q1.data());
      if (const StepStatus status = detail::smooth_dynamics<K>(t, q1.data(), v.data(), u, p, M1, a01, phi, C);
          status != StepStatus::ok)
        return status;
      if (!constraint_rows<Model>(s.links, std::span<const double>(q1.data(), nq),
                                  std::span<const double>(v.data(), nv), d.rows, &s.unmodeled_pair,
                                  phi.data(), C.data()))
        return StepStatus::unmodeled_pair;
      same[side] = detail::same_rows<Model>(d.rows, s.rows);
      gradient(M1, a01, d.rows, d.rows.aref.data(), g[side].data(), Mx[side].data());
    }
    e[k] = 0;
    // Central, or one-sided from the side whose rows are the state's.
    const int hi = same[0] || !same[1] ? 0 : -1, lo = same[1] || !same[0] ? 1 : -1;
    const double* gp = hi == 0 ? g[0].data() : g0.data();
    const double* gm = lo == 1 ? g[1].data() : g0.data();
    const double* xp = hi == 0 ? Mx[0].data() : Mx0.data();
    const double* xm = lo == 1 ? Mx[1].data() : Mx0.data();
    const double width = (hi == 0 ? eps_q : 0) + (lo == 1 ? eps_q : 0);
    for (int i = 0; i < nv; ++i) {
      d.rhs[i + nv * k] = -(gp[i] - gm[i]) / width;
      if (damped) d.dM[i + nv * k] = (xp[i] - xm[i]) / width;
    }
  }
  // v directions: a₀ at v ± ε e_k; aref moved by −B (J e_k) (±ε).
  std::array<double, ConstraintRows<Model>::capacity> aref;
  std::array<double, nv> v1;
  for (int k = 0; k < nv; ++k) {
    for (int side = 0; side < 2; ++side) {
      const double step = side == 0 ? eps : -eps;
      v1 = {};
      std::copy(v.begin(), v.end(), v1.begin());
      v1[k] += step;
      if (const StepStatus status = detail::smooth_dynamics<K>(t, q.data(), v1.data(), u, p, M1, a01, phi, C);
          status != StepStatus::ok)
        return status;
      for (int r = 0; r < s.rows.rows; ++r)
        aref[r] = s.rows.aref[r] - s.rows.aref_damping[r] * s.rows.J[static_cast<std::size_t>(r) * nv + k] *
                                       (v1[k] - v[k]);
      gradient(M, a01, s.rows, aref.data(), g[side].data(), Mx[side].data());
    }
    const double width = (v[k] + eps) - (v[k] - eps);  // the steps as taken
    for (int i = 0; i < nv; ++i) d.rhs[i + nv * (nv + k)] = -(g[0][i] - g[1][i]) / width;
  }
  // u directions: a₀ at u ± ε e_k.
  std::array<double, std::max(nu, 1)> u1{};
  for (int k = 0; k < nu; ++k) {
    for (int side = 0; side < 2; ++side) {
      std::copy(u, u + nu, u1.begin());
      u1[k] += side == 0 ? eps : -eps;
      if (const StepStatus status = detail::smooth_dynamics<K>(t, q.data(), v.data(), u1.data(), p, M1, a01, phi, C);
          status != StepStatus::ok)
        return status;
      gradient(M, a01, s.rows, s.rows.aref.data(), g[side].data(), Mx[side].data());
    }
    const double width = (u[k] + eps) - (u[k] - eps);
    for (int i = 0; i < nv; ++i) d.rhs[i + nv * (2 * nv + k)] = -(g[0][i] - g[1][i]) / width;
  }

  // da*/dθ = H⁻¹ (−∂g/∂θ); with damping da/dθ = (M + hB)⁻¹ (M da*/dθ + ∂M/∂θ (a* − a)).
  for (int c = 0; c < columns; ++c) linalg::cholesky_solve<double, nv>(H, d.rhs.data() + nv * c);
  if (damped) {
    alignas(64) std::array<double, nv * nv> Hd = M;
    for (int i = 0; i < nv; ++i) Hd[i + nv * i] += h * Model::damping[i];
    if (!linalg::cholesky<double, nv>(Hd)) return StepStatus::solver_failed;
    std::array<double, nv> y;
    for (int c = 0; c < columns; ++c) {
      double* x = d.rhs.data() + nv * c;
      detail::M_times<nv>(M, x, y.data());
      if (c < nv)
        for (int i = 0; i < nv; ++i) y[i] += d.dM[i + nv * c];
      linalg::cholesky_solve<double, nv>(Hd, y.data());
      std::copy(y.begin(), y.end(), x);
    }
  }

  // The chain rule of v⁺ = v + h a, q⁺ = q ⊕ h v⁺: column c of ∂v⁺ is h da/dθ_c (+ e for v's),
  // of ∂q⁺ the tangent map of q's own move (identity, or Exp(δ)ᵀ on a quaternion's three) for q's
  // columns plus Jr(δ) h ∂v⁺ (Jr the identity off quaternions).
  std::array<double, nv> v_next;
  for (int i = 0; i < nv; ++i) v_next[i] = v[i] + h * a[i];
  auto column = [&](int c) { return c < n ? d.A.data() + n * c : d.B.data() + n * (c - n); };
  for (int c = 0; c < columns; ++c) {
    double* out = column(c);
    const double* da = d.rhs.data() + nv * c;
    for (int i = 0; i < nv; ++i) out[nv + i] = h * da[i] + (c == nv + i ? 1 : 0);
    layout.walk([&](int, int j) { out[j] = h * out[nv + j] + (c == j ? 1 : 0); },
                [&](int, int j) {
                  std::array<double, 3> delta{h * v_next[j], h * v_next[j + 1], h * v_next[j + 2]};
                  std::array<double, 9> Rt, Jr;
                  detail::rotation_tangents(delta.data(), Rt, Jr);
                  const bool own = c >= j && c < j + 3;  // a direction of this quaternion
                  for (int r = 0; r < 3; ++r) {
                    double x = own ? Rt[r + 3 * (c - j)] : 0;
                    for (int l = 0; l < 3; ++l) x += Jr[r + 3 * l] * h * out[nv + j + l];
                    out[j + r] = x;
                  }
                });
  }

  detail::euler_update<K>(h, a, t, q, v);
  return StepStatus::ok;
}

}  // namespace eom
