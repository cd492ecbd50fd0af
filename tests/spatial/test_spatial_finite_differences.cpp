// The body form's M and c against double-double central differences of its own T (computed by
// eom::kinetic_energy_of in qd's dd_real, ~32 digits), generated and eom::Reference:
//   M_ij = ∂²T/∂q̇ᵢ∂q̇ⱼ  by the second difference of T in q̇ with step h = 1e-3 (T is quadratic in q̇,
//                       so only rounding remains, ~1e-32/h² = 1e-26),
//   c = Ṁq̇ − ∂T/∂q     (the definition), Ṁ = dM(q + τq̇)/dτ by a central difference of that M with
//                       step δ = 1e-9, and ∂T/∂q by central differences with step δ (truncation
//                       ~δ² = 1e-18, rounding ~1e-26/δ = 1e-17).
// Error: normwise relative in the max norm, max_i |a_i − b_i| / max_i |b_i|.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <span>

#include <gtest/gtest.h>
#include <qd/dd_real.h>

#include "record.hpp"
#include "spatial_cases.hpp"

namespace {

using namespace spatial_test;

template <class Case> struct FiniteDifferences {
  static constexpr int n = Case::nq;
  using V = std::array<dd_real, n>;
  std::array<dd_real, Case::np> p;

  dd_real T(const V& q, const V& qd) const {
    return eom::kinetic_energy_of<typename Case::Body, dd_real>(std::span<const dd_real>(q),
                                                                 std::span<const dd_real>(qd), p);
  }
  std::array<dd_real, n * n> M(const V& q) const {
    const dd_real h(1e-3);
    std::array<dd_real, n * n> m;
    const V zero{};
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        auto at = [&](double si, double sj) {
          V v = zero;
          v[i] += si * h;
          v[j] += sj * h;
          return T(q, v);
        };
        m[i + n * j] = (at(1, 1) - at(1, -1) - at(-1, 1) + at(-1, -1)) / (4.0 * h * h);
      }
    return m;
  }
  std::array<dd_real, n> c(const V& q, const V& qd) const {
    const dd_real d(1e-9);
    V qp = q, qm = q;
    for (int k = 0; k < n; ++k) qp[k] += d * qd[k], qm[k] -= d * qd[k];
    const auto Mp = M(qp), Mm = M(qm);
    std::array<dd_real, n> out;
    for (int i = 0; i < n; ++i) {
      dd_real s(0.0);
      for (int j = 0; j < n; ++j) s += (Mp[i + n * j] - Mm[i + n * j]) / (2.0 * d) * qd[j];
      V a = q, b = q;
      a[i] += d;
      b[i] -= d;
      out[i] = s - (T(a, qd) - T(b, qd)) / (2.0 * d);
    }
    return out;
  }
};

template <class R, std::size_t m> double relative(const double* a, const std::array<R, m>& b) {
  double diff = 0, size = 0;
  for (std::size_t i = 0; i < m; ++i) {
    const double e = to_double(b[i]);
    diff = std::max(diff, std::abs(a[i] - e));
    size = std::max(size, std::abs(e));
  }
  return std::isnan(diff) ? INFINITY : diff / size;
}

struct Worst {
  double M = 0, c = 0;
};

template <class Case, class K> Worst against_finite_differences() {
  constexpr int n = Case::nq;
  std::mt19937_64 rng(73);
  Worst w;
  for (int k = 0; k < 20; ++k) {
    const auto s = random_sample<Case>(rng);
    FiniteDifferences<Case> fd;
    typename FiniteDifferences<Case>::V q, qd;
    for (int i = 0; i < Case::np; ++i) fd.p[i] = dd_real(s.p[i]);
    for (int i = 0; i < n; ++i) q[i] = dd_real(s.q[i]), qd[i] = dd_real(s.qd[i]);
    std::array<double, n * n> M;
    std::array<double, n> c;
    K::mass_matrix(s.q.data(), s.p.data(), M.data());
    K::coriolis(s.q.data(), s.qd.data(), s.p.data(), c.data());
    w.M = std::max(w.M, relative(M.data(), fd.M(q)));
    w.c = std::max(w.c, relative(c.data(), fd.c(q, qd)));
  }
  return w;
}

template <class Case> void check(double tolerance) {
  const Worst g = against_finite_differences<Case, typename Case::GenBody>();
  const Worst r = against_finite_differences<Case, eom::Reference<typename Case::Body>>();
  std::printf("%s: generated M %.2e c %.2e, Reference M %.2e c %.2e\n", Case::name, g.M, g.c, r.M, r.c);
  EXPECT_LE(g.M, tolerance);
  EXPECT_LE(g.c, tolerance);
  EXPECT_LE(r.M, tolerance);
  EXPECT_LE(r.c, tolerance);
  record_figure("generated_M", g.M);
  record_figure("generated_c", g.c);
  record_figure("reference_M", r.M);
  record_figure("reference_c", r.c);
}

// Measured (max over 20 states; generated M, c / Reference M, c):
//   top                 3.9e-16, 2.1e-15 / 2.7e-16, 1.4e-15
//   universal pendulum  4.2e-16, 1.9e-15 / 5.4e-16, 1.4e-15
//   chain               2.0e-16, 9.8e-16 / 3.3e-16, 1.7e-15
// Asserted: ≤ 1e-13 (the kernels' own rounding is ~1e-15; a wrong term is O(1)).
TEST(SpatialFiniteDifferences, SymmetricTop) { check<TopCase>(1e-13); }
TEST(SpatialFiniteDifferences, UniversalPendulum) { check<UniversalPendulumCase>(1e-13); }
TEST(SpatialFiniteDifferences, PlanarChainAsSpatialBodies) { check<ChainCase>(1e-13); }

}  // namespace
