// The looped form's dense routine (generator/src/dense_solve.inc), compiled from the same file the
// generator copies into generated sources, against eom::linalg::solve_constrained (Cholesky with
// square roots, column-major storage: an independent implementation of the range-space method).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <eom/numeric/linalg.hpp>

#include "columns_of_rows_avx.hpp"
#include "dense_solve.hpp"  // the routine, as the generator compiles it (its pivot test is eom::linalg's)

namespace dense = eom::gen::dense;

// GCC 12 at -O1 (tests/CMakeLists.txt: EOM_TEST_OPTIMIZATION) takes the zero-size arrays of an
// unconstrained System (nc = 0), passed by reference, for uninitialized memory: a false positive,
// they have no element.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

namespace {

// A random system: M SPD (AᵀA + n I), C full rank, f and γ in [-1, 1]. Column-major for
// eom::linalg, and the routine's array: M by rows (the lower triangle read), f, C, γ, scratch.
template <int n, int nc> struct System {
  std::array<double, n * n> M{};
  std::array<double, n> f{};
  std::array<double, nc * n> C{};
  std::array<double, nc> gamma{};

  explicit System(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u(-1, 1);
    std::array<double, n * n> A{};
    for (double& a : A) a = u(rng);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        double s = i == j ? n : 0.0;
        for (int k = 0; k < n; ++k) s += A[k + n * i] * A[k + n * j];
        M[i + n * j] = s;
      }
    for (double& x : f) x = u(rng);
    for (double& x : C) x = u(rng);
    for (double& x : gamma) x = u(rng);
  }

  static constexpr int size = dense::DenseLayout(n, nc).size;
  std::vector<double> packed() const {
    std::vector<double> s(size, std::numeric_limits<double>::quiet_NaN());  // scratch: written first
    for (int i = 0; i < n; ++i)
      for (int j = 0; j <= i; ++j) s[j + n * i] = M[i + n * j];
    std::copy(f.begin(), f.end(), s.begin() + n * n);
    std::copy(C.begin(), C.end(), s.begin() + n * n + n);
    std::copy(gamma.begin(), gamma.end(), s.begin() + n * n + n + nc * n);
    return s;
  }
};

template <int n, int nc> void agrees_with_linalg() {
  std::mt19937_64 rng(1000 * n + nc);
  for (int trial = 0; trial < 20; ++trial) {
    const System<n, nc> sys(rng);
    std::array<double, n> expected{}, got{};
    ASSERT_TRUE((eom::linalg::solve_constrained<double, n, nc>(sys.M, sys.f, sys.C, sys.gamma, expected.data())));
    std::vector<double> s = sys.packed();
    ASSERT_TRUE((dense::solve_dense_system<n, nc>(s.data(), got.data()))) << "n = " << n << ", nc = " << nc;
    // The generator's evaluator runs the same text with run-time sizes: the same numbers.
    std::vector<double> s_runtime = sys.packed(), w(std::max(n, nc));
    std::array<double, n> got_runtime{};
    ASSERT_TRUE(dense::dense_system(n, nc, s_runtime.data(), got_runtime.data(), w.data()));
    EXPECT_EQ(got_runtime, got) << "n = " << n << ", nc = " << nc;
    double scale = 0;
    for (double x : expected) scale = std::max(scale, std::abs(x));
    for (int i = 0; i < n; ++i)
      EXPECT_NEAR(got[i], expected[i], 1e-12 * scale) << "n = " << n << ", nc = " << nc << ", i = " << i;
    // The constraints hold: C q̈ = −γ.
    for (int r = 0; r < nc; ++r) {
      double residual = sys.gamma[r];
      for (int i = 0; i < n; ++i) residual += sys.C[r + nc * i] * got[i];
      EXPECT_NEAR(residual, 0.0, 1e-12 * (1 + scale)) << "constraint " << r;
    }
  }
}

// More right-hand sides on the factors the first solve left: each column agrees with a fresh
// solve of its own system by eom::linalg, stored by columns or by rows (the derivative kernels'
// solves: here a block of columns within wider rows, the rest of them untouched).
template <int n, int nc> void more_columns_agree_with_linalg() {
  constexpr int count = 4, ld = count + 2;
  std::mt19937_64 rng(2000 * n + nc);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 10; ++trial) {
    System<n, nc> sys(rng);
    std::vector<double> s = sys.packed();
    std::array<double, n> qdd{};
    ASSERT_TRUE((dense::solve_dense_system<n, nc>(s.data(), qdd.data())));
    std::vector<double> b((n + nc) * count), x(n * count, std::numeric_limits<double>::quiet_NaN());
    for (double& v : b) v = u(rng);
    const std::vector<double> columns = b;  // b is the routine's scratch
    dense::solve_dense_columns<n, nc>(s.data(), b.data(), count, x.data());
    std::vector<double> b_runtime = columns, x_runtime(n * count);
    dense::dense_columns(n, nc, s.data(), b_runtime.data(), count, x_runtime.data());
    EXPECT_EQ(x_runtime, x) << "run-time sizes, n = " << n << ", nc = " << nc;
    EXPECT_EQ(b_runtime, b) << "run-time sizes (multipliers), n = " << n << ", nc = " << nc;
    std::vector<double> rows((n + nc) * ld, -7.0), x_rows(n * count, std::numeric_limits<double>::quiet_NaN());
    for (int k = 0; k < count; ++k)
      for (int i = 0; i < n + nc; ++i) rows[ld * i + k] = columns[(n + nc) * k + i];
    dense::solve_dense_rows<n, nc, ld>(s.data(), rows.data(), count, x_rows.data());
    for (int i = 0; i < n + nc; ++i)
      for (int k = 0; k < ld; ++k)
        if (k >= count) {
          EXPECT_EQ(rows[ld * i + k], -7.0);
        } else if (i >= n) {  // the multipliers, as by columns
          EXPECT_NEAR(rows[ld * i + k], b[(n + nc) * k + i], 1e-12 * (1 + std::abs(b[(n + nc) * k + i])));
        }
    for (int k = 0; k < count; ++k) {
      std::copy_n(columns.begin() + (n + nc) * k, n, sys.f.begin());
      std::copy_n(columns.begin() + (n + nc) * k + n, nc, sys.gamma.begin());
      std::array<double, n> expected{};
      ASSERT_TRUE((eom::linalg::solve_constrained<double, n, nc>(sys.M, sys.f, sys.C, sys.gamma, expected.data())));
      double scale = 0;
      for (double v : expected) scale = std::max(scale, std::abs(v));
      for (int i = 0; i < n; ++i) {
        EXPECT_NEAR(x[i + n * k], expected[i], 1e-12 * scale)
            << "n = " << n << ", nc = " << nc << ", column " << k << ", i = " << i;
        EXPECT_NEAR(x_rows[i + n * k], expected[i], 1e-12 * scale)
            << "by rows, n = " << n << ", nc = " << nc << ", column " << k << ", i = " << i;
      }
    }
  }
}

TEST(DenseSolve, MoreRightHandSidesOnTheKeptFactors) {
  more_columns_agree_with_linalg<1, 0>();
  more_columns_agree_with_linalg<7, 0>();
  more_columns_agree_with_linalg<7, 1>();
  more_columns_agree_with_linalg<12, 3>();
  more_columns_agree_with_linalg<33, 2>();
}

TEST(DenseSolve, AgreesWithTheRuntimeRangeSpaceSolve) {
  agrees_with_linalg<1, 0>();
  agrees_with_linalg<5, 0>();
  agrees_with_linalg<12, 0>();
  agrees_with_linalg<5, 1>();
  agrees_with_linalg<12, 3>();
  agrees_with_linalg<33, 2>();
}

// Rank-deficient systems in floating point: the last pivot is rounding noise, not zero, so
// without the relative pivot test the routine would return large finite garbage.
TEST(DenseSolve, RefusesASingularMassMatrix) {
  constexpr int n = 6;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  System<n, 0> sys(rng);
  std::array<double, (n - 1) * n> B{};  // M = BᵀB, rank n − 1
  for (double& b : B) b = u(rng);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      double s = 0;
      for (int k = 0; k < n - 1; ++k) s += B[k + (n - 1) * i] * B[k + (n - 1) * j];
      sys.M[i + n * j] = s;
    }
  std::array<double, n> qdd{};
  EXPECT_FALSE((eom::linalg::solve_constrained<double, n, 0>(sys.M, sys.f, sys.C, sys.gamma, qdd.data())));
  std::vector<double> s = sys.packed();
  EXPECT_FALSE((dense::solve_dense_system<n, 0>(s.data(), qdd.data())));
}

TEST(DenseSolve, RefusesDependentConstraints) {
  std::mt19937_64 rng(8);
  System<6, 2> sys(rng);
  for (int i = 0; i < 6; ++i) sys.C[1 + 2 * i] = 3 * sys.C[0 + 2 * i];  // row 1 = 3 × row 0
  std::array<double, 6> qdd{};
  EXPECT_FALSE((eom::linalg::solve_constrained<double, 6, 2>(sys.M, sys.f, sys.C, sys.gamma, qdd.data())));
  std::vector<double> s = sys.packed();
  EXPECT_FALSE((dense::solve_dense_system<6, 2>(s.data(), qdd.data())));
}

// columns_of_rows copies `count` columns of right-hand sides stored by rows into a column-major
// block exactly (times ±1), nothing past it: the form compiled here, and the transposing form
// compiled with AVX (columns_of_rows_avx.cpp) where this machine has AVX.
template <int rows, int step>
void copies_columns_exactly(std::mt19937_64& rng, bool avx) {
  constexpr int ld = step < 0 ? -step : step;
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> block(rows * ld);
  for (int count = 0; count <= ld; ++count)
    for (double sign : {1.0, -1.0}) {
      for (double& x : block) x = u(rng);
      const double* b = block.data() + (step < 0 ? (rows - 1) * ld : 0);
      std::vector<double> expected(rows * count + 3, -7.0);
      for (int k = 0; k < count; ++k)
        for (int i = 0; i < rows; ++i) expected[i + rows * k] = sign * b[step * i + k];
      std::vector<double> plain(expected.size(), -7.0), transposed(expected.size(), -7.0);
      dense::columns_of_rows<rows, step>(b, count, sign, plain.data());
      EXPECT_EQ(plain, expected) << rows << " rows " << step << " apart, " << count << " columns";
      if (!avx) continue;
      ASSERT_TRUE(columns_avx::columns_of_rows(rows, step, b, count, sign, transposed.data()));
      EXPECT_EQ(transposed, expected) << "AVX: " << rows << " rows " << step << " apart, " << count << " columns";
    }
}

TEST(DenseSolve, ColumnsOfRowsCopyExactly) {
  const bool avx = columns_avx::compiled_with_avx() && __builtin_cpu_supports("avx");
  std::printf("  the transposing (AVX) form %s\n", avx ? "checked too" : "not built or not run here");
  std::mt19937_64 rng(10);
  copies_columns_exactly<27, -72>(rng, avx);
  copies_columns_exactly<27, 72>(rng, avx);
  copies_columns_exactly<6, 72>(rng, avx);
  copies_columns_exactly<1, 8>(rng, avx);
  copies_columns_exactly<3, -5>(rng, avx);
  copies_columns_exactly<4, 4>(rng, avx);
  copies_columns_exactly<5, 9>(rng, avx);
  copies_columns_exactly<8, -8>(rng, avx);
}

TEST(DenseSolve, RefusesANonFiniteResult) {
  std::mt19937_64 rng(9);
  System<4, 0> sys(rng);
  sys.f[1] = std::numeric_limits<double>::infinity();
  std::vector<double> s = sys.packed();
  std::array<double, 4> qdd{};
  EXPECT_FALSE((dense::solve_dense_system<4, 0>(s.data(), qdd.data())));
}

}  // namespace

// aligned_rows: the first 64-byte boundary at or after p, within the 7 doubles a row-form kernel
// keeps to spare, from every double of a line.
TEST(DenseSolve, AlignedRowsStartACacheLineWithinSevenDoubles) {
  alignas(64) double block[32];
  for (int offset = 0; offset < 16; ++offset) {
    double* const p = block + offset;
    double* const rows = dense::aligned_rows(p);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(rows) % 64, 0u) << offset;
    EXPECT_GE(rows, p) << offset;
    EXPECT_LE(rows - p, 7) << offset;
    EXPECT_EQ(rows == p, offset % 8 == 0) << offset;
  }
}
