// The OCEA embedded variable (paper eq. 1): a scalar carried together with its gradient and
// Hessian with respect to N independent variables, propagated by operator overloading (eqs. 2-3).
//
//   Embedded<N, T, 2>  value, gradient[N], Hessian (symmetric, packed lower triangle)
//   Embedded<N, T, 1>  value, gradient[N] (first-order forward mode; no Hessian storage)
//
// Storage is a plain aggregate of std::array: no heap, trivially copyable when T is. T is any
// real type with the usual math functions found by ADL (double, long double, qd's dd_real) or
// another Embedded, which nests derivatives: Embedded<n, Embedded<1, double, 1>> carries the
// directional derivative of a Hessian, which the reference uses for the mass matrix rate.
//
// Every elementary function f(a) is one application of the chain rule
//   f(a) -> ( f, f'·∇a, f'·∇²a + f''·∇a∇aᵀ ),
// and every binary one of its two-argument form; the rules differ only in (f, f', f'').
#pragma once

#include <array>
#include <cmath>
#include <concepts>
#include <type_traits>

namespace eom {

template <int N, class T = double, int Order = 2>
struct Embedded {
  static_assert(N >= 0, "Embedded: the number of independent variables must be >= 0");
  static_assert(Order == 1 || Order == 2, "Embedded: Order must be 1 (gradient) or 2 (Hessian)");
  static constexpr int size = N;
  static constexpr int order = Order;
  static constexpr int hessian_size = Order == 2 ? N * (N + 1) / 2 : 0;
  using real_type = T;

  T v{};                            // value
  std::array<T, N> g{};             // gradient
  std::array<T, hessian_size> h{};  // Hessian, lower triangle row by row: (i, j), j <= i

  constexpr Embedded() = default;
  constexpr Embedded(const T& value) : v(value) {}  // NOLINT: a constant converts implicitly
  template <class C>
    requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
  constexpr Embedded(C value) : v(static_cast<T>(value)) {}  // NOLINT

  // The i-th independent variable at `value`: gradient e_i, Hessian 0.
  static constexpr Embedded variable(const T& value, int i) {
    Embedded x(value);
    x.g[i] = T(1);
    return x;
  }

  static constexpr int index(int i, int j) { return i >= j ? i * (i + 1) / 2 + j : j * (j + 1) / 2 + i; }
  constexpr const T& value() const { return v; }
  constexpr const T& gradient(int i) const { return g[i]; }
  constexpr const T& hessian(int i, int j) const
    requires(Order == 2)
  {
    return h[index(i, j)];
  }

  constexpr Embedded& operator+=(const Embedded& b) { return *this = *this + b; }
  constexpr Embedded& operator-=(const Embedded& b) { return *this = *this - b; }
  constexpr Embedded& operator*=(const Embedded& b) { return *this = *this * b; }
  constexpr Embedded& operator/=(const Embedded& b) { return *this = *this / b; }

  // ---- arithmetic -------------------------------------------------------------------------
  friend constexpr Embedded operator+(const Embedded& a) { return a; }
  friend constexpr Embedded operator-(const Embedded& a) {
    Embedded r;
    r.v = -a.v;
    for (int i = 0; i < N; ++i) r.g[i] = -a.g[i];
    for (int k = 0; k < hessian_size; ++k) r.h[k] = -a.h[k];
    return r;
  }
  friend constexpr Embedded operator+(const Embedded& a, const Embedded& b) {
    Embedded r;
    r.v = a.v + b.v;
    for (int i = 0; i < N; ++i) r.g[i] = a.g[i] + b.g[i];
    for (int k = 0; k < hessian_size; ++k) r.h[k] = a.h[k] + b.h[k];
    return r;
  }
  friend constexpr Embedded operator-(const Embedded& a, const Embedded& b) {
    Embedded r;
    r.v = a.v - b.v;
    for (int i = 0; i < N; ++i) r.g[i] = a.g[i] - b.g[i];
    for (int k = 0; k < hessian_size; ++k) r.h[k] = a.h[k] - b.h[k];
    return r;
  }
  // Eq. (3): (ab, a∇b + b∇a, a∇²b + ∇a∇bᵀ + ∇b∇aᵀ + b∇²a)
  friend constexpr Embedded operator*(const Embedded& a, const Embedded& b) {
    Embedded r;
    r.v = a.v * b.v;
    for (int i = 0; i < N; ++i) r.g[i] = a.v * b.g[i] + b.v * a.g[i];
    if constexpr (Order == 2)
      for (int i = 0, k = 0; i < N; ++i)
        for (int j = 0; j <= i; ++j, ++k)
          r.h[k] = a.v * b.h[k] + b.v * a.h[k] + a.g[i] * b.g[j] + b.g[i] * a.g[j];
    return r;
  }
  friend constexpr Embedded operator/(const Embedded& a, const Embedded& b) {
    const T q = a.v / b.v, inv = T(1) / b.v;
    // f = a/b: fa = 1/b, fb = -a/b², faa = 0, fab = -1/b², fbb = 2a/b³
    return binary(a, b, q, inv, -q * inv, T(0), -inv * inv, T(2) * q * inv * inv);
  }

  // Operations with a constant: cheaper than promoting the constant to an Embedded.
  friend constexpr Embedded operator+(const Embedded& a, const T& c) { Embedded r = a; r.v += c; return r; }
  friend constexpr Embedded operator+(const T& c, const Embedded& a) { return a + c; }
  friend constexpr Embedded operator-(const Embedded& a, const T& c) { Embedded r = a; r.v -= c; return r; }
  friend constexpr Embedded operator-(const T& c, const Embedded& a) { return -a + c; }
  friend constexpr Embedded operator*(const Embedded& a, const T& c) { return scaled(a, c); }
  friend constexpr Embedded operator*(const T& c, const Embedded& a) { return scaled(a, c); }
  friend constexpr Embedded operator/(const Embedded& a, const T& c) { return scaled(a, T(1) / c); }
  friend constexpr Embedded operator/(const T& c, const Embedded& a) {
    const T inv = T(1) / a.v;
    return unary(a, c * inv, -c * inv * inv, T(2) * c * inv * inv * inv);
  }
  template <class C> requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
  friend constexpr Embedded operator+(const Embedded& a, C c) { return a + T(c); }
  template <class C> requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
  friend constexpr Embedded operator+(C c, const Embedded& a) { return a + T(c); }
  template <class C> requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
  friend constexpr Embedded operator-(const Embedded& a, C c) { return a - T(c); }
  template <class C> requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
  friend constexpr Embedded operator-(C c, const Embedded& a) { return T(c) - a; }
  template <class C> requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
  friend constexpr Embedded operator*(const Embedded& a, C c) { return scaled(a, T(c)); }
  template <class C> requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
  friend constexpr Embedded operator*(C c, const Embedded& a) { return scaled(a, T(c)); }
  template <class C> requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
  friend constexpr Embedded operator/(const Embedded& a, C c) { return a / T(c); }
  template <class C> requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
  friend constexpr Embedded operator/(C c, const Embedded& a) { return T(c) / a; }

  // Comparisons look at values only (a branch taken at run time is the local derivative).
  friend constexpr bool operator==(const Embedded& a, const Embedded& b) { return a.v == b.v; }
  friend constexpr bool operator<(const Embedded& a, const Embedded& b) { return a.v < b.v; }
  friend constexpr bool operator>(const Embedded& a, const Embedded& b) { return a.v > b.v; }
  friend constexpr bool operator<=(const Embedded& a, const Embedded& b) { return a.v <= b.v; }
  friend constexpr bool operator>=(const Embedded& a, const Embedded& b) { return a.v >= b.v; }

  // ---- the chain rule, once for one argument and once for two -------------------------------
  static constexpr Embedded scaled(const Embedded& a, const T& c) {
    Embedded r;
    r.v = a.v * c;
    for (int i = 0; i < N; ++i) r.g[i] = a.g[i] * c;
    for (int k = 0; k < hessian_size; ++k) r.h[k] = a.h[k] * c;
    return r;
  }
  // f(a) with f' = d1, f'' = d2 at a.v
  static constexpr Embedded unary(const Embedded& a, const T& f, const T& d1, const T& d2) {
    Embedded r;
    r.v = f;
    for (int i = 0; i < N; ++i) r.g[i] = d1 * a.g[i];
    if constexpr (Order == 2)
      for (int i = 0, k = 0; i < N; ++i)
        for (int j = 0; j <= i; ++j, ++k) r.h[k] = d1 * a.h[k] + d2 * a.g[i] * a.g[j];
    return r;
  }
  // f(a, b) with its first (fa, fb) and second (faa, fab, fbb) partials at (a.v, b.v)
  static constexpr Embedded binary(const Embedded& a, const Embedded& b, const T& f, const T& fa,
                                   const T& fb, const T& faa, const T& fab, const T& fbb) {
    Embedded r;
    r.v = f;
    for (int i = 0; i < N; ++i) r.g[i] = fa * a.g[i] + fb * b.g[i];
    if constexpr (Order == 2)
      for (int i = 0, k = 0; i < N; ++i)
        for (int j = 0; j <= i; ++j, ++k)
          r.h[k] = fa * a.h[k] + fb * b.h[k] + faa * a.g[i] * a.g[j] +
                   fab * (a.g[i] * b.g[j] + b.g[i] * a.g[j]) + fbb * b.g[i] * b.g[j];
    return r;
  }
};

// Comparisons with constants on either side.
#define EOM_EMBEDDED_COMPARE(op)                                                                 \
  template <int N, class T, int O, class C>                                                      \
    requires std::convertible_to<C, T>                                                           \
  constexpr bool operator op(const Embedded<N, T, O>& a, const C& c) { return a.v op T(c); }     \
  template <int N, class T, int O, class C>                                                      \
    requires std::convertible_to<C, T>                                                           \
  constexpr bool operator op(const C& c, const Embedded<N, T, O>& a) { return T(c) op a.v; }
EOM_EMBEDDED_COMPARE(==)
EOM_EMBEDDED_COMPARE(!=)
EOM_EMBEDDED_COMPARE(<)
EOM_EMBEDDED_COMPARE(>)
EOM_EMBEDDED_COMPARE(<=)
EOM_EMBEDDED_COMPARE(>=)
#undef EOM_EMBEDDED_COMPARE

template <class T> struct is_embedded : std::false_type {};
template <int N, class T, int O> struct is_embedded<Embedded<N, T, O>> : std::true_type {};

// The value at the bottom of a (possibly nested) Embedded, as a double: for pivot tests,
// finiteness checks and printing. Wide types supply `to_double` (found by ADL), as qd does.
template <class T> constexpr double as_double(const T& x) {
  if constexpr (is_embedded<T>::value)
    return as_double(x.v);
  else if constexpr (std::is_arithmetic_v<T>)
    return static_cast<double>(x);
  else
    return to_double(x);
}

namespace detail {
// x^n for an integer n by repeated squaring: exact for any real type, defined for x < 0.
template <class T> constexpr T ipow(T x, int n) {
  if (n < 0) return T(1) / ipow(x, -n);
  T r(1);
  while (n) {
    if (n & 1) r = r * x;
    x = x * x;
    n >>= 1;
  }
  return r;
}
}  // namespace detail

// ---- elementary functions (f, f', f'') -------------------------------------------------------
template <int N, class T, int O> using E_ = Embedded<N, T, O>;

template <int N, class T, int O> constexpr E_<N, T, O> sin(const E_<N, T, O>& a) {
  using std::cos, std::sin;
  const T s = sin(a.v);
  return E_<N, T, O>::unary(a, s, cos(a.v), -s);
}
template <int N, class T, int O> constexpr E_<N, T, O> cos(const E_<N, T, O>& a) {
  using std::cos, std::sin;
  const T c = cos(a.v);
  return E_<N, T, O>::unary(a, c, -sin(a.v), -c);
}
template <int N, class T, int O> constexpr E_<N, T, O> tan(const E_<N, T, O>& a) {
  using std::tan;
  const T t = tan(a.v), d = T(1) + t * t;
  return E_<N, T, O>::unary(a, t, d, T(2) * t * d);
}
template <int N, class T, int O> constexpr E_<N, T, O> tanh(const E_<N, T, O>& a) {
  using std::tanh;
  const T t = tanh(a.v), d = T(1) - t * t;
  return E_<N, T, O>::unary(a, t, d, T(-2) * t * d);
}
template <int N, class T, int O> constexpr E_<N, T, O> asin(const E_<N, T, O>& a) {
  using std::asin, std::sqrt;
  const T w = T(1) - a.v * a.v, d = T(1) / sqrt(w);
  return E_<N, T, O>::unary(a, asin(a.v), d, a.v * d / w);
}
template <int N, class T, int O> constexpr E_<N, T, O> acos(const E_<N, T, O>& a) {
  using std::acos, std::sqrt;
  const T w = T(1) - a.v * a.v, d = T(1) / sqrt(w);
  return E_<N, T, O>::unary(a, acos(a.v), -d, -(a.v * d / w));
}
template <int N, class T, int O> constexpr E_<N, T, O> atan(const E_<N, T, O>& a) {
  using std::atan;
  const T d = T(1) / (T(1) + a.v * a.v);
  return E_<N, T, O>::unary(a, atan(a.v), d, T(-2) * a.v * d * d);
}
template <int N, class T, int O> constexpr E_<N, T, O> exp(const E_<N, T, O>& a) {
  using std::exp;
  const T e = exp(a.v);
  return E_<N, T, O>::unary(a, e, e, e);
}
template <int N, class T, int O> constexpr E_<N, T, O> log(const E_<N, T, O>& a) {
  using std::log;
  const T inv = T(1) / a.v;
  return E_<N, T, O>::unary(a, log(a.v), inv, -(inv * inv));
}
template <int N, class T, int O> constexpr E_<N, T, O> sqrt(const E_<N, T, O>& a) {
  using std::sqrt;
  const T s = sqrt(a.v), d = T(1) / (T(2) * s);
  return E_<N, T, O>::unary(a, s, d, -(d / (T(2) * a.v)));
}
// |a|: derivative sign(a); at a = 0 the one-sided derivatives differ and +1 is used.
template <int N, class T, int O> constexpr E_<N, T, O> abs(const E_<N, T, O>& a) {
  return a.v < T(0) ? -a : a;
}
template <int N, class T, int O> constexpr E_<N, T, O> fabs(const E_<N, T, O>& a) { return abs(a); }

template <int N, class T, int O> constexpr E_<N, T, O> pow(const E_<N, T, O>& a, int n) {
  if (n == 0) return E_<N, T, O>(T(1));
  const T pm2 = n >= 2 || n < 0 ? detail::ipow(a.v, n - 2) : T(0);
  const T pm1 = n == 1 ? T(1) : pm2 * a.v;
  return E_<N, T, O>::unary(a, pm1 * a.v, T(n) * pm1, T(n) * T(n - 1) * pm2);
}
namespace detail {
// a^r for a constant exponent r: (a^r, r·a^(r-1), r(r-1)·a^(r-2)). Each power is taken directly
// (not as a^(r-1)·a), so that a = 0 gives std::pow's value (0^0.5 = 0, 0^0 = 1), and a plain
// constant r = 0 or 1 has exact zero derivatives instead of 0·inf = NaN. When T is itself an
// Embedded, R stays the plain floating-point type so that the exponent is a constant one level
// down too (as a T it would take the AD^AD rule there, whose log(a) is NaN for a <= 0).
// A wide real type's pow may be exp(r·log a) (qd's is), NaN for a < 0 even when r is an integer
// (std::pow is defined there): such integer-valued exponents take the integer rule.
template <class A, class R> constexpr A pow_constant(const A& a, const R& r) {
  using std::abs, std::floor, std::pow;
  using T = typename A::real_type;
  constexpr bool plain = !is_embedded<R>::value;
  if constexpr (plain && !std::is_floating_point_v<T> && !is_embedded<T>::value) {
    if (r == floor(r) && abs(r) <= R(1 << 20)) return pow(a, static_cast<int>(as_double(r)));
  }
  const T f = pow(a.v, r);
  const T d1 = plain && r == R(0) ? T(0) : pow(a.v, r - R(1)) * r;
  const T d2 = plain && (r == R(0) || r == R(1)) ? T(0) : pow(a.v, r - R(2)) * (r * (r - R(1)));
  return A::unary(a, f, d1, d2);
}
}  // namespace detail
template <int N, class T, int O> constexpr E_<N, T, O> pow(const E_<N, T, O>& a, const T& r) {
  return detail::pow_constant(a, r);
}
template <int N, class T, int O, class C>
  requires(std::is_floating_point_v<C> && !std::is_same_v<C, T>)
constexpr E_<N, T, O> pow(const E_<N, T, O>& a, C r) {
  if constexpr (is_embedded<T>::value)
    return detail::pow_constant(a, r);
  else
    return detail::pow_constant(a, T(r));
}
template <int N, class T, int O> constexpr E_<N, T, O> pow(const T& c, const E_<N, T, O>& b) {
  using std::log, std::pow;
  const T f = pow(c, b.v), l = log(c);
  return E_<N, T, O>::unary(b, f, f * l, f * l * l);
}
template <int N, class T, int O, class C>
  requires(std::is_arithmetic_v<C> && !std::is_same_v<C, T>)
constexpr E_<N, T, O> pow(C c, const E_<N, T, O>& b) { return pow(T(c), b); }
template <int N, class T, int O> constexpr E_<N, T, O> pow(const E_<N, T, O>& a, const E_<N, T, O>& b) {
  using std::log, std::pow;
  const T f = pow(a.v, b.v), l = log(a.v), pm1 = pow(a.v, b.v - T(1));
  return E_<N, T, O>::binary(a, b, f, b.v * pm1, f * l, b.v * (b.v - T(1)) * pow(a.v, b.v - T(2)),
                             pm1 * (T(1) + b.v * l), f * l * l);
}
template <int N, class T, int O> constexpr E_<N, T, O> atan2(const E_<N, T, O>& y, const E_<N, T, O>& x) {
  using std::atan2;
  const T r2 = x.v * x.v + y.v * y.v, i2 = T(1) / r2, i4 = i2 * i2;
  // f_y = x/r², f_x = -y/r², f_yy = -2xy/r⁴, f_yx = (y²-x²)/r⁴, f_xx = 2xy/r⁴
  return E_<N, T, O>::binary(y, x, atan2(y.v, x.v), x.v * i2, -y.v * i2, T(-2) * x.v * y.v * i4,
                             (y.v * y.v - x.v * x.v) * i4, T(2) * x.v * y.v * i4);
}
template <int N, class T, int O> constexpr E_<N, T, O> hypot(const E_<N, T, O>& a, const E_<N, T, O>& b) {
  using std::sqrt;
  const T r = sqrt(a.v * a.v + b.v * b.v), i = T(1) / r, i3 = i * i * i;
  return E_<N, T, O>::binary(a, b, r, a.v * i, b.v * i, b.v * b.v * i3, -a.v * b.v * i3,
                             a.v * a.v * i3);
}
// Mixed forms with a constant on one side.
template <int N, class T, int O, class C>
  requires std::convertible_to<C, T>
constexpr E_<N, T, O> atan2(const E_<N, T, O>& y, const C& x) { return atan2(y, E_<N, T, O>(T(x))); }
template <int N, class T, int O, class C>
  requires std::convertible_to<C, T>
constexpr E_<N, T, O> atan2(const C& y, const E_<N, T, O>& x) { return atan2(E_<N, T, O>(T(y)), x); }
template <int N, class T, int O, class C>
  requires std::convertible_to<C, T>
constexpr E_<N, T, O> hypot(const E_<N, T, O>& a, const C& b) { return hypot(a, E_<N, T, O>(T(b))); }
template <int N, class T, int O, class C>
  requires std::convertible_to<C, T>
constexpr E_<N, T, O> hypot(const C& a, const E_<N, T, O>& b) { return hypot(E_<N, T, O>(T(a)), b); }

}  // namespace eom
