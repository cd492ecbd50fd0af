// eom::linalg's symmetric solves: cholesky_solve_overlapped (the contact solver's Newton
// direction) against cholesky_solve and a long-double solve of the same system.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>

#include <eom/numeric/linalg.hpp>

namespace {

// A random SPD matrix B Bᵀ + shift I (column-major), its condition set by the shift.
template <int n> std::array<double, n * n> spd(std::mt19937_64& g, double shift) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::array<double, n * n> B, A;
  for (double& x : B) x = u(g);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      double s = 0;
      for (int k = 0; k < n; ++k) s += B[i + n * k] * B[j + n * k];
      A[i + n * j] = s + (i == j ? shift : 0);
    }
  return A;
}

// x of A x = b in long double (Cholesky in long double, A's entries as given).
template <int n> std::array<long double, n> solve_long(const std::array<double, n * n>& A, const double* b) {
  std::array<long double, n * n> L;
  for (int i = 0; i < n * n; ++i) L[i] = A[i];
  std::array<long double, n> x;
  for (int i = 0; i < n; ++i) x[i] = b[i];
  EXPECT_TRUE((eom::linalg::cholesky<long double, n>(L)));
  eom::linalg::cholesky_solve<long double, n>(L, x.data());
  return x;
}

// Both solves on `trials` systems of size n: each within a few ε·cond of the long-double x
// (relative to x's largest entry), and within that of each other.
template <int n> void check(double shift, int trials) {
  std::mt19937_64 g(20261208 + n);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int t = 0; t < trials; ++t) {
    const auto A = spd<n>(g, shift);
    std::array<double, n> b;
    for (double& x : b) x = u(g);
    alignas(64) auto L = A;
    ASSERT_TRUE((eom::linalg::cholesky<double, n>(L)));
    auto x = b, y = b;
    eom::linalg::cholesky_solve<double, n>(L, x.data());
    eom::linalg::cholesky_solve_overlapped<double, n>(L, y.data());
    const auto exact = solve_long<n>(A, b.data());
    long double size = 0;
    for (long double e : exact) size = std::max(size, std::fabs(e));
    // ‖A‖ / λ_min bounds the condition: λ_min ≥ shift, ‖A‖ ≤ n (1 + ... ) + shift (Gershgorin).
    double norm = 0;
    for (int i = 0; i < n; ++i) {
      double row = 0;
      for (int j = 0; j < n; ++j) row += std::abs(A[i + n * j]);
      norm = std::max(norm, row);
    }
    const double bound = 8 * n * std::numeric_limits<double>::epsilon() * (norm / shift) * static_cast<double>(size);
    for (int i = 0; i < n; ++i) {
      EXPECT_LE(std::fabs(y[i] - exact[i]), bound) << "n = " << n << ", trial " << t << ", entry " << i;
      EXPECT_LE(std::fabs(x[i] - exact[i]), bound) << "n = " << n << ", trial " << t << ", entry " << i;
    }
  }
}

TEST(Linalg, OverlappedCholeskySolveAgreesWithLongDouble) {
  check<1>(0.5, 8);
  check<2>(0.5, 8);
  check<5>(0.1, 16);
  check<27>(1.0, 16);   // the humanoid's Newton matrix size, well conditioned
  check<27>(1e-6, 16);  // and a condition near 1e8
}

// Overlapped means reordered, not approximate: on a system solved exactly in double (a
// diagonal L with powers of two, integer right-hand side), both forms give the same x.
TEST(Linalg, OverlappedCholeskySolveIsExactWhereArithmeticIs) {
  constexpr int n = 6;
  std::array<double, n * n> L{};
  for (int i = 0; i < n; ++i) L[i + n * i] = std::ldexp(1.0, i - 2);
  std::array<double, n> b{1, -2, 3, -4, 5, -6}, x = b;
  eom::linalg::cholesky_solve_overlapped<double, n>(L, x.data());
  for (int i = 0; i < n; ++i) EXPECT_EQ(x[i], b[i] / (L[i + n * i] * L[i + n * i])) << i;
}

}  // namespace
