// eom::Embedded: layout, compound assignment, comparisons, eom::select, integer and real
// powers at special bases (negative, zero), constant bases for every scalar type, nesting
// against a closed form. Exact results are compared exactly; others with the normwise relative
// error of ad_test_support.hpp.
#include "ad_test_support.hpp"

#include <eom/model/model.hpp>

#include <limits>
#include <numbers>

namespace {

using adtest::Jet;
using E1 = eom::Embedded<1, double, 2>;
using E3 = eom::Embedded<3, double, 2>;
using D = eom::Embedded<1, double, 1>;
using Nested1 = eom::Embedded<1, D, 2>;
using Nested3 = eom::Embedded<3, D, 2>;

// ---- layout -----------------------------------------------------------------------------------
static_assert(sizeof(E3) == sizeof(double) * (1 + 3 + 6), "value, gradient, packed Hessian only");
static_assert(std::is_trivially_copyable_v<E3>);
static_assert(std::is_trivially_copyable_v<eom::Embedded<3, double, 1>>);
static_assert(std::is_trivially_copyable_v<Nested3>);
static_assert(std::is_trivially_copyable_v<eom::Embedded<4, long double, 2>>);
static_assert(sizeof(eom::Embedded<3, double, 1>) < sizeof(E3), "order 1 stores no Hessian");
static_assert(sizeof(Nested3) == sizeof(D) * (1 + 3 + 6));
static_assert(E3::hessian_size == 6 && eom::Embedded<3, double, 1>::hessian_size == 0);

// The rules are constexpr: a product evaluated at compile time.
constexpr E3 kProduct = E3::variable(2.0, 0) * E3::variable(3.0, 1) * 2 + 1.0;
static_assert(kProduct.v == 13.0 && kProduct.g[0] == 6.0 && kProduct.g[1] == 4.0 &&
              kProduct.g[2] == 0.0);
static_assert(kProduct.hessian(1, 0) == 2.0 && kProduct.hessian(0, 1) == 2.0 &&
              kProduct.hessian(0, 0) == 0.0 && kProduct.hessian(2, 1) == 0.0);

TEST(Layout, HessianAccessorIsSymmetricAndPacked) {
  // f = x·y·z + x² + 3y·z² has every Hessian entry distinct where nonzero
  const double x0 = 1.5, y0 = -2.0, z0 = 0.5;
  const E3 x = E3::variable(x0, 0), y = E3::variable(y0, 1), z = E3::variable(z0, 2);
  const E3 f = x * y * z + x * x + 3.0 * y * z * z;
  const double H[3][3] = {{2.0, z0, y0}, {z0, 0.0, x0 + 6.0 * z0}, {y0, x0 + 6.0 * z0, 6.0 * y0}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      EXPECT_EQ(f.hessian(i, j), H[i][j]) << i << ", " << j;
      EXPECT_EQ(&f.hessian(i, j), &f.hessian(j, i));
    }
  // row-by-row lower triangle
  EXPECT_EQ(f.h[0], H[0][0]);
  EXPECT_EQ(f.h[1], H[1][0]);
  EXPECT_EQ(f.h[2], H[1][1]);
  EXPECT_EQ(f.h[3], H[2][0]);
  EXPECT_EQ(f.h[4], H[2][1]);
  EXPECT_EQ(f.h[5], H[2][2]);
}

// ---- compound assignment ----------------------------------------------------------------------
E3 inner(double x0, double y0, double z0) {
  const E3 x = E3::variable(x0, 0), y = E3::variable(y0, 1), z = E3::variable(z0, 2);
  return sin(x * y) + z * z * x;
}
Jet<3> inner_jet(double x, double y, double z) {
  Jet<3> j;
  const double s = std::sin(x * y), c = std::cos(x * y);
  j.v = s + z * z * x;
  j.g = {y * c + z * z, x * c, 2.0 * z * x};
  j.H = {{{-y * y * s, c - x * y * s, 2.0 * z},
          {c - x * y * s, -x * x * s, 0.0},
          {2.0 * z, 0.0, 2.0 * x}}};
  return j;
}

TEST(CompoundAssignment, WithConstants) {
  for (const auto& [x, y, z] : {std::array{0.7, -1.2, 0.4}, std::array{-1.5, 0.3, -2.0}}) {
    E3 s = inner(x, y, z);
    s += 2.5;
    s -= 1;
    s *= 3;
    s *= 0.5;
    s /= 4;
    s /= 1.25;
    s += 1;
    s -= 0.5;
    const Jet<3> a = inner_jet(x, y, z);
    adtest::expect_jet_near(adtest::to_jet(s), adtest::compose(a, (a.v + 1.5) * 0.3 + 0.5, 0.3, 0.0),
                            1e-15, "compound assignment", "with constants");
  }
}

TEST(CompoundAssignment, AliasedOperand) {
  const Jet<3> a = inner_jet(0.7, -1.2, 0.4);
  E3 s = inner(0.7, -1.2, 0.4);
  s *= s;  // a²
  adtest::expect_jet_near(adtest::to_jet(s), adtest::compose(a, a.v * a.v, 2.0 * a.v, 2.0), 1e-15,
                          "compound assignment", "s *= s");
  s = inner(0.7, -1.2, 0.4);
  s += s;  // 2a
  adtest::expect_jet_near(adtest::to_jet(s), adtest::compose(a, 2.0 * a.v, 2.0, 0.0), 1e-15,
                          "compound assignment", "s += s");
  s = inner(0.7, -1.2, 0.4);
  s -= s;  // exactly 0
  EXPECT_EQ(adtest::to_jet(s).v, 0.0);
  EXPECT_EQ(adtest::to_jet(s).g, (std::array<double, 3>{}));
  EXPECT_EQ(adtest::to_jet(s).H, (Jet<3>{}.H));
  s = inner(0.7, -1.2, 0.4);
  s /= s;  // 1, derivatives 0 up to rounding
  adtest::expect_jet_near(adtest::to_jet(s), adtest::compose(a, 1.0, 0.0, 0.0), 1e-15,
                          "compound assignment", "s /= s");
}

// ---- comparisons and select -------------------------------------------------------------------
TEST(Comparison, LooksAtValuesOnly) {
  const E3 x = E3::variable(1.5, 0), y = E3::variable(1.5, 1), z = E3::variable(-2.0, 2);
  // equal values, different derivatives
  EXPECT_TRUE(x == y);
  EXPECT_FALSE(x != y);
  EXPECT_FALSE(x < y);
  EXPECT_FALSE(x > y);
  EXPECT_TRUE(x <= y);
  EXPECT_TRUE(x >= y);
  EXPECT_TRUE(z < x);
  EXPECT_TRUE(x > z);
  EXPECT_TRUE(z != x);
  EXPECT_FALSE(z >= x);
  // constants, double and int, on both sides
  EXPECT_TRUE(x == 1.5);
  EXPECT_TRUE(1.5 == x);
  EXPECT_FALSE(x != 1.5);
  EXPECT_FALSE(1.5 != x);
  EXPECT_TRUE(x != 1);
  EXPECT_TRUE(x > 1);
  EXPECT_TRUE(1 < x);
  EXPECT_TRUE(x < 2.0);
  EXPECT_TRUE(2.0 > x);
  EXPECT_TRUE(x <= 1.5);
  EXPECT_TRUE(x >= 1.5);
  EXPECT_TRUE(1.5 <= x);
  EXPECT_TRUE(1.5 >= x);
  EXPECT_FALSE(x < 1.5);
  EXPECT_FALSE(x > 1.5);
  EXPECT_TRUE(z < 0);
  EXPECT_TRUE(0 > z);
  EXPECT_FALSE(z >= 0);
  EXPECT_TRUE(-2 == z);
  EXPECT_TRUE(z <= -2);
  EXPECT_FALSE(z < -2);
  // nested numbers compare their bottom values
  Nested1 n = Nested1::variable(D(0.25), 0);
  n.v.g[0] = 7.0;
  EXPECT_TRUE(n == 0.25);
  EXPECT_TRUE(n < 1);
  EXPECT_TRUE(0.0 < n);
  EXPECT_FALSE(n > Nested1(0.25));
}

TEST(Select, BoolConditionTakesOneBranchWithItsDerivatives) {
  for (const auto& [x0, y0, z0] : {std::array{1.2, 0.4, -0.7}, std::array{-0.3, 0.9, 1.1}}) {
    const E3 x = E3::variable(x0, 0), y = E3::variable(y0, 1), z = E3::variable(z0, 2);
    const E3 a = x * x * y, b = sin(y) * z;
    const E3 r = eom::select(x > y, a, b);
    const E3& want = x0 > y0 ? a : b;
    EXPECT_EQ(r.v, want.v);
    EXPECT_EQ(r.g, want.g);
    EXPECT_EQ(r.h, want.h);
    const E3 r2 = eom::select(x0 > y0, b, a);  // a plain bool works too
    const E3& want2 = x0 > y0 ? b : a;
    EXPECT_EQ(r2.g, want2.g);
    EXPECT_EQ(r2.h, want2.h);
  }
  // piecewise |x| through select matches abs
  for (double x0 : {-1.7, 0.6}) {
    const E1 x = E1::variable(x0, 0);
    const E1 s = eom::select(x < 0.0, -x, x), a = abs(x);
    EXPECT_EQ(s.v, a.v);
    EXPECT_EQ(s.g, a.g);
    EXPECT_EQ(s.h, a.h);
  }
}

TEST(Abs, AtZeroUsesPlusOne) {  // documented in ad.hpp
  const E1 a = abs(E1::variable(0.0, 0));
  EXPECT_EQ(a.v, 0.0);
  EXPECT_EQ(a.g[0], 1.0);
  EXPECT_EQ(a.h[0], 0.0);
}

// ---- powers at special bases ------------------------------------------------------------------
void expect_exact(const E1& r, double v, double g, double h, const std::string& what) {
  EXPECT_EQ(r.v, v) << what;
  EXPECT_EQ(r.g[0], g) << what;
  EXPECT_EQ(r.h[0], h) << what;
}

TEST(Pow, IntegerExponentsAtZero) {
  const E1 x = E1::variable(0.0, 0);
  expect_exact(pow(x, 0), 1.0, 0.0, 0.0, "0^0");
  expect_exact(pow(x, 1), 0.0, 1.0, 0.0, "0^1");
  expect_exact(pow(x, 2), 0.0, 0.0, 2.0, "0^2");
  expect_exact(pow(x, 3), 0.0, 0.0, 0.0, "0^3");
  expect_exact(pow(x, 4), 0.0, 0.0, 0.0, "0^4");
}

TEST(Pow, IntegerExponentsExactOnSmallIntegers) {
  // at integer bases every term is an exactly representable integer (or power of two)
  for (double b : {-3.0, -2.0, -1.0, 1.0, 2.0, 3.0}) {
    const E1 x = E1::variable(b, 0);
    expect_exact(pow(x, 0), 1.0, 0.0, 0.0, "n = 0");
    expect_exact(pow(x, 1), b, 1.0, 0.0, "n = 1");
    expect_exact(pow(x, 2), b * b, 2.0 * b, 2.0, "n = 2");
    expect_exact(pow(x, 3), b * b * b, 3.0 * b * b, 6.0 * b, "n = 3");
  }
  for (double b : {-4.0, -2.0, -0.5, 0.5, 2.0, 4.0}) {  // powers of two: reciprocals exact
    const E1 x = E1::variable(b, 0);
    expect_exact(pow(x, -1), 1.0 / b, -1.0 / (b * b), 2.0 / (b * b * b), "n = -1");
    expect_exact(pow(x, -2), 1.0 / (b * b), -2.0 / (b * b * b), 6.0 / (b * b * b * b), "n = -2");
  }
}

TEST(Pow, IntegerExponentsAgreeWithProducts) {
  for (double b : {-1.7, -0.3, 0.45, 2.2}) {
    const E3 x = inner(b, 0.8, -0.6);
    const std::string at = "base " + std::to_string(b);
    auto near = [&](const E3& r, const E3& e, const std::string& what) {
      adtest::expect_jet_near(adtest::to_jet(r), adtest::to_jet(e), 1e-14,
                              "integer pow vs products", what + ", " + at);
    };
    near(pow(x, 2), x * x, "n = 2");
    near(pow(x, 3), x * x * x, "n = 3");
    near(pow(x, 5), x * x * x * x * x, "n = 5");
    near(pow(x, -1), 1.0 / x, "n = -1");
    near(pow(x, -2), 1.0 / (x * x), "n = -2");
    near(pow(x, -3), 1.0 / (x * x * x), "n = -3");
    near(pow(x, 3.0), x * x * x, "real n = 3.0 at a negative base");
    near(pow(x, -2.0), 1.0 / (x * x), "real n = -2.0 at a negative base");
  }
}

// Real exponents at a zero base: the values are std::pow's, and the derivatives of the constant
// (r = 0) and linear (r = 1) powers are exact, not 0·inf = NaN.
TEST(Pow, RealExponentsAtZero) {
  const E1 x = E1::variable(0.0, 0);
  const double inf = std::numeric_limits<double>::infinity();
  expect_exact(pow(x, 0.0), 1.0, 0.0, 0.0, "0^0.0");
  expect_exact(pow(x, 1.0), 0.0, 1.0, 0.0, "0^1.0");
  expect_exact(pow(x, 2.0), 0.0, 0.0, 2.0, "0^2.0");
  expect_exact(pow(x, 3.0), 0.0, 0.0, 0.0, "0^3.0");
  expect_exact(pow(x, 2.5), 0.0, 0.0, 0.0, "0^2.5");
  expect_exact(pow(x, 1.5), 0.0, 0.0, inf, "0^1.5");  // (x^1.5)'' = 0.75/sqrt(x)
  const E1 s = pow(x, 0.5);                           // the square root: value 0, slope inf
  EXPECT_EQ(s.v, 0.0);
  EXPECT_EQ(s.g[0], inf);
  // inside a larger expression the exact zero derivatives keep the Hessian finite
  const E1 y = E1::variable(0.0, 0);
  const E1 f = pow(y, 1.0) * 3.0 + pow(y, 0.0) * y;  // 3y + y
  expect_exact(f, 0.0, 4.0, 0.0, "3·y^1.0 + y^0.0·y at 0");
}

// A nested number takes a real exponent as a constant at every level: defined at zero and at
// negative bases for an integer-valued exponent (mass-matrix rates of models using pow(v, 2.0)).
TEST(Pow, NestedRealExponentAtZeroAndNegativeBases) {
  for (double b : {-1.5, 0.0, 1.5}) {
    D inner(b);
    inner.g[0] = 1.0;  // d/dt along direction 1
    const Nested1 x = Nested1::variable(inner, 0);
    const Nested1 p = pow(x, 2.0);
    const std::string at = "base " + std::to_string(b);
    EXPECT_EQ(p.v.v, b * b) << at;
    EXPECT_EQ(p.v.g[0], 2.0 * b) << at;
    EXPECT_EQ(p.g[0].v, 2.0 * b) << at;
    EXPECT_EQ(p.g[0].g[0], 2.0) << at;
    EXPECT_EQ(p.h[0].v, 2.0) << at;
    EXPECT_EQ(p.h[0].g[0], 0.0) << at;
    const Nested1 c = pow(x, 3.0);
    EXPECT_EQ(c.v.v, b * b * b) << at;
    EXPECT_EQ(c.v.g[0], 3.0 * b * b) << at;
    EXPECT_EQ(c.g[0].g[0], 6.0 * b) << at;
    EXPECT_EQ(c.h[0].v, 6.0 * b) << at;
    EXPECT_EQ(c.h[0].g[0], 6.0) << at;
  }
}

// c^x with a double or int base for every scalar type (plain, long double, dd_real, nested).
TEST(Pow, ConstantBaseForEveryScalarType) {
  const double x0 = -0.8, ln2 = std::numbers::ln2;
  const double f = std::exp2(x0);
  {
    const E1 x = E1::variable(x0, 0);
    for (const E1& r : {pow(2.0, x), pow(2, x)}) {
      EXPECT_NEAR(r.v, f, 1e-16);
      EXPECT_NEAR(r.g[0], f * ln2, 1e-16);
      EXPECT_NEAR(r.h[0], f * ln2 * ln2, 1e-16);
    }
  }
  {
    using L = eom::Embedded<1, long double, 2>;
    const L x = L::variable(x0, 0);
    const long double lf = std::exp2(static_cast<long double>(x0)), lln2 = std::log(2.0L);
    for (const L& r : {pow(2.0, x), pow(2, x), pow(2.0L, x)}) {
      EXPECT_NEAR(static_cast<double>((r.v - lf) / lf), 0.0, 1e-18);
      EXPECT_NEAR(static_cast<double>((r.h[0] - lf * lln2 * lln2) / lf), 0.0, 1e-18);
    }
  }
  {
    using Q = eom::Embedded<1, dd_real, 2>;
    const Q x = Q::variable(dd_real(x0), 0);
    const dd_real l2 = log(dd_real(2.0)), qf = exp(dd_real(x0) * l2);
    for (const Q& r : {pow(2.0, x), pow(2, x), pow(dd_real(2.0), x)}) {
      EXPECT_LT(to_double(abs(r.v - qf) / qf), 1e-30);
      EXPECT_LT(to_double(abs(r.g[0] - qf * l2) / qf), 1e-30);
      EXPECT_LT(to_double(abs(r.h[0] - qf * l2 * l2) / qf), 1e-30);
    }
  }
  {
    D inner(x0);
    inner.g[0] = 0.5;
    const Nested1 x = Nested1::variable(inner, 0);
    for (const Nested1& r : {pow(2.0, x), pow(2, x)}) {
      EXPECT_NEAR(r.v.v, f, 1e-16);
      EXPECT_NEAR(r.v.g[0], 0.5 * f * ln2, 1e-16);
      EXPECT_NEAR(r.g[0].v, f * ln2, 1e-16);
      EXPECT_NEAR(r.h[0].g[0], 0.5 * f * ln2 * ln2 * ln2, 1e-16);
    }
  }
}

// Mixed arithmetic with int and double constants works unchanged on nested and dd_real numbers.
TEST(MixedConstants, NestedAndDdReal) {
  D inner(0.7);
  inner.g[0] = 1.0;
  const Nested1 x = Nested1::variable(inner, 0);
  const Nested1 a = 2 * x + x * 3 - 1 / x + x / 4 - (5 - x) + (x - 6) + (7 + x) * 0.5;
  const Nested1 b = 2.0 * x + x * 3.0 - 1.0 / x + x / 4.0 - (5.0 - x) + (x - 6.0) + (7.0 + x) * 0.5;
  EXPECT_EQ(a.v.v, b.v.v);
  EXPECT_EQ(a.v.g[0], b.v.g[0]);
  EXPECT_EQ(a.g[0].g[0], b.g[0].g[0]);
  EXPECT_EQ(a.h[0].g[0], b.h[0].g[0]);
  // (1/x)''' = -6/x⁴ is the only third derivative: directional derivative of the Hessian
  EXPECT_NEAR(a.h[0].g[0], 6.0 / std::pow(0.7, 4), 1e-13);

  using Q = eom::Embedded<1, dd_real, 2>;
  const Q q = Q::variable(dd_real(0.7), 0);
  const Q c = 2 * q + q * 3.0 - 1 / q + q / 4;
  const dd_real v = dd_real(0.7);
  EXPECT_LT(to_double(abs(c.v - (dd_real(5.25) * v - dd_real(1.0) / v))), 1e-30);
  EXPECT_LT(to_double(abs(c.h[0] + dd_real(2.0) / (v * v * v))), 1e-29);
  EXPECT_DOUBLE_EQ(eom::as_double(c), 5.25 * 0.7 - 1.0 / 0.7);
  EXPECT_EQ(eom::as_double(x), 0.7);
}

// ---- nesting against a closed form: f = x²·y·e^z ---------------------------------------------
TEST(Nested, DirectionalDerivativeOfHessianClosedForm) {
  const double x = 0.8, y = -1.3, z = 0.4;
  const std::array<double, 3> d{0.6, -0.25, 1.1};
  std::array<Nested3, 3> v;
  for (int i = 0; i < 3; ++i) {
    D inner(std::array{x, y, z}[i]);
    inner.g[0] = d[i];
    v[i] = Nested3::variable(inner, i);
  }
  const Nested3 f = v[0] * v[0] * v[1] * exp(v[2]);
  const double e = std::exp(z);
  // Hessian and the gradients of its entries
  const double H[3][3] = {{2 * y * e, 2 * x * e, 2 * x * y * e},
                          {2 * x * e, 0.0, x * x * e},
                          {2 * x * y * e, x * x * e, x * x * y * e}};
  const double dH[3][3][3] = {
      {{0.0, 2 * e, 2 * y * e}, {2 * e, 0.0, 2 * x * e}, {2 * y * e, 2 * x * e, 2 * x * y * e}},
      {{2 * e, 0.0, 2 * x * e}, {0.0, 0.0, 0.0}, {2 * x * e, 0.0, x * x * e}},
      {{2 * y * e, 2 * x * e, 2 * x * y * e},
       {2 * x * e, 0.0, x * x * e},
       {2 * x * y * e, x * x * e, x * x * y * e}}};
  const double g[3] = {2 * x * y * e, x * x * e, x * x * y * e};
  Jet<3> want_base, want_dir, got_base, got_dir;
  want_base.v = x * x * y * e;
  for (int i = 0; i < 3; ++i) {
    want_base.g[i] = g[i];
    want_dir.v += g[i] * d[i];
    for (int k = 0; k < 3; ++k) {
      want_base.H[i][k] = H[i][k];
      want_dir.g[i] += H[i][k] * d[k];
      for (int m = 0; m < 3; ++m) want_dir.H[i][k] += dH[i][k][m] * d[m];
    }
  }
  got_base = adtest::to_jet(f);
  got_dir.v = f.v.g[0];
  for (int i = 0; i < 3; ++i) {
    got_dir.g[i] = f.g[i].g[0];
    for (int k = 0; k < 3; ++k) got_dir.H[i][k] = f.hessian(i, k).g[0];
  }
  adtest::expect_jet_near(got_base, want_base, 1e-15, "nested closed form", "x^2 y e^z, base");
  adtest::expect_jet_near(got_dir, want_dir, 1e-14, "nested closed form",
                          "x^2 y e^z, directional");
}

// ---- the worst errors of the run --------------------------------------------------------------
class PrintWorstErrors : public ::testing::Environment {
 public:
  void TearDown() override { adtest::WorstErrors::print(); }
};
[[maybe_unused]] const auto* const kPrinter =
    ::testing::AddGlobalTestEnvironment(new PrintWorstErrors);

}  // namespace
