// Dense solves on fixed sizes, with no allocation and no exceptions: symmetric positive definite
// ones for the forward dynamics, on any real type (double, long double, dd_real, AD numbers), and
// a general LU with partial pivoting, real or complex, for the Newton iterations of the implicit
// integrators (variational.hpp, radau5.hpp).
//
// Constrained dynamics use the range-space method (paper, closed-chain example):
//   M = L Lᵀ,  a = M⁻¹ f,  S = C M⁻¹ Cᵀ,  S μ = C a + γ,  q̈ = a − M⁻¹ Cᵀ μ
// which solves [M Cᵀ; C 0][q̈; μ] = [f; −γ] (docs/CONTRACT.md §2) using only SPD factorizations.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstddef>
#include <limits>
#include <utility>

#include "eom/numeric/ad.hpp"

namespace eom::linalg {

// A pivot smaller than this fraction of its original diagonal entry means the matrix is
// numerically singular (rank deficient), not merely ill-conditioned: 1e3·ε accepts condition
// numbers up to about 1e12 while rejecting a Jacobian that has lost rank. The factor is the one
// rule: generated kernels print it into their copy of the test.
inline constexpr double pivot_factor = 1e3;  // × the scalar's ε
template <class Real> constexpr double pivot_tolerance() {
  if constexpr (is_embedded<Real>::value)
    return pivot_tolerance<typename Real::real_type>();
  else
    return pivot_factor * static_cast<double>(std::numeric_limits<Real>::epsilon());
}

// The pivot test: a pivot clearly positive relative to its original diagonal entry (which must be
// positive), finite. The generator folds with the same function, and generated sources carry a
// copy of it for double (they include nothing of eomgen).
template <class Real = double> bool pivot_ok(double pivot, double diagonal) noexcept {
  return pivot > pivot_tolerance<Real>() * diagonal && diagonal > 0 && std::isfinite(pivot);
}

template <class Real> bool is_finite(const Real& x) { return std::isfinite(as_double(x)); }

// In-place Cholesky of the n×n column-major SPD matrix A (lower triangle read and overwritten
// by L; the strict upper triangle is left alone). Returns the row of the first pivot that is not
// clearly positive (then stops, its pivot and original diagonal entry in *pivot, *diagonal), or
// −1 when A factors. Each entry is its own dot product, k ascending; the entries below a pivot
// four rows at a time, so that their sums run side by side (in one vector register) rather than
// each waiting for the last: the same operations per entry as one at a time, in the same order
// (docs/benchmarks/contact_step.md: the humanoid's contact step 0.94x the time). Inlined: GCC
// stopped inlining it into the contact solver once a translation unit had more callers (the
// humanoid's contact step 1.11x slower as a call).
template <class Real, int n>
[[gnu::always_inline]] inline int cholesky_failure(std::array<Real, n * n>& A, double* pivot = nullptr,
                                                   double* diagonal = nullptr) {
  using std::sqrt;
  constexpr int w = 4;
  for (int j = 0; j < n; ++j) {
    Real d = A[j + n * j];
    const double scale = as_double(d);
    for (int k = 0; k < j; ++k) d -= A[j + n * k] * A[j + n * k];
    const double dv = as_double(d);
    if (!pivot_ok<Real>(dv, scale)) {
      if (pivot) *pivot = dv;
      if (diagonal) *diagonal = scale;
      return j;
    }
    const Real l = sqrt(d);
    A[j + n * j] = l;
    int i = j + 1;
    if constexpr (n > w)  // (a block needs n > w: no code, and no warning, for smaller A)
      for (; i + w <= n; i += w) {
        Real s[w];
        for (int r = 0; r < w; ++r) s[r] = A[i + r + n * j];
        for (int k = 0; k < j; ++k) {
          const Real x = A[j + n * k];
          for (int r = 0; r < w; ++r) s[r] -= A[i + r + n * k] * x;
        }
        for (int r = 0; r < w; ++r) A[i + r + n * j] = s[r] / l;
      }
    for (; i < n; ++i) {
      Real s = A[i + n * j];
      for (int k = 0; k < j; ++k) s -= A[i + n * k] * A[j + n * k];
      A[i + n * j] = s / l;
    }
  }
  return -1;
}
// False when a pivot is not clearly positive.
template <class Real, int n> bool cholesky(std::array<Real, n * n>& A) {
  return cholesky_failure<Real, n>(A) < 0;
}

// Why a symmetric matrix fails the pivot test, at the first pivot that does (Cholesky in the
// order of the coordinates, as the kernels factor M): a pivot or diagonal entry that is not
// finite; an indefinite matrix (a negative diagonal entry, or a pivot below −tolerance × its
// diagonal entry: the quadratic form is negative along some direction); otherwise a singular one
// (a pivot within the tolerance of zero: semidefinite, or rank lost to rounding).
enum class PivotProblem { none, not_finite, singular, indefinite };
struct PivotFailure {
  PivotProblem problem = PivotProblem::none;
  int index = -1;  // the failing pivot's row (a velocity index), −1 when none fails
  double pivot = 0, diagonal = 0;
};
template <int n> PivotFailure first_failing_pivot(std::array<double, n * n> A) noexcept {
  PivotFailure f;
  f.index = cholesky_failure<double, n>(A, &f.pivot, &f.diagonal);
  if (f.index >= 0)
    f.problem = !std::isfinite(f.pivot) || !std::isfinite(f.diagonal) ? PivotProblem::not_finite
                : f.diagonal < 0 || f.pivot < -pivot_tolerance<double>() * f.diagonal
                    ? PivotProblem::indefinite
                    : PivotProblem::singular;
  return f;
}

// Solves L Lᵀ x = b in place, L from cholesky().
template <class Real, int n> void cholesky_solve(const std::array<Real, n * n>& L, Real* b) {
  for (int i = 0; i < n; ++i) {
    Real s = b[i];
    for (int k = 0; k < i; ++k) s -= L[i + n * k] * b[k];
    b[i] = s / L[i + n * i];
  }
  for (int i = n - 1; i >= 0; --i) {
    Real s = b[i];
    for (int k = i + 1; k < n; ++k) s -= L[k + n * i] * b[k];
    b[i] = s / L[i + n * i];
  }
}

// cholesky_solve in about half its time, for solves whose last bits nothing hangs on (a Newton
// direction, a step's damped acceleration): the back substitution sums each entry's terms from the
// far end, so that each sum waits for the entry before only in its last term (in cholesky_solve's
// order its first term waits, and the entries' sums run one after the other), and both passes
// multiply by the pivots' reciprocals, computed side by side, instead of dividing on the chain of
// dependent entries. Each entry's error stays a few units in the last place of its terms' sizes,
// but its rounding differs from cholesky_solve's (which eom::Reference and the kernels' tests
// keep). A 27×27 solve 0.49× cholesky_solve's time (g++ 12 -O3 -march=native, AMD EPYC).
template <class Real, int n> void cholesky_solve_overlapped(const std::array<Real, n * n>& L, Real* b) {
  std::array<Real, n> r;
  for (int i = 0; i < n; ++i) r[i] = Real(1) / L[i + n * i];
  for (int i = 0; i < n; ++i) {
    Real s = b[i];
    for (int k = 0; k < i; ++k) s -= L[i + n * k] * b[k];
    b[i] = s * r[i];
  }
  for (int i = n - 1; i >= 0; --i) {
    Real s = b[i];
    for (int k = n - 1; k > i; --k) s -= L[k + n * i] * b[k];
    b[i] = s * r[i];
  }
}

// cholesky_solve on the m columns of B (n × m, column-major) at once: four columns' substitutions
// interleaved, so that the divisions and sums of one column wait for each other's, not for
// their own (each column's operations those of cholesky_solve, in its order).
template <class Real, int n> void cholesky_solve_columns(const std::array<Real, n * n>& L, Real* B, int m) {
  constexpr int w = 4;
  int c = 0;
  for (; c + w <= m; c += w) {
    Real* b = B + static_cast<std::ptrdiff_t>(n) * c;
    for (int i = 0; i < n; ++i) {
      Real s[w];
      for (int j = 0; j < w; ++j) s[j] = b[i + n * j];
      for (int k = 0; k < i; ++k)
        for (int j = 0; j < w; ++j) s[j] -= L[i + n * k] * b[k + n * j];
      for (int j = 0; j < w; ++j) b[i + n * j] = s[j] / L[i + n * i];
    }
    for (int i = n - 1; i >= 0; --i) {
      Real s[w];
      for (int j = 0; j < w; ++j) s[j] = b[i + n * j];
      for (int k = i + 1; k < n; ++k)
        for (int j = 0; j < w; ++j) s[j] -= L[k + n * i] * b[k + n * j];
      for (int j = 0; j < w; ++j) b[i + n * j] = s[j] / L[i + n * i];
    }
  }
  for (; c < m; ++c) cholesky_solve<Real, n>(L, B + static_cast<std::ptrdiff_t>(n) * c);
}

// The size pivoting compares: |x|, and |Re x| + |Im x| for complex x (within √2 of the modulus,
// without the cost of a hypot per comparison).
inline double pivot_size(double x) noexcept { return std::abs(x); }
inline double pivot_size(const std::complex<double>& x) noexcept {
  return std::abs(x.real()) + std::abs(x.imag());
}

// In-place LU factorization with partial pivoting of the n×n column-major A, Scalar = double or
// std::complex<double>. False when a pivot is not finite or its size falls below
// pivot_tolerance<double>() times the largest size in its original column.
template <class Scalar, int n>
bool lu_factor(std::array<Scalar, n * n>& A, std::array<int, n>& piv) noexcept {
  std::array<double, n> scale{};
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) scale[j] = std::max(scale[j], pivot_size(A[i + n * j]));
  for (int k = 0; k < n; ++k) {
    int best = k;
    for (int i = k + 1; i < n; ++i)
      if (pivot_size(A[i + n * k]) > pivot_size(A[best + n * k])) best = i;
    const Scalar pivot = A[best + n * k];
    const double size = pivot_size(pivot);
    if (!std::isfinite(size) || !(size > pivot_tolerance<double>() * scale[k])) return false;
    piv[k] = best;
    if (best != k)
      for (int j = 0; j < n; ++j) std::swap(A[k + n * j], A[best + n * j]);
    for (int i = k + 1; i < n; ++i) A[i + n * k] /= pivot;
    for (int j = k + 1; j < n; ++j) {
      const Scalar a = A[k + n * j];
      if (a != Scalar(0))
        for (int i = k + 1; i < n; ++i) A[i + n * j] -= A[i + n * k] * a;
    }
  }
  return true;
}

// Solves A x = b in place with the factors from lu_factor().
template <class Scalar, int n>
void lu_solve(const std::array<Scalar, n * n>& LU, const std::array<int, n>& piv, Scalar* b) noexcept {
  if constexpr (n > 1)  // (for n = 1 there is nothing to swap; GCC's -Warray-bounds cannot tell)
    for (int k = 0; k < n; ++k)
      if (piv[k] != k) std::swap(b[k], b[piv[k]]);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < i; ++k) b[i] -= LU[i + n * k] * b[k];
  for (int i = n - 1; i >= 0; --i) {
    for (int k = i + 1; k < n; ++k) b[i] -= LU[i + n * k] * b[k];
    b[i] /= LU[i + n * i];
  }
}

// A range-space correction on M's Cholesky factor L (from cholesky()): with Y = M⁻¹Aᵀ over the
// active rows of A (m×n, column-major; an inactive row enters S as an identity row and its x is
// 0), x = (A Y + ρI)⁻¹ r in place of r, then dx += Y x. The M-metric step that moves dx along
// Aᵀ's range to change A dx by r (ρ = 0). False, dx untouched, when A Y + ρI does not factor
// (dependent active rows).
template <int n, int m>
bool range_space_step(const std::array<double, n * n>& L, const std::array<double, m * n>& A,
                      const std::array<bool, m>& active, double rho, std::array<double, m>& r,
                      double* dx) noexcept {
  std::array<double, n * m> Y{};
  for (int i = 0; i < m; ++i) {
    if (!active[i]) continue;
    for (int k = 0; k < n; ++k) Y[k + n * i] = A[i + m * k];
    cholesky_solve<double, n>(L, &Y[n * i]);
  }
  std::array<double, m * m> S{};
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      if (!active[i] || !active[j]) {
        S[i + m * j] = i == j ? 1.0 : 0.0;
        continue;
      }
      double s = i == j ? rho : 0.0;
      for (int k = 0; k < n; ++k) s += A[i + m * k] * Y[k + n * j];
      S[i + m * j] = s;
    }
  if (!cholesky<double, m>(S)) return false;
  for (int i = 0; i < m; ++i)
    if (!active[i]) r[i] = 0;
  cholesky_solve<double, m>(S, r.data());
  for (int k = 0; k < n; ++k)
    for (int i = 0; i < m; ++i) dx[k] += Y[k + n * i] * r[i];
  return true;
}

// q̈ from M q̈ + Cᵀ μ = f, C q̈ = −γ by the range-space method. M (nq×nq) and C (nc×nq) are
// column-major. Writes qdd (and mu, if given) only on success.
template <class Real, int nq, int nc>
bool solve_constrained(std::array<Real, nq * nq> M, const std::array<Real, nq>& f,
                       const std::array<Real, nc * nq>& C, const std::array<Real, nc>& gamma,
                       Real* qdd, Real* mu = nullptr) {
  if (!cholesky<Real, nq>(M)) return false;
  std::array<Real, nq> a = f;
  cholesky_solve<Real, nq>(M, a.data());
  if constexpr (nc == 0) {
    for (int i = 0; i < nq; ++i) qdd[i] = a[i];
    return true;
  } else {
    // Y = M⁻¹ Cᵀ (nq×nc), S = C Y (nc×nc), r = C a + γ
    std::array<Real, nq * nc> Y{};
    for (int k = 0; k < nc; ++k) {
      for (int i = 0; i < nq; ++i) Y[i + nq * k] = C[k + nc * i];
      cholesky_solve<Real, nq>(M, &Y[nq * k]);
    }
    std::array<Real, nc * nc> S{};
    std::array<Real, nc> m{};
    for (int r = 0; r < nc; ++r) {
      m[r] = gamma[r];
      for (int i = 0; i < nq; ++i) m[r] += C[r + nc * i] * a[i];
      for (int k = 0; k < nc; ++k) {
        Real s(0);
        for (int i = 0; i < nq; ++i) s += C[r + nc * i] * Y[i + nq * k];
        S[r + nc * k] = s;
      }
    }
    if (!cholesky<Real, nc>(S)) return false;
    cholesky_solve<Real, nc>(S, m.data());
    for (int i = 0; i < nq; ++i) {
      Real s = a[i];
      for (int k = 0; k < nc; ++k) s -= Y[i + nq * k] * m[k];
      qdd[i] = s;
    }
    if (mu)
      for (int k = 0; k < nc; ++k) mu[k] = m[k];
    return true;
  }
}

}  // namespace eom::linalg
