// eom::Jet: every function's Taylor coefficients against closed forms (double), identities that
// tie the recurrences to each other on a general series (double, long double, dd_real), the
// known-length bookkeeping, order-0 comparisons, and nesting inside eom::Embedded.
#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <cmath>
#include <complex>
#include <limits>
#include <numbers>

#include <eom/model/model.hpp>
#include <eom/numeric/ad.hpp>
#include <eom/numeric/jet.hpp>

namespace {

constexpr int N = 12;
using Jd = eom::Jet<double, N>;

double factorial(int k) {
  double f = 1;
  for (int i = 2; i <= k; ++i) f *= i;
  return f;
}
// Generalized binomial coefficient C(r, k).
double binomial(double r, int k) {
  double b = 1;
  for (int i = 0; i < k; ++i) b *= (r - i) / (i + 1);
  return b;
}

// Relative agreement of every coefficient with want(k), scaled by max(1, |want|).
template <class F>
void expect_coefficients(const Jd& x, F want, double tol, const char* what) {
  ASSERT_EQ(x.size(), N) << what;
  for (int k = 0; k < N; ++k) {
    const double w = want(k);
    EXPECT_NEAR(x[k], w, tol * std::max(1.0, std::abs(w))) << what << ", coefficient " << k;
  }
}

TEST(Jet, ElementaryFunctionsMatchClosedForms) {
  const double x0 = 0.7, eps = std::numeric_limits<double>::epsilon();
  const Jd x = Jd::variable(x0);
  const double tol = 64 * eps;
  expect_coefficients(exp(x), [&](int k) { return std::exp(x0) / factorial(k); }, tol, "exp");
  expect_coefficients(log(x), [&](int k) {
    return k == 0 ? std::log(x0) : (k % 2 ? 1.0 : -1.0) / (k * std::pow(x0, k));
  }, tol, "log");
  expect_coefficients(1.0 / x, [&](int k) { return (k % 2 ? -1.0 : 1.0) / std::pow(x0, k + 1); },
                      tol, "reciprocal");
  expect_coefficients(sqrt(x), [&](int k) { return binomial(0.5, k) * std::pow(x0, 0.5 - k); },
                      tol, "sqrt");
  expect_coefficients(pow(x, 2.3), [&](int k) { return binomial(2.3, k) * std::pow(x0, 2.3 - k); },
                      tol, "pow real");
  expect_coefficients(pow(x, -3), [&](int k) { return binomial(-3, k) * std::pow(x0, -3 - k); },
                      tol, "pow int");
  expect_coefficients(pow(2.0, x), [&](int k) {
    return std::pow(2.0, x0) * std::pow(std::log(2.0), k) / factorial(k);
  }, tol, "constant^jet");
  const double half_pi = std::numbers::pi / 2;
  expect_coefficients(sin(x), [&](int k) { return std::sin(x0 + k * half_pi) / factorial(k); },
                      tol, "sin");
  expect_coefficients(cos(x), [&](int k) { return std::cos(x0 + k * half_pi) / factorial(k); },
                      tol, "cos");

  // atan' = 1/(1 + x²) = Im-part of 1/(x − i): coefficient m of 1/(x0 + τ − i) is
  // (−1)^m / (x0 − i)^(m+1), so atan_k = (−1)^(k−1) Im((x0 − i)^(−k)) / k.
  const std::complex<double> z(x0, -1.0);
  expect_coefficients(atan(x), [&](int k) {
    return k == 0 ? std::atan(x0) : ((k - 1) % 2 ? -1.0 : 1.0) * std::imag(std::pow(z, -k)) / k;
  }, tol, "atan");
  // asin' = (1 − x)^(−1/2) (1 + x)^(−1/2): the product of two binomial series around y0.
  const double y0 = 0.3;  // |x| < 1 for asin, acos
  const Jd y = Jd::variable(y0);
  auto asin_at_y = [&](int k) {
    double s = 0;  // coefficient k−1 of asin', divided by k
    for (int j = 0; j < k; ++j)
      s += binomial(-0.5, j) * std::pow(1 - y0, -0.5 - j) * ((j % 2) ? -1.0 : 1.0) *
           binomial(-0.5, k - 1 - j) * std::pow(1 + y0, -0.5 - (k - 1 - j));
    return s / k;
  };
  expect_coefficients(asin(y), [&](int k) { return k == 0 ? std::asin(y0) : asin_at_y(k); }, tol,
                      "asin");
  expect_coefficients(acos(y), [&](int k) { return k == 0 ? std::acos(y0) : -asin_at_y(k); }, tol,
                      "acos");
  // tan = sin/cos computed by the independent sin/cos and quotient recurrences.
  const Jd t = tan(x), sc = sin(x) / cos(x);
  expect_coefficients(t, [&](int k) { return sc[k]; }, tol, "tan");
  // tanh = (e^2x − 1)/(e^2x + 1) by the independent exp and quotient recurrences.
  const Jd e = exp(2.0 * x), th = (e - 1.0) / (e + 1.0);
  expect_coefficients(tanh(x), [&](int k) { return th[k]; }, tol, "tanh");
}

TEST(Jet, IntegerPowersAreExactAtZeroAndForNegativeBases) {
  const Jd tau = Jd::variable(0.0);
  const Jd cube = pow(tau, 3);
  for (int k = 0; k < N; ++k) EXPECT_EQ(cube[k], k == 3 ? 1.0 : 0.0);
  // (−2 + τ)^3 = −8 + 12τ − 6τ² + τ³, also through a real exponent that is an integer.
  const Jd a = Jd::variable(-2.0);
  for (const Jd& r : {pow(a, 3), pow(a, 3.0), pow(a, Jd(3.0))}) {
    const double want[] = {-8, 12, -6, 1};
    for (int k = 0; k < N; ++k) EXPECT_EQ(r[k], k < 4 ? want[k] : 0.0);
  }
  EXPECT_EQ(pow(a, 0)[0], 1.0);
  EXPECT_TRUE(pow(a, 0).is_constant());
}

// A general series (all coefficients nonzero) with value g0: the identities below exercise the
// recurrences on arguments whose higher coefficients interact.
template <class T, int M> eom::Jet<T, M> general_series(double g0) {
  T coefficients[M];
  for (int k = 0; k < M; ++k) coefficients[k] = k == 0 ? T(g0) : T(0.3) / T(k * k + 1) * T(k % 3 == 1 ? -1 : 1);
  return eom::Jet<T, M>::truncated(coefficients, M);
}

template <class T> double epsilon_of() {
  return static_cast<double>(std::numeric_limits<T>::epsilon());
}

template <class T> double max_diff(const eom::Jet<T, N>& a, const eom::Jet<T, N>& b) {
  double m = 0;
  for (int k = 0; k < N; ++k) m = std::max(m, eom::as_double(abs(a.c[k] - b.c[k])));
  return m;
}

template <class T> class JetIdentities : public ::testing::Test {};
using RealTypes = ::testing::Types<double, long double, dd_real>;
TYPED_TEST_SUITE(JetIdentities, RealTypes);

TYPED_TEST(JetIdentities, InverseFunctionsAndIdentitiesHoldToRoundOff) {
  using T = TypeParam;
  using J = eom::Jet<T, N>;
  const double tol = 256 * epsilon_of<T>();
  const J g = general_series<T, N>(0.4), h = general_series<T, N>(-1.3);
  const J one(T(1));
  EXPECT_LT(max_diff(sin(g) * sin(g) + cos(g) * cos(g), one), tol);
  EXPECT_LT(max_diff(exp(log(g + 1.0)), g + 1.0), tol);
  EXPECT_LT(max_diff(log(exp(g)), g), tol);
  EXPECT_LT(max_diff(sqrt(g + 2.0) * sqrt(g + 2.0), g + 2.0), tol);
  EXPECT_LT(max_diff((g / h) * h, g), tol);
  EXPECT_LT(max_diff(tan(atan(h)), h), tol);
  EXPECT_LT(max_diff(atan(tan(g)), g), tol);
  EXPECT_LT(max_diff(sin(asin(g)), g), tol);
  EXPECT_LT(max_diff(cos(acos(g)), g), tol);
  using std::acos;
  EXPECT_LT(max_diff(asin(g) + acos(g), J(acos(T(0)))), tol);  // π/2 in T
  EXPECT_LT(max_diff(tan(g) * cos(g), sin(g)), tol);
  EXPECT_LT(max_diff(pow(g + 2.0, h), exp(h * log(g + 2.0))), tol);
  EXPECT_LT(max_diff(pow(g + 2.0, T(0.37)) * pow(g + 2.0, T(0.63)), g + 2.0), tol);
  EXPECT_LT(max_diff(hypot(T(3) * h, T(4) * h), T(5) * abs(h)), tol);
  // atan2 in all four quadrants: atan2(r sin φ, r cos φ) = φ for φ in (−π, π).
  const J r = g + 1.5;
  for (double phi0 : {0.3, 2.5, -2.8, -0.9}) {
    const J phi = general_series<T, N>(phi0);
    EXPECT_LT(max_diff(atan2(r * sin(phi), r * cos(phi)), phi), tol) << phi0;
    EXPECT_LT(max_diff(hypot(r * cos(phi), r * sin(phi)), r), tol) << phi0;
  }
}

TEST(Jet, KnownLengthIsTheLeastKnownArgumentAndConstantsCostOneCoefficient) {
  const double a[] = {1.0, 2.0, 3.0, 4.0};
  const Jd x = Jd::truncated(a, 4), y = Jd::truncated(a, 2), c(5.0);
  EXPECT_TRUE(c.is_constant());
  EXPECT_EQ(c.size(), N);
  EXPECT_EQ((x * y).n, 2);
  EXPECT_EQ((x + c).n, 4);
  EXPECT_EQ((c * x / c).n, 4);
  EXPECT_TRUE((c * c + exp(c) / sin(c)).is_constant());
  // A constant's higher coefficients are exact zeros: reading them is valid.
  const Jd cc = sqrt(c) * c;
  for (int k = 1; k < N; ++k) EXPECT_EQ(cc[k], 0.0);
  // (1 + 2τ + 3τ² + 4τ³)²: known to order 3 only, and exact there.
  const Jd sq = x * x;
  EXPECT_EQ(sq.n, 4);
  EXPECT_EQ(sq[0], 1.0);
  EXPECT_EQ(sq[1], 4.0);
  EXPECT_EQ(sq[2], 10.0);
  EXPECT_EQ(sq[3], 20.0);
}

TEST(Jet, ComparisonsSelectAndFinitenessLookAtTheRightCoefficients) {
  const double a[] = {1.0, -100.0}, b[] = {2.0, 100.0};
  const Jd x = Jd::truncated(a, 2), y = Jd::truncated(b, 2);
  EXPECT_TRUE(x < y);
  EXPECT_TRUE(x < 1.5 && 0.5 < x && x != 2.0 && x == 1.0);
  EXPECT_EQ(eom::select(x < y, x, y)[1], -100.0);
  EXPECT_EQ(abs(-x)[1], -100.0);  // |−x| = x near x0 = 1
  EXPECT_EQ(eom::as_double(y), 2.0);
  EXPECT_TRUE(eom::isfinite(x));
  double inf[] = {1.0, std::numeric_limits<double>::infinity()};
  EXPECT_FALSE(eom::isfinite(Jd::truncated(inf, 2)));
  // The coefficient beyond a truncated jet's length is not looked at.
  EXPECT_TRUE(eom::isfinite(Jd::truncated(inf, 1)));
}

// Nested: Embedded over (x, y) whose values are Jets in τ, as the reference's dynamics use it.
// f = sin(x y) with x = x0 + τ, y = y0: ∂f/∂x = y cos(xy), ∂²f/∂x∂y = cos(xy) − xy sin(xy),
// each a function of τ whose coefficients are y-scaled derivatives of cos and sin at x0 y0.
TEST(Jet, NestsInsideEmbedded) {
  constexpr int M = 8;
  using J = eom::Jet<double, M>;
  using A = eom::Embedded<2, J, 2>;
  const double x0 = 0.6, y0 = 1.7, u0 = x0 * y0, half_pi = std::numbers::pi / 2;
  const A x = A::variable(J::variable(x0), 0), y = A::variable(J(y0), 1);
  const A f = sin(x * y);
  for (int k = 0; k < M; ++k) {
    // d^k/dτ^k g(y0 (x0 + τ)) / k! = y0^k g⁽ᵏ⁾(u0)/k!
    const double yk = std::pow(y0, k) / factorial(k);
    const double sin_k = std::sin(u0 + k * half_pi) * yk, cos_k = std::cos(u0 + k * half_pi) * yk;
    const double sin_k1 = k ? std::sin(u0 + (k - 1) * half_pi) * std::pow(y0, k - 1) / factorial(k - 1) : 0;
    const double tol = 1e-13;
    EXPECT_NEAR(f.v[k], sin_k, tol) << k;
    EXPECT_NEAR(f.gradient(0)[k], y0 * cos_k, tol) << k;
    // x y sin(xy) = (u0 + y0 τ) sin(y0 (x0 + τ)): coefficient k = u0 sin_k + y0 sin_{k−1}
    EXPECT_NEAR(f.hessian(0, 1)[k], cos_k - (u0 * sin_k + y0 * sin_k1), tol) << k;
    EXPECT_NEAR(f.hessian(0, 0)[k], -y0 * y0 * sin_k, tol) << k;
  }
  // Embedded's constant-exponent pow and sqrt on jets: x^2.5 = exp(2.5 log x), x^2.0 = x·x.
  using A1 = eom::Embedded<1, J, 2>;
  const A1 z = A1::variable(J::variable(1.3), 0);
  const A1 p25 = pow(z, 2.5), e25 = exp(2.5 * log(z)), p2 = pow(z, 2.0), zz = z * z;
  const A1 s = sqrt(z) * sqrt(z);
  for (int k = 0; k < M; ++k) {
    EXPECT_NEAR(p25.v[k], e25.v[k], 1e-14) << k;
    EXPECT_NEAR(p25.hessian(0, 0)[k], e25.hessian(0, 0)[k], 1e-14) << k;
    EXPECT_NEAR(p2.gradient(0)[k], zz.gradient(0)[k], 1e-14) << k;
    EXPECT_NEAR(s.hessian(0, 0)[k], 0.0, 1e-14) << k;
    EXPECT_NEAR(s.gradient(0)[k], k == 0 ? 1.0 : 0.0, 1e-14) << k;
  }
  // The wide type nests too.
  using Jw = eom::Jet<dd_real, 4>;
  using Aw = eom::Embedded<1, Jw, 2>;
  const Aw w = exp(Aw::variable(Jw::variable(dd_real(0.5)), 0) * 2.0);
  EXPECT_NEAR(eom::as_double(w.hessian(0, 0)[1]), 8 * std::exp(1.0), 1e-14);
}

}  // namespace
