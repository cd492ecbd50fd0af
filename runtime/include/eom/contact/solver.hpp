// The constrained acceleration of MuJoCo's soft-constraint model (docs/CONTRACT.md §1,
// "Constraint solver"): the unique minimizer a of its primal problem
//   ½ (a − a₀)ᵀ M (a − a₀) + Σ s(J a − aref)
// over the rows of eom::constraint_rows (a₀ the unconstrained acceleration), with MuJoCo's costs
// s: ½ D x² for a limit or pyramidal row below zero (0 above), friction loss's Huber (quadratic
// within ±R·loss, then linear), the elliptic cone's three zones (free above the cone, ½ D x²
// below the dual cone, ½ D/(μ²(1 + μ²)) (N − μT)² between). Newton's method with an exact line
// search, as MuJoCo's Newton solver, but run until its steps fall to rounding rather than to a
// tolerance, or until a full step keeps every row in its zone (then it was exact): the problem is
// strictly convex, so any solver that converges finds MuJoCo's a and forces. Allocation-free (the
// workspace is the caller's ConstraintSolution), in double.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include "eom/contact/constraints.hpp"
#include "eom/numeric/linalg.hpp"

namespace eom {

// The solution, and the solver's workspace (caller-owned, as the rows).
template <class Model> struct ConstraintSolution {
  static constexpr int nv = ConstraintRows<Model>::nv, capacity = ConstraintRows<Model>::capacity;
  std::array<double, nv> qacc{};             // a
  std::array<double, capacity> force{};      // per row (MuJoCo's efc_force)
  double cost = 0;      // Σ s(J a − aref) at a (the rows' part of the primal cost)
  int iterations = 0;   // Newton steps taken

  // Workspace: J a − aref, J δ, trial points, forces, each row's curvature (D where quadratic),
  // each elliptic contact's cone Hessian (in its first row's slot).
  std::array<double, capacity> jar, Jd, trial, trial_force, curvature;
  std::array<std::array<double, 36>, capacity> cone;
  std::array<signed char, capacity> zone;  // each row's zone at the Newton step's start
};

namespace detail {

// The rows' cost s at jar = J a − aref, their forces (−∂s/∂jar) and, where hessian is given,
// the Hessian of s in jar's coordinates as: per quadratic row D (diagonal), per elliptic contact
// in its middle zone a dim × dim block (cone[first row], row-major, dim ≤ 6; its [0] is 0 in the
// other zones).
template <class Model>
double row_costs(const ConstraintRows<Model>& rows, const double* jar, double* force,
                 double* diagonal, std::array<std::array<double, 36>, ConstraintRows<Model>::capacity>* cone) {
  double s = 0;
  for (int i = 0; i < rows.rows;) {
    const RowKind kind = rows.kind[i];
    const double D = rows.D[i], x = jar[i];
    force[i] = -D * x;
    if (diagonal) diagonal[i] = 0;
    if (kind == RowKind::friction_dof || kind == RowKind::friction_tendon) {
      const double f = rows.frictionloss[i], R = rows.R[i];
      if (x <= -R * f) {
        s += -0.5 * R * f * f - f * x, force[i] = f;
      } else if (x >= R * f) {
        s += -0.5 * R * f * f + f * x, force[i] = -f;
      } else {
        s += 0.5 * D * x * x;
        if (diagonal) diagonal[i] = D;
      }
      ++i;
    } else if (kind == RowKind::equality) {
      s += 0.5 * D * x * x;
      if (diagonal) diagonal[i] = D;
      ++i;
    } else if (kind != RowKind::elliptic) {
      if (x >= 0) {
        force[i] = 0;
      } else {
        s += 0.5 * D * x * x;
        if (diagonal) diagonal[i] = D;
      }
      ++i;
    } else {
      const int c = rows.id[i];
      const CollisionPair& pair = Model::collision_pairs[rows.contact_pair[c]];
      const int dim = pair.condim;
      const double mu = rows.mu[c];
      auto scale = [&](int j) { return j == 0 ? mu : pair.friction[j - 1]; };
      std::array<double, 6> U{};
      for (int j = 0; j < dim; ++j) U[j] = jar[i + j] * scale(j);
      const double N = U[0];
      double T = 0;
      for (int j = 1; j < dim; ++j) T += U[j] * U[j];
      T = std::sqrt(T);
      if (cone) (*cone)[i][0] = 0;  // no cone block unless in the middle zone
      if (N >= mu * T || (T <= 0 && N >= 0)) {  // above the cone: free
        for (int j = 0; j < dim; ++j) force[i + j] = 0;
        if (diagonal)
          for (int j = 0; j < dim; ++j) diagonal[i + j] = 0;
      } else if (mu * N + T <= 0 || (T <= 0 && N < 0)) {  // below the dual cone: quadratic
        for (int j = 0; j < dim; ++j) {
          s += 0.5 * rows.D[i + j] * jar[i + j] * jar[i + j];
          force[i + j] = -rows.D[i + j] * jar[i + j];
          if (diagonal) diagonal[i + j] = rows.D[i + j];
        }
      } else {  // between: ½ Dm (N − μT)²
        const double Dm = D / (mu * mu * (1 + mu * mu)), NmT = N - mu * T;
        s += 0.5 * Dm * NmT * NmT;
        force[i] = -Dm * NmT * mu;
        for (int j = 1; j < dim; ++j) force[i + j] = -force[i] / T * U[j] * pair.friction[j - 1];
        if (diagonal) {
          for (int j = 0; j < dim; ++j) diagonal[i + j] = 0;
          // Dm diag(scale) [1, −μ/T Uᵀ; ., μN/T³ U Uᵀ + (μ² − μN/T) I] diag(scale), MuJoCo's
          auto& H = (*cone)[i];
          H.fill(0);
          H[0] = 1;
          for (int j = 1; j < dim; ++j) H[j] = H[j * dim] = -mu / T * U[j];
          for (int k = 1; k < dim; ++k)
            for (int j = 1; j < dim; ++j)
              H[k * dim + j] = mu * N / (T * T * T) * U[j] * U[k] + (j == k ? mu * mu - mu * N / T : 0);
          for (int k = 0; k < dim; ++k)
            for (int j = 0; j < dim; ++j) H[k * dim + j] *= Dm * scale(k) * scale(j);
        }
      }
      i += dim;
    }
  }
  return s;
}

// visit(first row, p, s, entry) for every entry of the elliptic contacts' cone blocks in use
// (row_costs' `cone`: a block's [0] is 0 where its contact is not in the curved zone).
template <class Model, class Visit>
void cone_blocks(const ConstraintRows<Model>& rows,
                 const std::array<std::array<double, 36>, ConstraintRows<Model>::capacity>& cone,
                 Visit&& visit) {
  for (int k = 0; k < rows.rows;) {
    if (rows.kind[k] != RowKind::elliptic) {
      ++k;
      continue;
    }
    const int dim = Model::collision_pairs[rows.contact_pair[rows.id[k]]].condim;
    if (cone[k][0] != 0)
      for (int p = 0; p < dim; ++p)
        for (int s = 0; s < dim; ++s) visit(k, p, s, cone[k][p * dim + s]);
    k += dim;
  }
}

// Newton's matrix H = M + Jᵀ (diagonal + cone blocks) J, the primal cost's Hessian at the
// curvature row_costs left in `diagonal` and `cone`. Whole columns (the strict upper triangle is
// scratch: the factorization reads the lower), skipping the columns where a row is zero:
// fixed-length vector updates over the columns a contact moves. Inlined: into its caller's own
// aligned H the updates vectorize (the box stack's contact step 1.15x slower as a call).
template <class Model>
[[gnu::always_inline]] inline void newton_hessian(
    const std::array<double, ConstraintRows<Model>::nv * ConstraintRows<Model>::nv>& M,
    const ConstraintRows<Model>& rows, const double* diagonal,
    const std::array<std::array<double, 36>, ConstraintRows<Model>::capacity>& cone,
    std::array<double, ConstraintRows<Model>::nv * ConstraintRows<Model>::nv>& H) {
  constexpr int nv = ConstraintRows<Model>::nv;
  const double* J = rows.J.data();
  H = M;
  for (int k = 0; k < rows.rows; ++k) {
    const double* row = J + static_cast<std::size_t>(k) * nv;
    if (diagonal[k] != 0)
      for (int j = 0; j < nv; ++j)
        if (row[j] != 0)
          for (int i = 0; i < nv; ++i) H[i + nv * j] += diagonal[k] * row[i] * row[j];
  }
  cone_blocks<Model>(rows, cone, [&](int k, int p, int s, double h) {
    const double* rp = J + static_cast<std::size_t>(k + p) * nv;
    const double* rs = J + static_cast<std::size_t>(k + s) * nv;
    for (int j = 0; j < nv; ++j)
      for (int i = j; i < nv; ++i) H[i + nv * j] += h * rp[i] * rs[j];
  });
}

// y = J x over the rows (x: nv entries), and jar = J a − aref.
template <class Model> void J_times(const ConstraintRows<Model>& rows, const double* x, double* y) {
  constexpr int nv = ConstraintRows<Model>::nv;
  for (int r = 0; r < rows.rows; ++r) {
    double s = 0;
    for (int j = 0; j < nv; ++j) s += rows.J[static_cast<std::size_t>(r) * nv + j] * x[j];
    y[r] = s;
  }
}
// y = Jᵀ f over the rows (f: one force per row; y: nv entries).
template <class Model> void JT_times(const ConstraintRows<Model>& rows, const double* f, double* y) {
  constexpr int nv = ConstraintRows<Model>::nv;
  for (int j = 0; j < nv; ++j) y[j] = 0;
  for (int r = 0; r < rows.rows; ++r)
    for (int j = 0; j < nv; ++j) y[j] += rows.J[static_cast<std::size_t>(r) * nv + j] * f[r];
}
template <class Model> void residuals(const ConstraintRows<Model>& rows, const double* a, double* jar) {
  J_times<Model>(rows, a, jar);
  for (int r = 0; r < rows.rows; ++r) jar[r] -= rows.aref[r];
}
// y = M x, M n × n column-major.
template <int n> void M_times(const std::array<double, n * n>& M, const double* x, double* y) {
  for (int i = 0; i < n; ++i) {
    double s = 0;
    for (int j = 0; j < n; ++j) s += M[i + n * j] * x[j];
    y[i] = s;
  }
}

// The primal cost's gradient g = M (a − a₀) − Jᵀ f at a, f the rows' forces at J a − aref (each
// row in the zone its residual puts it; aref: rows.aref or another reference acceleration);
// returns the largest entry of its two terms. jar and force: scratch of the rows' capacity.
template <class Model>
double primal_gradient(const std::array<double, ConstraintRows<Model>::nv * ConstraintRows<Model>::nv>& M,
                       const std::array<double, ConstraintRows<Model>::nv>& a0,
                       const ConstraintRows<Model>& rows, const double* aref,
                       const std::array<double, ConstraintRows<Model>::nv>& a, double* jar,
                       double* force, double* g) {
  constexpr int nv = ConstraintRows<Model>::nv;
  J_times<Model>(rows, a.data(), jar);
  for (int r = 0; r < rows.rows; ++r) jar[r] -= aref[r];
  row_costs<Model>(rows, jar, force, nullptr, nullptr);
  std::array<double, nv> r, Mr, Jf;
  for (int i = 0; i < nv; ++i) r[i] = a[i] - a0[i];
  M_times<nv>(M, r.data(), Mr.data());
  JT_times<Model>(rows, force, Jf.data());
  double scale = 0;
  for (int i = 0; i < nv; ++i) {
    g[i] = Mr[i] - Jf[i];
    scale = std::max({scale, std::abs(Mr[i]), std::abs(Jf[i])});
  }
  return scale;
}

}  // namespace detail

// How far a is from the minimizer: the primal gradient M (a − a₀) − Jᵀ f(J a − aref), largest
// entry over the largest of its two terms' (0 at the solution, rounding's size at best). Uses
// `work`'s workspace.
template <class Model>
double optimality(const std::array<double, ConstraintRows<Model>::nv * ConstraintRows<Model>::nv>& M,
                  const std::array<double, ConstraintRows<Model>::nv>& a0,
                  const ConstraintRows<Model>& rows, const std::array<double, ConstraintRows<Model>::nv>& a,
                  ConstraintSolution<Model>& work) {
  std::array<double, ConstraintRows<Model>::nv> g;
  const double scale = detail::primal_gradient<Model>(M, a0, rows, rows.aref.data(), a, work.jar.data(),
                                                      work.trial_force.data(), g.data());
  double worst = 0;
  for (double x : g) worst = std::max(worst, std::abs(x));
  return scale > 0 ? worst / scale : worst;
}

// Solves for Model's constrained acceleration from M (nv × nv, symmetric, column-major), the
// unconstrained acceleration a0 and the rows, from a0 or, where given and cheaper (as MuJoCo's
// warm start), from `start` (e.g. the last step's a). False (out unchanged past its iterations)
// where the Newton matrix fails to factor or the iterations (at most 100) do not settle.
template <class Model>
bool solve_constraints(const std::array<double, ConstraintRows<Model>::nv * ConstraintRows<Model>::nv>& M,
                       const std::array<double, ConstraintRows<Model>::nv>& a0,
                       const ConstraintRows<Model>& rows, ConstraintSolution<Model>& out,
                       const std::array<double, ConstraintRows<Model>::nv>* start = nullptr) {
  constexpr int nv = ConstraintRows<Model>::nv;
  const int n = rows.rows;
  auto cone_blocks = [&](auto&& visit) { detail::cone_blocks<Model>(rows, out.cone, visit); };
  auto& a = out.qacc;
  a = a0;
  if (start) {  // the cheaper of a0 and start: ½ (a − a0)ᵀ M (a − a0) + s(J a − aref)
    auto primal = [&](const std::array<double, nv>& x) {
      std::array<double, nv> r, Mr;
      for (int i = 0; i < nv; ++i) r[i] = x[i] - a0[i];
      detail::M_times<nv>(M, r.data(), Mr.data());
      double c = 0;
      for (int i = 0; i < nv; ++i) c += 0.5 * r[i] * Mr[i];
      detail::residuals<Model>(rows, x.data(), out.jar.data());
      return c + detail::row_costs<Model>(rows, out.jar.data(), out.trial_force.data(), nullptr, nullptr);
    };
    if (primal(*start) < primal(a0)) a = *start;
  }
  auto& jar = out.jar;
  auto& Jd = out.Jd;
  auto& trial = out.trial;
  auto& force = out.trial_force;
  auto& diagonal = out.curvature;
  auto& cone = out.cone;
  std::array<double, nv> grad, delta, Md, Mr;
  // A row's zone from row_costs' output: quadratic (1), friction loss's linear zones (2, 3 by
  // the force's sign), free (0); whether some contact is in the elliptic cone's curved zone.
  auto zone = [&](int k) -> signed char {
    return diagonal[k] != 0 ? 1 : force[k] > 0 ? 2 : force[k] < 0 ? 3 : 0;
  };
  auto curved = [&] {
    bool any = false;
    cone_blocks([&](int, int, int, double) { any = true; });
    return any;
  };
  out.iterations = 0;
  bool settled = false;
  double previous = 0;  // the last step's size
  int stalls = 0;       // steps in a row that were small but did not shrink
  for (int iteration = 0; iteration < 100 && !settled; ++iteration) {
    detail::residuals<Model>(rows, a.data(), jar.data());
    out.cost = detail::row_costs<Model>(rows, jar.data(), force.data(), diagonal.data(), &cone);
    for (int k = 0; k < n; ++k) out.zone[k] = zone(k);
    std::array<double, nv> r;  // a − a₀
    for (int i = 0; i < nv; ++i) r[i] = a[i] - a0[i];
    detail::M_times<nv>(M, r.data(), Mr.data());

    detail::JT_times<Model>(rows, force.data(), grad.data());  // ∇ = M (a − a₀) − Jᵀ f
    for (int i = 0; i < nv; ++i) grad[i] = Mr[i] - grad[i];
    // Aligned by hand: GCC 12 at -O3 -march=native vectorizes newton_hessian's updates with
    // aligned stores but left this frame unaligned (a crash in bench_contact_step).
    alignas(64) std::array<double, nv * nv> H;
    detail::newton_hessian<Model>(M, rows, diagonal.data(), cone, H);
    const bool curved_start = curved();
    if (!linalg::cholesky<double, nv>(H)) return false;
    for (int i = 0; i < nv; ++i) delta[i] = -grad[i];
    linalg::cholesky_solve_overlapped<double, nv>(H, delta.data());  // (a direction: its last bits do not matter)

    // φ(α) = cost(a + α δ): its slope from the forces at jar + α J δ; Newton on the slope within
    // a bracket, to rounding.
    detail::J_times<Model>(rows, delta.data(), Jd.data());
    detail::M_times<nv>(M, delta.data(), Md.data());
    double dMd = 0, dMr = 0;
    for (int i = 0; i < nv; ++i) dMd += delta[i] * Md[i], dMr += delta[i] * Mr[i];
    if (!(dMd > 0)) {  // δ = 0: a is the minimizer
      settled = true;
      break;
    }
    // The slope at alpha, its curvature, and whether it is zero to rounding (within a few ε of
    // the sum of its terms' sizes: no α is better to double's precision).
    auto slope = [&](double alpha, double* curvature, bool* flat) {
      for (int k = 0; k < n; ++k) trial[k] = jar[k] + alpha * Jd[k];
      detail::row_costs<Model>(rows, trial.data(), force.data(), diagonal.data(), &cone);
      double d = dMr + alpha * dMd, c = dMd, size = std::abs(dMr) + std::abs(alpha * dMd);
      for (int k = 0; k < n; ++k) {
        d -= Jd[k] * force[k], c += diagonal[k] * Jd[k] * Jd[k];
        size += std::abs(Jd[k] * force[k]);
      }
      cone_blocks([&](int k, int p, int s, double h) { c += Jd[k + p] * h * Jd[k + s]; });
      *curvature = c;
      *flat = std::abs(d) <= 1e-14 * size;
      return d;
    };
    double lo = 0, hi = 1, curvature;
    bool flat;
    double d_hi = slope(hi, &curvature, &flat);
    for (int k = 0; d_hi < 0 && !flat && k < 60; ++k)
      lo = hi, hi *= 2, d_hi = slope(hi, &curvature, &flat);
    double alpha = hi;
    if (d_hi > 0 && !flat) {
      // Newton from hi (the full step: exact where no row changes zone), kept in the bracket,
      // until the slope is zero to rounding.
      double next = hi - d_hi / curvature;
      for (int k = 0; k < 200; ++k) {
        if (!(next > lo && next < hi)) next = lo + (hi - lo) / 2;
        alpha = next;
        const double d = slope(alpha, &curvature, &flat);
        if (d == 0 || flat) break;
        (d < 0 ? lo : hi) = alpha;
        next = alpha - d / curvature;
        if (next == alpha || hi - lo <= 1e-16 * hi) break;
      }
    }
    // The full step kept every row in its zone (the zones are convex, so along all of it), with no
    // curved cone zone at either end: the cost is one quadratic there, whose minimizer Newton's
    // step found, so a + δ is the problem's to rounding and no confirming step is needed.
    bool exact = alpha == 1 && flat && !curved_start && !curved();
    for (int k = 0; k < n && exact; ++k) exact = zone(k) == out.zone[k];
    double moved = 0, size = 0;
    for (int i = 0; i < nv; ++i) {
      a[i] += alpha * delta[i];
      moved = std::max(moved, std::abs(alpha * delta[i]));
      size = std::max(size, std::abs(a[i]));
    }
    out.iterations = iteration + 1;
    // Settled: a step at rounding's size, or three small steps no longer shrinking (Newton
    // converges quadratically once the rows' zones are right, so what remains is the rounding
    // of a stiff H's gradient; a test on the cost would stop at √ε instead).
    const double scale = std::max(1.0, size);
    stalls = moved <= 1e-10 * scale && moved >= 0.25 * previous ? stalls + 1 : 0;
    settled = exact || moved <= 1e-13 * scale || stalls == 3;
    previous = moved;
  }
  detail::residuals<Model>(rows, a.data(), jar.data());
  out.cost = detail::row_costs<Model>(rows, jar.data(), out.force.data(), nullptr, nullptr);
  return out.iterations < 100;
}

// The force of contact c in its frame (rows.contacts[c].frame: normal, then the tangents; with
// condim 4 and 6 the torsional and rolling moments after), from the rows' forces, as MuJoCo's
// mj_contactForce: a pyramid's edge forces summed into the normal and differenced (times the
// friction) into each tangent; an elliptic cone's rows as they are. Zeros for a contact without
// rows. Positive normal: pushing the geoms apart.
template <class Model>
std::array<double, 6> contact_force(const ConstraintRows<Model>& rows,
                                    const ConstraintSolution<Model>& solution, int c) {
  std::array<double, 6> f{};
  if (c < 0 || c >= rows.ncontacts || rows.contact_row[c] < 0) return f;
  const int r = rows.contact_row[c];
  const CollisionPair& pair = Model::collision_pairs[rows.contact_pair[c]];
  const int dim = pair.condim;
  const double* x = solution.force.data() + r;
  if (rows.kind[r] != RowKind::pyramidal) {
    for (int k = 0; k < dim; ++k) f[k] = x[k];
    return f;
  }
  for (int k = 0; k < 2 * (dim - 1); ++k) f[0] += x[k];
  for (int k = 0; k < dim - 1; ++k) f[k + 1] = (x[2 * k] - x[2 * k + 1]) * pair.friction[k];
  return f;
}

}  // namespace eom
