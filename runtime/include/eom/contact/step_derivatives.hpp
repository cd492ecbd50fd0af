// One contact step and its Jacobians (docs/CONTRACT.md §1, "Step derivatives"): MuJoCo's Euler
// step as eom::contact_step takes it, and ∂x⁺/∂x, ∂x⁺/∂u at the state it started from, x = (δq,
// v) with δq along the tangent directions (a quaternion's in its moving axes: q ⊕ δq), as
// MuJoCo's mjd_transitionFD lays out its A and B.
//
// The solver is differentiated, not run again: at its solution a* the primal gradient
//   g(a; q, v, u) = M (a − a₀) − Jᵀ f(J a − aref)
// is zero, so H da*/dθ = −∂g/∂θ with H = M + Jᵀ C J its Hessian at a* (C the rows' curvature:
// D where quadratic, the elliptic cone's blocks), one Cholesky factor for all 2 nv + nu
// directions; no solve per direction, so no Newton iterations' rounding or zone changes inside a
// difference. ∂g/∂θ = −M ∂a₀/∂θ + the rows' part: ∂a₀/∂(q, v, u) from K's
// forward_dynamics_derivatives where KERNELS has them, else by central differences of a₀; the
// rows' part in v exactly (aref is affine in v: −Jᵀ C B J), in q by central differences of M'(a* −
// a₀) − J'ᵀ f(J' a* − aref') with M' and the rows (collision included) at q ⊕ ±ε e_k. Where the
// rows at one side of a q direction differ from the state's (a contact made or lost, a limit
// reached) the other side's one-sided difference is taken. The step's chain rule is exact:
// implicit damping a = (M + hB)⁻¹ M a*, v⁺ = v + h a, q⁺ = q ⊕ h v⁺ (a quaternion turned by
// Exp(δ), δ = h ω⁺: ∂q⁺/∂q = Exp(δ)ᵀ, ∂q⁺/∂δ = the right Jacobian Jr(δ)).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <span>

#include "eom/contact/step.hpp"

namespace eom {

// The Jacobians of a step and their workspace (caller-owned, as eom::ContactStepper).
template <class K, class Model> struct StepDerivatives {
  static constexpr int nv = K::nv, nu = K::nu, n = 2 * nv;
  std::array<double, n * n> A;                   // ∂x⁺/∂x, 2nv × 2nv, column-major
  std::array<double, n * std::max(nu, 1)> B;     // ∂x⁺/∂u, 2nv × nu, column-major

  // Workspace: the rows at a perturbed state, the residuals and forces there, the directions'
  // right-hand sides (q, v, u columns), ∂a₀/∂(q, v, u) and ∂M/∂q_k (a* − a).
  ConstraintRows<Model> rows;
  std::array<double, ConstraintRows<Model>::capacity> jar, force;
  static constexpr std::size_t npairs = std::max<std::size_t>(Model::collision_pairs.size(), 1);
  std::array<int, npairs> pairs;  // those in contact at the state, then those a direction moves
  std::array<bool, npairs> kept;  // whether a pair is among a direction's
  std::array<double, nv * (2 * nv + nu)> rhs, da0;  // da0: ∂a₀/∂(q, v, u), nv × (2nv + nu)
  std::array<double, nv * nv> dM;
};

namespace detail {

// Whether `a` are the rows of `base` less the contacts of the pairs not `kept` (a's were made
// from those pairs alone): the same constraints in order (kind and what each row is of: a
// contact's pair), so that a difference of g across them is smooth.
template <class Model>
bool same_rows(const ConstraintRows<Model>& a, const ConstraintRows<Model>& base, const bool* kept) {
  int r = 0;
  for (int b = 0; b < base.rows; ++b) {
    const bool contact = is_contact(base.kind[b]);
    if (contact && !kept[base.contact_pair[base.id[b]]]) continue;
    if (r == a.rows || a.kind[r] != base.kind[b]) return false;
    if (contact ? a.contact_pair[a.id[r]] != base.contact_pair[base.id[b]] : a.id[r] != base.id[b])
      return false;
    ++r;
  }
  return r == a.rows;
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
  // Central differences' steps: in v and u about the cube root of the rounding; in q far below
  // the width over which the impedance bends (solimp's, MuJoCo's default 1 mm): truncation
  // (ε_q / width)² beside rounding's u |g's terms| / ε_q.
  constexpr double eps = 0x1p-20, eps_q = 0x1p-24;

  std::array<double, nv * nv> M;
  std::array<double, nv> a0;
  if (const StepStatus status = detail::constrained_acceleration(s, t, q.data(), v.data(), u, p, M, a0);
      status != StepStatus::ok)
    return status;
  std::array<double, nv> a;  // with implicit damping, what the step takes
  alignas(64) std::array<double, nv * nv> Hd;  // M + h B's factor, where damped
  if (!detail::damped_acceleration(s, M, a0, a, Hd)) return StepStatus::solver_failed;
  const std::array<double, nv>& a_star = s.solution.qacc;
  constexpr bool damped = detail::damped<Model>();

  // Newton's matrix at a*, factored (the solver's workspace is free once it has solved).
  ConstraintSolution<Model>& w = s.solution;
  detail::residuals<Model>(s.rows, a_star.data(), w.jar.data());
  detail::row_costs<Model>(s.rows, w.jar.data(), w.trial_force.data(), w.curvature.data(), &w.cone);
  alignas(64) std::array<double, nv * nv> H;
  detail::newton_hessian<Model>(M, s.rows, w.curvature.data(), w.cone, H);
  if (!linalg::cholesky<double, nv>(H)) return StepStatus::solver_failed;

  // ∂a₀/∂(q, v, u): K's forward_dynamics_derivatives where it has them (and no equality
  // constraints, whose a₀ is not its forward dynamics), else central differences of a₀ (q's in
  // the loop over q below).
  constexpr bool a0_kernel =
      K::nc == 0 && requires(double* x) { K::forward_dynamics_derivatives(t, x, x, x, x, x, x, x); };
  std::array<double, nq> q1;
  std::array<double, nv> v1, e{}, a0_side[2];
  std::array<double, std::max(nu, 1)> u1{};
  std::array<double, nv * nv> M1;
  std::array<double, nc> phi{};
  std::array<double, nc * nv> C{};
  if constexpr (a0_kernel) {
    if (!K::forward_dynamics_derivatives(t, q.data(), v.data(), u, p, d.da0.data(), d.da0.data() + nv * nv,
                                         d.da0.data() + 2 * nv * nv))
      return StepStatus::dynamics_failed;
  } else {
    for (int k = 0; k < nv + nu; ++k) {  // v's, then u's
      for (int side = 0; side < 2; ++side) {
        std::copy(v.begin(), v.end(), v1.begin());
        if (nu > 0) std::copy(u, u + nu, u1.begin());
        double& x = k < nv ? v1[k] : u1[k - nv];
        x += side == 0 ? eps : -eps;
        if (const StepStatus status =
                detail::smooth_dynamics<K>(t, q.data(), v1.data(), u1.data(), p, M1, a0_side[side], phi, C);
            status != StepStatus::ok)
          return status;
      }
      const double width = k < nv ? (v[k] + eps) - (v[k] - eps) : (u[k - nv] + eps) - (u[k - nv] - eps);
      for (int i = 0; i < nv; ++i) d.da0[i + nv * (nv + k)] = (a0_side[0][i] - a0_side[1][i]) / width;
    }
  }

  // q directions: the rows' part of g, M'(a* − a₀) − J'ᵀ f(J' a* − aref'), with M' and the rows
  // at q ⊕ ±ε e_k (a₀ held: its part is M ∂a₀/∂q below); and M'(a* − a) for the damping.
  std::array<double, nv> a_minus, g0, g_state, Mx0, g[2], Mx[2];
  for (int i = 0; i < nv; ++i) a_minus[i] = a_star[i] - a[i];
  auto gradient = [&](const std::array<double, nv * nv>& M1, const ConstraintRows<Model>& rows,
                      double* g, double* Mx) {
    detail::primal_gradient<Model>(M1, a0, rows, rows.aref.data(), a_star, d.jar.data(), d.force.data(), g);
    if (damped) detail::M_times<nv>(M1, a_minus.data(), Mx);
  };
  gradient(M, s.rows, g0.data(), Mx0.data());
  // Only the pairs in contact at the state are collided again (a pair apart from it by more than
  // ε_q's reach keeps no contact; one within it would make the step not differentiable), and of
  // those only the ones a direction moves: velocity k moves the links whose joint takes it (a
  // mimic's too) and all below them; the other contacts' rows, and their part of g, stay as
  // they are and drop out of the difference.
  int in_contact = 0;
  for (int c = 0; c < s.rows.ncontacts; ++c)
    if (in_contact == 0 || d.pairs[in_contact - 1] != s.rows.contact_pair[c])
      d.pairs[in_contact++] = s.rows.contact_pair[c];
  constexpr std::size_t N = Model::link_count;
  const std::array<int, N> offsets = detail::velocity_offsets(s.links);
  std::array<bool, N> moved;
  std::array<int, StepDerivatives<K, Model>::npairs> pairs_k;
  const std::array<Transform<double>, N> X0 = tree_placements(s.links, std::span<const double>(q.data(), nq));
  std::array<Transform<double>, N> X1;
  for (int k = 0; k < nv; ++k) {
    for (std::size_t l = 0; l < N; ++l) {
      const TreeLink<double>& link = s.links[l];
      moved[l] = (offsets[l] >= 0 && k >= offsets[l] && k < offsets[l] + detail::joint_velocities(link)) ||
                 (link.parent >= 0 && moved[static_cast<std::size_t>(link.parent)]);
    }
    int count = 0;
    d.kept.fill(false);
    for (int i = 0; i < in_contact; ++i) {
      const CollisionPair& pair = Model::collision_pairs[d.pairs[i]];
      const int a = Model::geoms[pair.geom1].link, b = Model::geoms[pair.geom2].link;
      if ((a >= 0 && moved[a]) || (b >= 0 && moved[b])) pairs_k[count++] = d.pairs[i], d.kept[d.pairs[i]] = true;
    }
    bool same[2];
    e[k] = 1;
    for (int side = 0; side < 2; ++side) {
      integrate_configuration(layout, q.data(), e.data(), side == 0 ? eps_q : -eps_q, q1.data());
      const std::span<const double> at(q1.data(), nq);
      X1 = X0;  // the links the direction moves placed again
      for (std::size_t l = 0; l < N; ++l)
        if (moved[l]) X1[l] = link_placement(s.links, X1, l, at);
      if constexpr (a0_kernel) {
        K::mass_matrix(q1.data(), p, M1.data());
      } else if (const StepStatus status =
                     detail::smooth_dynamics<K>(t, q1.data(), v.data(), u, p, M1, a0_side[side], phi, C);
                 status != StepStatus::ok) {
        return status;
      }
      if (!detail::rows_at<Model>(s.links, X1, at, std::span<const double>(v.data(), nv), d.rows,
                                  &s.unmodeled_pair, phi.data(), C.data(),
                                  std::span<const int>(pairs_k.data(), static_cast<std::size_t>(count))))
        return StepStatus::unmodeled_pair;
      same[side] = detail::same_rows<Model>(d.rows, s.rows, d.kept.data());
      gradient(M1, d.rows, g[side].data(), Mx[side].data());
    }
    // One-sided where one side's rows are not the state's: g at the state with the same pairs,
    // the other pairs' contacts' Jᵀ f taken out of g0.
    if (same[0] != same[1]) {
      std::array<double, nv> out{};
      for (int r = 0; r < s.rows.rows; ++r) {
        if (is_contact(s.rows.kind[r]) && !d.kept[s.rows.contact_pair[s.rows.id[r]]])
          for (int j = 0; j < nv; ++j) out[j] += s.rows.J[static_cast<std::size_t>(r) * nv + j] * s.solution.force[r];
      }
      for (int j = 0; j < nv; ++j) g_state[j] = g0[j] + out[j];
    }
    e[k] = 0;
    if constexpr (!a0_kernel)
      for (int i = 0; i < nv; ++i) d.da0[i + nv * k] = (a0_side[0][i] - a0_side[1][i]) / (2 * eps_q);
    // Central, or one-sided from the side whose rows are the state's.
    const int hi = same[0] || !same[1] ? 0 : -1, lo = same[1] || !same[0] ? 1 : -1;
    const double* gp = hi == 0 ? g[0].data() : g_state.data();
    const double* gm = lo == 1 ? g[1].data() : g_state.data();
    const double* xp = hi == 0 ? Mx[0].data() : Mx0.data();
    const double* xm = lo == 1 ? Mx[1].data() : Mx0.data();
    const double width = (hi == 0 ? eps_q : 0) + (lo == 1 ? eps_q : 0);
    for (int i = 0; i < nv; ++i) {
      d.rhs[i + nv * k] = -(gp[i] - gm[i]) / width;
      if (damped) d.dM[i + nv * k] = (xp[i] - xm[i]) / width;
    }
  }

  // −∂g/∂θ = M ∂a₀/∂θ + (q's: the rows' part above; v's: −Jᵀ C ∂(J a − aref)/∂v = −Jᵀ C B J,
  // C the rows' curvature at a*, exact as aref is affine in v).
  for (int c = 0; c < columns; ++c) {
    std::array<double, nv> y;
    detail::M_times<nv>(M, d.da0.data() + nv * c, y.data());
    for (int i = 0; i < nv; ++i) d.rhs[i + nv * c] = (c < nv ? d.rhs[i + nv * c] : 0) + y[i];
  }
  const ConstraintRows<Model>& rows = s.rows;
  for (int k = 0; k < nv; ++k) {
    double* x = d.jar.data();  // B J e_k, then C of it
    for (int r = 0; r < rows.rows; ++r) {
      const double b = rows.aref_damping[r] * rows.J[static_cast<std::size_t>(r) * nv + k];
      d.force[r] = b;
      x[r] = w.curvature[r] * b;
    }
    detail::cone_blocks<Model>(rows, w.cone, [&](int r, int i, int j, double h) { x[r + i] += h * d.force[r + j]; });
    std::array<double, nv> y;
    detail::JT_times<Model>(rows, x, y.data());
    for (int i = 0; i < nv; ++i) d.rhs[i + nv * (nv + k)] -= y[i];
  }

  // da*/dθ = H⁻¹ (−∂g/∂θ); with damping da/dθ = (M + hB)⁻¹ (M da*/dθ + ∂M/∂θ (a* − a)).
  linalg::cholesky_solve_columns<double, nv>(H, d.rhs.data(), columns);
  if constexpr (damped) {  // Hd factored by damped_acceleration
    std::array<double, nv> y;
    for (int c = 0; c < columns; ++c) {
      double* x = d.rhs.data() + nv * c;
      detail::M_times<nv>(M, x, y.data());
      if (c < nv)
        for (int i = 0; i < nv; ++i) y[i] += d.dM[i + nv * c];
      std::copy(y.begin(), y.end(), x);
    }
    linalg::cholesky_solve_columns<double, nv>(Hd, d.rhs.data(), columns);
  }

  for (double x : d.rhs)  // e.g. a kernel's NaN at a perturbed state: nothing written
    if (!std::isfinite(x)) return StepStatus::dynamics_failed;

  // The chain rule of v⁺ = v + h a, q⁺ = q ⊕ h v⁺: column c of ∂v⁺ is h da/dθ_c (+ e for v's),
  // of ∂q⁺ the tangent map of q's own move (identity, or Exp(δ)ᵀ on a quaternion's three) for q's
  // columns plus Jr(δ) h ∂v⁺ (Jr the identity off quaternions).
  std::array<double, nv> v_next;
  for (int i = 0; i < nv; ++i) v_next[i] = v[i] + h * a[i];
  constexpr int quaternions = std::max(nq - nv, 1);
  std::array<std::array<double, 9>, quaternions> Rt, Jr;  // each quaternion's, in q's order
  int at = 0;
  layout.walk([](int, int) {}, [&](int, int j) {
    const std::array<double, 3> delta{h * v_next[j], h * v_next[j + 1], h * v_next[j + 2]};
    detail::rotation_tangents(delta.data(), Rt[at], Jr[at]);
    ++at;
  });
  auto column = [&](int c) { return c < n ? d.A.data() + n * c : d.B.data() + n * (c - n); };
  for (int c = 0; c < columns; ++c) {
    double* out = column(c);
    const double* da = d.rhs.data() + nv * c;
    for (int i = 0; i < nv; ++i) out[nv + i] = h * da[i] + (c == nv + i ? 1 : 0);
    at = 0;
    layout.walk([&](int, int j) { out[j] = h * out[nv + j] + (c == j ? 1 : 0); },
                [&](int, int j) {
                  const bool own = c >= j && c < j + 3;  // a direction of this quaternion
                  for (int r = 0; r < 3; ++r) {
                    double x = own ? Rt[at][r + 3 * (c - j)] : 0;
                    for (int l = 0; l < 3; ++l) x += Jr[at][r + 3 * l] * h * out[nv + j + l];
                    out[j + r] = x;
                  }
                  ++at;
                });
  }

  detail::euler_update<K>(h, a, t, q, v);
  return StepStatus::ok;
}

}  // namespace eom
