// eom::Jet<T, N>: a truncated univariate Taylor series in the normalized coefficients
//   x(τ) = x₀ + x₁ τ + … + x_{N−1} τ^{N−1} + O(τ^N),   x_k = x⁽ᵏ⁾(0) / k!,
// propagated by operator overloading with the standard recurrences of Taylor arithmetic
// (Griewank & Walther, "Evaluating Derivatives", ch. 13; Jorba & Zou 2005): products by
// convolution, quotients, sqrt, exp, log and pow by their recurrences, sin and cos together, and
// tan, tanh, asin, acos, atan, atan2 and hypot through their derivative ODEs with an auxiliary series.
// Coefficient k of a result depends only on coefficients 0..k of the arguments.
//
// Known length. A jet knows its first `n` coefficients (1 <= n <= N); n = 0 marks a constant,
// whose higher coefficients are exactly zero (they are stored as zeros) to every order. An
// operation knows as many coefficients as its least-known argument, and constants do not limit
// it. So a caller that knows a series only to order k seeds jets with n = k + 1 and pays for
// k + 1 coefficients, not N (eom::Reference's Taylor kernel does this at every order), and
// constants (parameters, zero derivatives inside a nesting Embedded) cost one coefficient.
//
// T is double, long double, qd's dd_real (math functions found by argument-dependent lookup),
// and a Jet nests inside eom::Embedded<n, Jet<...>, Order> (the reference's dynamics run on it).
// Comparisons look at the order-0 value only: a branch (eom::select, |x|, a pivot test) is the
// one taken at the expansion point, as the Taylor kernel contract requires.
// No heap, no exceptions; the storage is a std::array.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <limits>
#include <type_traits>

#include "eom/numeric/ad.hpp"

namespace eom {

template <class T, int N>
struct Jet {
  static_assert(N >= 1, "Jet: at least the order-0 coefficient");
  static constexpr int capacity = N;
  using real_type = T;

  std::array<T, N> c{};  // normalized Taylor coefficients x_k = x⁽ᵏ⁾(0)/k!
  int n = 0;             // known leading coefficients; 0: a constant (c[0], all higher exactly 0)

  constexpr Jet() = default;
  constexpr Jet(const T& value) { c[0] = value; }  // NOLINT: a constant converts implicitly
  template <class C>
    requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
  constexpr Jet(C value) {  // NOLINT
    if constexpr (std::is_constructible_v<T, C>)
      c[0] = T(value);
    else  // e.g. dd_real from long: only int and double constructors exist
      c[0] = T(static_cast<double>(value));
  }

  // The independent variable τ ↦ x0 + τ, known to every order.
  static constexpr Jet variable(const T& x0) {
    Jet x(x0);
    if constexpr (N > 1) x.c[1] = T(1);
    x.n = N;
    return x;
  }
  // A series known to its first `count` coefficients (1 <= count <= N).
  static constexpr Jet truncated(const T* coefficients, int count) {
    Jet x;
    for (int k = 0; k < count; ++k) x.c[k] = coefficients[k];
    x.n = count;
    return x;
  }

  constexpr bool is_constant() const { return n == 0; }
  constexpr int size() const { return n == 0 ? N : n; }  // coefficients that may be read
  constexpr const T& value() const { return c[0]; }
  constexpr const T& operator[](int k) const { return c[k]; }

  constexpr Jet& operator+=(const Jet& b) { return *this = *this + b; }
  constexpr Jet& operator-=(const Jet& b) { return *this = *this - b; }
  constexpr Jet& operator*=(const Jet& b) { return *this = *this * b; }
  constexpr Jet& operator/=(const Jet& b) { return *this = *this / b; }

  // Known length of a result of a and b (0 when both are constants), and how many coefficients
  // to compute for it.
  static constexpr int common(const Jet& a, const Jet& b) {
    return a.n == 0 ? b.n : b.n == 0 ? a.n : std::min(a.n, b.n);
  }
  static constexpr int computed(int known) { return known == 0 ? 1 : known; }
  // A result with known length `known`, every coefficient zero.
  static constexpr Jet with_length(int known) {
    Jet r;
    r.n = known;
    return r;
  }

  // ---- arithmetic -----------------------------------------------------------------------------
  friend constexpr Jet operator+(const Jet& a) { return a; }
  friend constexpr Jet operator-(const Jet& a) {
    Jet r = with_length(a.n);
    for (int k = 0; k < computed(a.n); ++k) r.c[k] = -a.c[k];
    return r;
  }
  friend constexpr Jet operator+(const Jet& a, const Jet& b) {
    Jet r = with_length(common(a, b));
    for (int k = 0; k < computed(r.n); ++k) r.c[k] = a.c[k] + b.c[k];
    return r;
  }
  friend constexpr Jet operator-(const Jet& a, const Jet& b) {
    Jet r = with_length(common(a, b));
    for (int k = 0; k < computed(r.n); ++k) r.c[k] = a.c[k] - b.c[k];
    return r;
  }
  // (ab)_k = Σ_{j=0..k} a_j b_{k−j}; a constant factor scales.
  friend constexpr Jet operator*(const Jet& a, const Jet& b) {
    Jet r = with_length(common(a, b));
    const int m = computed(r.n);
    if (a.n == 0) {
      for (int k = 0; k < m; ++k) r.c[k] = a.c[0] * b.c[k];
    } else if (b.n == 0) {
      for (int k = 0; k < m; ++k) r.c[k] = a.c[k] * b.c[0];
    } else {
      for (int k = 0; k < m; ++k) {
        T s = a.c[0] * b.c[k];
        for (int j = 1; j <= k; ++j) s += a.c[j] * b.c[k - j];
        r.c[k] = s;
      }
    }
    return r;
  }
  // q = a/b from q b = a: q_k = (a_k − Σ_{j=1..k} b_j q_{k−j}) / b_0.
  friend constexpr Jet operator/(const Jet& a, const Jet& b) {
    Jet r = with_length(common(a, b));
    const int m = computed(r.n);
    if (b.n == 0) {
      for (int k = 0; k < m; ++k) r.c[k] = a.c[k] / b.c[0];
    } else {
      for (int k = 0; k < m; ++k) {
        T s = a.c[k];
        for (int j = 1; j <= k; ++j) s -= b.c[j] * r.c[k - j];
        r.c[k] = s / b.c[0];
      }
    }
    return r;
  }

  // Comparisons look at the order-0 values only.
  friend constexpr bool operator==(const Jet& a, const Jet& b) { return a.c[0] == b.c[0]; }
  friend constexpr bool operator<(const Jet& a, const Jet& b) { return a.c[0] < b.c[0]; }
  friend constexpr bool operator>(const Jet& a, const Jet& b) { return a.c[0] > b.c[0]; }
  friend constexpr bool operator<=(const Jet& a, const Jet& b) { return a.c[0] <= b.c[0]; }
  friend constexpr bool operator>=(const Jet& a, const Jet& b) { return a.c[0] >= b.c[0]; }
};

// Comparisons with constants on either side (a constant is not promoted to a jet).
#define EOM_JET_COMPARE(op)                                                                      \
  template <class T, int N, class C>                                                             \
    requires std::convertible_to<C, T>                                                           \
  constexpr bool operator op(const Jet<T, N>& a, const C& b) { return a.c[0] op T(b); }          \
  template <class T, int N, class C>                                                             \
    requires std::convertible_to<C, T>                                                           \
  constexpr bool operator op(const C& a, const Jet<T, N>& b) { return T(a) op b.c[0]; }
EOM_JET_COMPARE(==)
EOM_JET_COMPARE(!=)
EOM_JET_COMPARE(<)
EOM_JET_COMPARE(>)
EOM_JET_COMPARE(<=)
EOM_JET_COMPARE(>=)
#undef EOM_JET_COMPARE

template <class T> struct is_jet : std::false_type {};
template <class T, int N> struct is_jet<Jet<T, N>> : std::true_type {};

// The order-0 value as a double (found by eom::as_double through argument-dependent lookup):
// pivot tests and finiteness checks of the reference's linear algebra use it.
template <class T, int N> constexpr double to_double(const Jet<T, N>& a) { return as_double(a.c[0]); }

namespace detail {
template <class T> bool scalar_is_finite(const T& x) {
  if constexpr (std::is_floating_point_v<T>)
    return std::isfinite(x);
  else
    return std::isfinite(as_double(x));
}
// hypot on any real type: std::hypot where it exists, else scaled so that the squares cannot
// overflow (qd has no hypot).
template <class T> T scalar_hypot(const T& a, const T& b) {
  using std::abs, std::sqrt;
  if constexpr (std::is_floating_point_v<T>) {
    return std::hypot(a, b);
  } else {
    const T x = abs(a), y = abs(b);
    const T big = x > y ? x : y, small = x > y ? y : x;
    if (big == T(0)) return T(0);
    const T ratio = small / big;
    return big * sqrt(T(1) + ratio * ratio);
  }
}
}  // namespace detail

// Every known coefficient is finite (an overflowing higher coefficient makes the jet non-finite).
template <class T, int N> bool isfinite(const Jet<T, N>& a) {
  for (int k = 0; k < a.size(); ++k)
    if (!detail::scalar_is_finite(a.c[k])) return false;
  return true;
}

// ---- elementary functions ------------------------------------------------------------------
// Each takes the constant shortcut (one scalar call) and otherwise runs its recurrence over the
// argument's known length.
template <class T, int N> using J_ = Jet<T, N>;

namespace detail {
// sin and cos together: s' = c a', c' = −s a' give
//   s_k = (1/k) Σ_{j=1..k} j a_j c_{k−j},   c_k = −(1/k) Σ_{j=1..k} j a_j s_{k−j}.
template <class T, int N> void sin_cos(const J_<T, N>& a, J_<T, N>& s, J_<T, N>& c) {
  using std::cos, std::sin;
  s = J_<T, N>::with_length(a.n);
  c = J_<T, N>::with_length(a.n);
  s.c[0] = sin(a.c[0]);
  c.c[0] = cos(a.c[0]);
  for (int k = 1; k < a.n; ++k) {
    T ss(0), cc(0);
    for (int j = 1; j <= k; ++j) {
      const T ja = T(j) * a.c[j];
      ss += ja * c.c[k - j];
      cc += ja * s.c[k - j];
    }
    s.c[k] = ss / T(k);
    c.c[k] = -cc / T(k);
  }
}
// r with r' w = a' (r_0 given): k r_k w_0 = k a_k − Σ_{j=1..k−1} j r_j w_{k−j}. The shape of
// asin (w = √(1 − a²)), atan (w = 1 + a²).
template <class T, int N> J_<T, N> integrate_quotient(const J_<T, N>& a, const J_<T, N>& w, const T& r0) {
  J_<T, N> r = J_<T, N>::with_length(a.n);
  r.c[0] = r0;
  for (int k = 1; k < a.n; ++k) {
    T s(0);
    for (int j = 1; j < k; ++j) s += T(j) * r.c[j] * w.c[k - j];
    r.c[k] = (a.c[k] - s / T(k)) / w.c[0];
  }
  return r;
}
// e = exp(a) with a given order-0 value (pow passes its own, more accurate one):
//   e' = a' e  →  e_k = (1/k) Σ_{j=1..k} j a_j e_{k−j}.
template <class T, int N> J_<T, N> exp_series(const J_<T, N>& a, const T& e0) {
  J_<T, N> e = J_<T, N>::with_length(a.n);
  e.c[0] = e0;
  for (int k = 1; k < a.n; ++k) {
    T s(0);
    for (int j = 1; j <= k; ++j) s += T(j) * a.c[j] * e.c[k - j];
    e.c[k] = s / T(k);
  }
  return e;
}
// r = √s with r_0 given: r_k = (s_k − Σ_{j=1..k−1} r_j r_{k−j}) / (2 r_0).
template <class T, int N> J_<T, N> sqrt_series(const J_<T, N>& s, const T& r0) {
  J_<T, N> r = J_<T, N>::with_length(s.n);
  r.c[0] = r0;
  for (int k = 1; k < s.n; ++k) {
    T sum(0);
    for (int j = 1; j < k; ++j) sum += r.c[j] * r.c[k - j];
    r.c[k] = (s.c[k] - sum) / (T(2) * r0);
  }
  return r;
}
}  // namespace detail

template <class T, int N> J_<T, N> sin(const J_<T, N>& a) {
  using std::sin;
  if (a.is_constant()) return J_<T, N>(sin(a.c[0]));
  J_<T, N> s, c;
  detail::sin_cos(a, s, c);
  return s;
}
template <class T, int N> J_<T, N> cos(const J_<T, N>& a) {
  using std::cos;
  if (a.is_constant()) return J_<T, N>(cos(a.c[0]));
  J_<T, N> s, c;
  detail::sin_cos(a, s, c);
  return c;
}
namespace detail {
// t = tan a (sign +1) or tanh a (sign −1), t_0 given: t' = u a' with the auxiliary u = 1 ± t²,
//   t_k = (1/k) Σ_{j=1..k} j a_j u_{k−j},   u_k = ±Σ_{j=0..k} t_j t_{k−j} (k >= 1).
template <class T, int N> J_<T, N> tangent_series(const J_<T, N>& a, const T& t0, int sign) {
  J_<T, N> t = J_<T, N>::with_length(a.n);
  std::array<T, N> u{};
  t.c[0] = t0;
  u[0] = T(1) + T(sign) * t0 * t0;
  for (int k = 1; k < a.n; ++k) {
    T s(0);
    for (int j = 1; j <= k; ++j) s += T(j) * a.c[j] * u[k - j];
    t.c[k] = s / T(k);
    T tt(0);
    for (int j = 0; j <= k; ++j) tt += t.c[j] * t.c[k - j];
    u[k] = T(sign) * tt;
  }
  return t;
}
}  // namespace detail
template <class T, int N> J_<T, N> tan(const J_<T, N>& a) {
  using std::tan;
  const T t0 = tan(a.c[0]);
  if (a.is_constant()) return J_<T, N>(t0);
  return detail::tangent_series(a, t0, 1);
}
template <class T, int N> J_<T, N> tanh(const J_<T, N>& a) {
  using std::tanh;
  const T t0 = tanh(a.c[0]);
  if (a.is_constant()) return J_<T, N>(t0);
  return detail::tangent_series(a, t0, -1);
}
// asin a: r' √(1 − a²) = a'.
template <class T, int N> J_<T, N> asin(const J_<T, N>& a) {
  using std::asin, std::sqrt;
  if (a.is_constant()) return J_<T, N>(asin(a.c[0]));
  const J_<T, N> v = T(1) - a * a;
  return detail::integrate_quotient(a, detail::sqrt_series(v, T(sqrt(v.c[0]))), T(asin(a.c[0])));
}
// acos a = π/2 − asin a: the same higher coefficients, negated.
template <class T, int N> J_<T, N> acos(const J_<T, N>& a) {
  using std::acos;
  if (a.is_constant()) return J_<T, N>(acos(a.c[0]));
  J_<T, N> r = -asin(a);
  r.c[0] = acos(a.c[0]);
  return r;
}
// atan a: r' (1 + a²) = a'.
template <class T, int N> J_<T, N> atan(const J_<T, N>& a) {
  using std::atan;
  if (a.is_constant()) return J_<T, N>(atan(a.c[0]));
  return detail::integrate_quotient(a, T(1) + a * a, T(atan(a.c[0])));
}
// r = atan2(y, x): r' w = x y' − y x' with w = x² + y². In coefficients, with
// d_{k−1} = Σ_{j=0..k−1} (k−j) (x_j y_{k−j} − y_j x_{k−j}) the (k−1)-th coefficient of x y' − y x':
//   k r_k w_0 = d_{k−1} − Σ_{j=1..k−1} j r_j w_{k−j}.
template <class T, int N> J_<T, N> atan2(const J_<T, N>& y, const J_<T, N>& x) {
  using std::atan2;
  const int known = J_<T, N>::common(y, x);
  if (known == 0) return J_<T, N>(atan2(y.c[0], x.c[0]));
  const J_<T, N> w = x * x + y * y;
  J_<T, N> r = J_<T, N>::with_length(known);
  r.c[0] = atan2(y.c[0], x.c[0]);
  for (int k = 1; k < known; ++k) {
    T d(0), s(0);
    for (int j = 0; j < k; ++j) d += T(k - j) * (x.c[j] * y.c[k - j] - y.c[j] * x.c[k - j]);
    for (int j = 1; j < k; ++j) s += T(j) * r.c[j] * w.c[k - j];
    r.c[k] = (d - s) / (T(k) * w.c[0]);
  }
  return r;
}
template <class T, int N> J_<T, N> exp(const J_<T, N>& a) {
  using std::exp;
  if (a.is_constant()) return J_<T, N>(exp(a.c[0]));
  return detail::exp_series(a, T(exp(a.c[0])));
}
// r = log a: r' a = a'  →  r_k = (a_k − (1/k) Σ_{j=1..k−1} j r_j a_{k−j}) / a_0.
template <class T, int N> J_<T, N> log(const J_<T, N>& a) {
  using std::log;
  if (a.is_constant()) return J_<T, N>(log(a.c[0]));
  return detail::integrate_quotient(a, a, T(log(a.c[0])));
}
template <class T, int N> J_<T, N> sqrt(const J_<T, N>& a) {
  using std::sqrt;
  if (a.is_constant()) return J_<T, N>(sqrt(a.c[0]));
  return detail::sqrt_series(a, T(sqrt(a.c[0])));
}
// √(a² + b²): the square root recurrence on a² + b², its value from a scaled hypot.
template <class T, int N> J_<T, N> hypot(const J_<T, N>& a, const J_<T, N>& b) {
  const T r0 = detail::scalar_hypot(a.c[0], b.c[0]);
  if (J_<T, N>::common(a, b) == 0) return J_<T, N>(r0);
  return detail::sqrt_series(a * a + b * b, r0);
}
// |a|: the sign taken at the order-0 value (+ at 0, like Embedded's abs).
template <class T, int N> J_<T, N> abs(const J_<T, N>& a) { return a.c[0] < T(0) ? -a : a; }
template <class T, int N> J_<T, N> fabs(const J_<T, N>& a) { return abs(a); }
// Piecewise constant: zero higher coefficients (Embedded's pow uses floor to detect integers).
template <class T, int N> J_<T, N> floor(const J_<T, N>& a) {
  using std::floor;
  return J_<T, N>(floor(a.c[0]));
}
template <class T, int N> J_<T, N> ceil(const J_<T, N>& a) {
  using std::ceil;
  return J_<T, N>(ceil(a.c[0]));
}

// a^n for an integer n: repeated squaring, exact at a_0 = 0 and for a_0 < 0.
template <class T, int N> J_<T, N> pow(const J_<T, N>& a, int n) {
  if (n == 0) return J_<T, N>(T(1));
  return detail::ipow(a, n);
}
// a^r for a constant real r. Integer-valued r takes the integer rule (defined at a_0 <= 0, and
// a wide type's pow may be exp(r log a)); otherwise p' a = r a' p gives
//   p_k = Σ_{j=0..k−1} (r (k−j) − j) a_{k−j} p_j / (k a_0),
// which needs a_0 != 0 (a^r is not analytic at 0: the higher coefficients come out Inf/NaN).
template <class T, int N> J_<T, N> pow(const J_<T, N>& a, const T& r) {
  using std::abs, std::floor, std::pow;
  if (r == floor(r) && abs(r) <= T(1 << 20)) return pow(a, static_cast<int>(as_double(r)));
  if (a.is_constant()) return J_<T, N>(pow(a.c[0], r));
  J_<T, N> p = J_<T, N>::with_length(a.n);
  p.c[0] = pow(a.c[0], r);
  for (int k = 1; k < a.n; ++k) {
    T s(0);
    for (int j = 0; j < k; ++j) s += (r * T(k - j) - T(j)) * a.c[k - j] * p.c[j];
    p.c[k] = s / (T(k) * a.c[0]);
  }
  return p;
}
template <class T, int N, class C>
  requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T> && !std::is_same_v<C, int>)
J_<T, N> pow(const J_<T, N>& a, C r) {
  if constexpr (std::is_integral_v<C>)
    return pow(a, static_cast<int>(r));
  else
    return pow(a, T(r));
}
// a^b = exp(b log a) with the value pow(a_0, b_0); a constant exponent is the rule above.
template <class T, int N> J_<T, N> pow(const J_<T, N>& a, const J_<T, N>& b) {
  using std::pow;
  if (b.is_constant()) return pow(a, b.c[0]);
  return detail::exp_series(b * log(a), T(pow(a.c[0], b.c[0])));
}
template <class T, int N> J_<T, N> pow(const T& c, const J_<T, N>& b) {
  using std::log, std::pow;
  if (b.is_constant()) return J_<T, N>(pow(c, b.c[0]));
  return detail::exp_series(b * T(log(c)), T(pow(c, b.c[0])));
}
template <class T, int N, class C>
  requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
J_<T, N> pow(C c, const J_<T, N>& b) { return pow(T(c), b); }

// Mixed forms with a constant on one side.
template <class T, int N, class C>
  requires std::convertible_to<C, T>
J_<T, N> atan2(const J_<T, N>& y, const C& x) { return atan2(y, J_<T, N>(T(x))); }
template <class T, int N, class C>
  requires std::convertible_to<C, T>
J_<T, N> atan2(const C& y, const J_<T, N>& x) { return atan2(J_<T, N>(T(y)), x); }
template <class T, int N, class C>
  requires std::convertible_to<C, T>
J_<T, N> hypot(const J_<T, N>& a, const C& b) { return hypot(a, J_<T, N>(T(b))); }
template <class T, int N, class C>
  requires std::convertible_to<C, T>
J_<T, N> hypot(const C& a, const J_<T, N>& b) { return hypot(J_<T, N>(T(a)), b); }

}  // namespace eom

// The limits of the coefficient type: linalg's pivot tolerance reads epsilon() through them.
namespace std {
template <class T, int N> class numeric_limits<eom::Jet<T, N>> : public numeric_limits<T> {};
}  // namespace std
