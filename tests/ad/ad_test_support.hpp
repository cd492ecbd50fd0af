// Shared helpers of the eom::Embedded tests: reference jets (value, gradient, full Hessian), the
// error measure, a log of the worst errors seen, and high-precision central differences in qd's
// dd_real (about 32 significant digits).
//
// Error measure ("normwise relative, max norm"), applied separately to the value, the gradient
// and the Hessian:   err(a, e) = max_i |a_i - e_i| / max_i |e_i|,
// or max_i |a_i| when the expected part is exactly zero. NaN counts as an infinite error.
#pragma once

#include <eom/numeric/ad.hpp>
#include <gtest/gtest.h>
#include <qd/dd_real.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <string>
#include <type_traits>

namespace adtest {

using eom::as_double;

// A reference jet of f: R^N -> R: value, gradient and the full (symmetric) Hessian.
template <int N, class R = double>
struct Jet {
  R v{};
  std::array<R, N> g{};
  std::array<std::array<R, N>, N> H{};
};

// The bottom-level value of an entry, in R (R = double, or dd_real for dd_real entries).
template <class R, class X>
R bottom(const X& x) {
  if constexpr (eom::is_embedded<X>::value)
    return bottom<R>(x.v);
  else if constexpr (std::is_same_v<R, double>)
    return as_double(x);
  else
    return R(x);
}

// An Embedded number as a jet (entries taken at the bottom level of a nested Embedded). For
// Order 1 the Hessian is left zero.
template <class R = double, int N, class T, int O>
Jet<N, R> to_jet(const eom::Embedded<N, T, O>& a) {
  Jet<N, R> j;
  j.v = bottom<R>(a.v);
  for (int i = 0; i < N; ++i) j.g[i] = bottom<R>(a.g[i]);
  if constexpr (O == 2)
    for (int i = 0; i < N; ++i)
      for (int k = 0; k < N; ++k) j.H[i][k] = bottom<R>(a.hessian(i, k));
  return j;
}

template <class R>
double normwise(const R* a, const R* e, int n) {
  using std::abs;
  R num(0), den(0);
  for (int i = 0; i < n; ++i) {
    const R d = abs(a[i] - e[i]), m = abs(e[i]);
    if (!(d <= num)) num = d;  // NaN propagates
    if (m > den) den = m;
  }
  const double r = den == R(0) ? as_double(num) : as_double(num / den);
  return std::isnan(r) ? INFINITY : r;
}

struct Errors {
  double value = 0, gradient = 0, hessian = 0;
};

template <int N, class R>
Errors compare(const Jet<N, R>& a, const Jet<N, R>& e, bool with_hessian) {
  Errors r;
  r.value = normwise(&a.v, &e.v, 1);
  r.gradient = normwise(a.g.data(), e.g.data(), N);
  if (with_hessian) r.hessian = normwise(&a.H[0][0], &e.H[0][0], N * N);
  return r;
}

template <int N, class R>
std::string describe(const Jet<N, R>& j, bool with_hessian) {
  std::ostringstream s;
  s.precision(17);
  s << "v = " << as_double(j.v) << ", g = [";
  for (int i = 0; i < N; ++i) s << (i ? ", " : "") << as_double(j.g[i]);
  s << "]";
  if (with_hessian) {
    s << ", H = [";
    for (int i = 0; i < N; ++i) {
      s << (i ? "; " : "");
      for (int k = 0; k < N; ++k) s << (k ? ", " : "") << as_double(j.H[i][k]);
    }
    s << "]";
  }
  return s.str();
}

// The worst error seen per check group; printed once at the end of the run.
class WorstErrors {
 public:
  static void record(const std::string& group, double err, const std::string& where) {
    auto& e = table()[group];
    if (!(err <= e.first)) e = {err, where};
  }
  static void print() {
    if (table().empty()) return;
    std::printf("\nWorst normwise relative errors (max over value, gradient, Hessian):\n");
    for (const auto& [group, e] : table())
      std::printf("  %-44s %.3e   at %s\n", group.c_str(), e.first, e.second.c_str());
  }

 private:
  static std::map<std::string, std::pair<double, std::string>>& table() {
    static std::map<std::string, std::pair<double, std::string>> t;
    return t;
  }
};

// Expects value, gradient and Hessian of `actual` within `tol` of `expected` (error measure
// above) and records the worst error under `group`.
template <int N, class R>
void expect_jet_near(const Jet<N, R>& actual, const Jet<N, R>& expected, double tol,
                     const std::string& group, const std::string& where, bool with_hessian = true) {
  const Errors e = compare(actual, expected, with_hessian);
  const double worst = std::max({e.value, e.gradient, e.hessian});
  WorstErrors::record(group, worst, where);
  EXPECT_LE(e.value, tol) << where << " (value)\n  actual:   " << describe(actual, with_hessian)
                          << "\n  expected: " << describe(expected, with_hessian);
  EXPECT_LE(e.gradient, tol) << where << " (gradient)\n  actual:   "
                             << describe(actual, with_hessian)
                             << "\n  expected: " << describe(expected, with_hessian);
  if (with_hessian) {
    EXPECT_LE(e.hessian, tol) << where << " (Hessian)\n  actual:   " << describe(actual, true)
                              << "\n  expected: " << describe(expected, true);
  }
}

// ---- the chain rule on reference jets (closed forms) ---------------------------------------
// f(a) with f, f', f'' at a.v
template <int N>
Jet<N> compose(const Jet<N>& a, double f, double f1, double f2) {
  Jet<N> r;
  r.v = f;
  for (int i = 0; i < N; ++i) r.g[i] = f1 * a.g[i];
  for (int i = 0; i < N; ++i)
    for (int k = 0; k < N; ++k) r.H[i][k] = f1 * a.H[i][k] + f2 * a.g[i] * a.g[k];
  return r;
}
// f(a, b) with its partials at (a.v, b.v)
template <int N>
Jet<N> compose(const Jet<N>& a, const Jet<N>& b, double f, double fa, double fb, double faa,
               double fab, double fbb) {
  Jet<N> r;
  r.v = f;
  for (int i = 0; i < N; ++i) r.g[i] = fa * a.g[i] + fb * b.g[i];
  for (int i = 0; i < N; ++i)
    for (int k = 0; k < N; ++k)
      r.H[i][k] = fa * a.H[i][k] + fb * b.H[i][k] + faa * a.g[i] * a.g[k] +
                  fab * (a.g[i] * b.g[k] + b.g[i] * a.g[k]) + fbb * b.g[i] * b.g[k];
  return r;
}

// ---- scalar-generic helpers for test functions --------------------------------------------
// Test functions are templates on the scalar S and call math functions unqualified, so that
// argument-dependent lookup finds eom:: (Embedded) and the global qd (dd_real) overloads.
// qd needs three detours, all in the dd_real reference only:
//  * it has no hypot;
//  * pow(dd_real, 0.7) silently picks pow(dd_real, int) (a standard conversion beats the
//    user-defined double -> dd_real), so a real exponent must be passed as a dd_real;
//  * pow(dd_real, dd_real) is exp(b·log a), undefined for a < 0 even for an integer-valued b.
template <class S>
S hyp(const S& a, const S& b) {
  if constexpr (std::is_same_v<S, dd_real>) {
    return sqrt(a * a + b * b);
  } else {
    using std::hypot;
    return hypot(a, b);
  }
}
template <class S>
S rpow(const S& a, double r) {  // a^r, r a real (double) exponent
  if constexpr (std::is_same_v<S, dd_real>) {
    if (r == std::trunc(r)) return pow(a, static_cast<int>(r));
    return pow(a, dd_real(r));
  } else {
    using std::pow;
    return pow(a, r);
  }
}
template <class S>
S cpow(double c, const S& b) {  // c^b, c a double base
  if constexpr (std::is_same_v<S, dd_real>) {
    return pow(dd_real(c), b);
  } else {
    using std::pow;
    return pow(c, b);
  }
}

// ---- high-precision central differences ----------------------------------------------------
// Sixth-order central stencils with step h:
//   f'(x)  ≈ Σ_k w1_k (f(x+kh) − f(x−kh)) / (60 h),              w1 = (45, −9, 1)
//   f''(x) ≈ (−490 f(x) + Σ_k w2_k (f(x+kh) + f(x−kh))) / (180 h²), w2 = (270, −27, 2)
//   ∂²f/∂xi∂xj ≈ Σ_k Σ_l w1_k w1_l (f(++) − f(+−) − f(−+) + f(−−)) / (3600 h²)
// Truncation is O(h⁶ f⁽⁷⁾) resp. O(h⁶ f⁽⁸⁾); with h = 2⁻¹³ ≈ 1.2e-4 that is ~1e-24 for O(1)
// derivatives, and dd_real's rounding (~1e-32) divided by h² is ~1e-23: both far below the 1e-12
// tolerance of the double AD. Measured against Embedded<3, dd_real, 2> the differences agree to
// about 1e-20 (qd's own function accuracy included), which allows a 1e-18 check of dd_real AD.
inline constexpr double kStep = 1.0 / 8192.0;
inline constexpr std::array<double, 3> kW1{45.0, -9.0, 1.0};
inline constexpr std::array<double, 3> kW2{270.0, -27.0, 2.0};

// f: std::array<dd_real, N> -> dd_real; x in double (exactly representable shifts: h = 2⁻¹³).
template <int N, class F>
Jet<N, dd_real> central_differences(const F& f, const std::array<double, N>& x,
                                    double h = kStep) {
  auto at = [&](int i, double di, int j, double dj) {
    std::array<dd_real, N> p;
    for (int m = 0; m < N; ++m) p[m] = dd_real(x[m]);
    if (i >= 0) p[i] += dd_real(di);
    if (j >= 0) p[j] += dd_real(dj);
    return f(p);
  };
  Jet<N, dd_real> r;
  const dd_real f0 = at(-1, 0, -1, 0);
  r.v = f0;
  const dd_real hh(h);
  for (int i = 0; i < N; ++i) {
    dd_real d1(0), d2 = dd_real(-490.0) * f0;
    for (int k = 1; k <= 3; ++k) {
      const dd_real fp = at(i, k * h, -1, 0), fm = at(i, -k * h, -1, 0);
      d1 += dd_real(kW1[k - 1]) * (fp - fm);
      d2 += dd_real(kW2[k - 1]) * (fp + fm);
    }
    r.g[i] = d1 / (dd_real(60.0) * hh);
    r.H[i][i] = d2 / (dd_real(180.0) * hh * hh);
  }
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < i; ++j) {
      dd_real s(0);
      for (int k = 1; k <= 3; ++k)
        for (int l = 1; l <= 3; ++l) {
          const dd_real c = at(i, k * h, j, l * h) - at(i, k * h, j, -l * h) -
                            at(i, -k * h, j, l * h) + at(i, -k * h, j, -l * h);
          s += dd_real(kW1[k - 1] * kW1[l - 1]) * c;
        }
      r.H[i][j] = r.H[j][i] = s / (dd_real(3600.0) * hh * hh);
    }
  return r;
}

template <int N>
Jet<N> to_double_jet(const Jet<N, dd_real>& j) {
  Jet<N> r;
  r.v = to_double(j.v);
  for (int i = 0; i < N; ++i) r.g[i] = to_double(j.g[i]);
  for (int i = 0; i < N; ++i)
    for (int k = 0; k < N; ++k) r.H[i][k] = to_double(j.H[i][k]);
  return r;
}

// The N independent variables at x, as an Embedded type A.
template <class A, std::size_t N>
std::array<A, N> variables(const std::array<double, N>& x) {
  std::array<A, N> r;
  for (std::size_t i = 0; i < N; ++i)
    r[i] = A::variable(typename A::real_type(x[i]), static_cast<int>(i));
  return r;
}

inline std::string point_name(const std::array<double, 3>& x) {
  char b[96];
  std::snprintf(b, sizeof b, "(%g, %g, %g)", x[0], x[1], x[2]);
  return b;
}

}  // namespace adtest
