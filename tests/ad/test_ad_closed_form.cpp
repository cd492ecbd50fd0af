// Every elementary rule of eom::Embedded<3, double, 2> against hand-derived closed forms.
//
// Each rule f is applied to nontrivial inner functions of three independent variables
//   a(x, y, z) = x·exp(0.2y) + y·sin z,     b(x, y, z) = y·exp(0.3z) − z²,
// whose value, gradient and Hessian are written out below, so the expected result is the chain
// rule  (f, f'∇a, f'∇²a + f''∇a∇aᵀ)  (two-argument form for f(a, b)) with f, f', f'' (and the
// partials of f(a, b)) hand-derived, in forms independent of ad.hpp's where one exists (e.g.
// tan' = 1/cos², asin'' = u/(1−u²)^1.5). Points are constructed so that (a, b) hits chosen
// targets (negative arguments, all four atan2 quadrants, ...), each with two different inner
// gradients. Tolerance: 1e-14 normwise relative (see ad_test_support.hpp), value, gradient and
// Hessian separately.
#include "ad_test_support.hpp"

#include <functional>
#include <numbers>
#include <vector>

namespace {

using adtest::Jet;
using E3 = eom::Embedded<3, double, 2>;
using P3 = std::array<double, 3>;

constexpr double kTol = 1e-14;
const std::string kGroup = "closed form, Embedded<3,double,2>";

template <class S>
S inner_a(const S& x, const S& y, const S& z) {
  using std::exp, std::sin;
  return x * exp(0.2 * y) + y * sin(z);
}
template <class S>
S inner_b(const S& x, const S& y, const S& z) {
  using std::exp;
  (void)x;
  return y * exp(0.3 * z) - z * z;
}

Jet<3> jet_a(const P3& p) {
  const double x = p[0], y = p[1], z = p[2];
  const double e = std::exp(0.2 * y), s = std::sin(z), c = std::cos(z);
  Jet<3> j;
  j.v = x * e + y * s;
  j.g = {e, 0.2 * x * e + s, y * c};
  j.H = {{{0.0, 0.2 * e, 0.0}, {0.2 * e, 0.04 * x * e, c}, {0.0, c, -y * s}}};
  return j;
}
Jet<3> jet_b(const P3& p) {
  const double y = p[1], z = p[2];
  const double e = std::exp(0.3 * z);
  Jet<3> j;
  j.v = y * e - z * z;
  j.g = {0.0, e, 0.3 * y * e - 2.0 * z};
  j.H = {{{0.0, 0.0, 0.0}, {0.0, 0.0, 0.3 * e}, {0.0, 0.3 * e, 0.09 * y * e - 2.0}}};
  return j;
}

// The point with a = a_target and b = b_target at the given z.
P3 point_for(double a_target, double b_target, double z) {
  const double y = (b_target + z * z) / std::exp(0.3 * z);
  const double x = (a_target - y * std::sin(z)) / std::exp(0.2 * y);
  return {x, y, z};
}

std::array<E3, 3> vars(const P3& p) { return adtest::variables<E3>(p); }

// x^n by plain repeated multiplication (ad.hpp uses repeated squaring).
double power(double x, int n) {
  double r = 1.0;
  for (int k = 0; k < (n < 0 ? -n : n); ++k) r *= x;
  return n < 0 ? 1.0 / r : r;
}

// ---- one-argument rules -------------------------------------------------------------------
struct UnaryCase {
  std::string name;
  std::function<E3(const E3&)> ad;
  std::function<std::array<double, 3>(double)> closed;  // f, f', f'' at u
  std::vector<double> targets;                          // values of the argument u = a
};

const std::vector<double> kAny{-2.6, -1.7, -0.35, 0.45, 1.3, 3.1};
const std::vector<double> kPositive{0.03, 0.4, 1.3, 3.1, 7.5};
const std::vector<double> kNonzero{-2.6, -1.7, -0.35, 0.45, 1.3, 3.1};

std::vector<UnaryCase> unary_cases() {
  using std::array;
  const double ln2 = std::numbers::ln2, ln03 = std::log(0.3), ln3 = std::log(3.0);
  std::vector<UnaryCase> c = {
      {"negate", [](const E3& u) { return -u; }, [](double u) { return array{-u, -1.0, 0.0}; },
       kAny},
      {"unary_plus", [](const E3& u) { return +u; }, [](double u) { return array{u, 1.0, 0.0}; },
       kAny},
      {"sin", [](const E3& u) { return sin(u); },
       [](double u) { return array{std::sin(u), std::cos(u), -std::sin(u)}; }, kAny},
      {"cos", [](const E3& u) { return cos(u); },
       [](double u) { return array{std::cos(u), -std::sin(u), -std::cos(u)}; }, kAny},
      {"tan", [](const E3& u) { return tan(u); },
       [](double u) {
         const double co = std::cos(u);
         return array{std::tan(u), 1.0 / (co * co), 2.0 * std::sin(u) / (co * co * co)};
       },
       {-1.3, -0.7, 0.2, 0.9, 1.35}},
      {"tanh", [](const E3& u) { return tanh(u); },
       [](double u) {
         const double ch = std::cosh(u);
         return array{std::tanh(u), 1.0 / (ch * ch), -2.0 * std::sinh(u) / (ch * ch * ch)};
       },
       kAny},
      {"asin", [](const E3& u) { return asin(u); },
       [](double u) {
         const double w = 1.0 - u * u;
         return array{std::asin(u), 1.0 / std::sqrt(w), u / std::pow(w, 1.5)};
       },
       {-0.93, -0.4, 0.15, 0.6, 0.88}},
      {"acos", [](const E3& u) { return acos(u); },
       [](double u) {
         const double w = 1.0 - u * u;
         return array{std::acos(u), -1.0 / std::sqrt(w), -u / std::pow(w, 1.5)};
       },
       {-0.93, -0.4, 0.15, 0.6, 0.88}},
      {"atan", [](const E3& u) { return atan(u); },
       [](double u) {
         const double w = 1.0 + u * u;
         return array{std::atan(u), 1.0 / w, -2.0 * u / (w * w)};
       },
       kAny},
      {"exp", [](const E3& u) { return exp(u); },
       [](double u) { return array{std::exp(u), std::exp(u), std::exp(u)}; }, kAny},
      {"log", [](const E3& u) { return log(u); },
       [](double u) { return array{std::log(u), 1.0 / u, -1.0 / (u * u)}; }, kPositive},
      {"sqrt", [](const E3& u) { return sqrt(u); },
       [](double u) {
         const double s = std::sqrt(u);
         return array{s, 0.5 / s, -0.25 / (u * s)};
       },
       kPositive},
      {"abs", [](const E3& u) { return abs(u); },
       [](double u) { return array{std::abs(u), u < 0 ? -1.0 : 1.0, 0.0}; }, kNonzero},
      {"fabs", [](const E3& u) { return fabs(u); },
       [](double u) { return array{std::abs(u), u < 0 ? -1.0 : 1.0, 0.0}; }, kNonzero},
      // real exponents
      {"pow_real_2p5", [](const E3& u) { return pow(u, 2.5); },
       [](double u) { return array{std::pow(u, 2.5), 2.5 * std::pow(u, 1.5), 3.75 * std::sqrt(u)}; },
       kPositive},
      {"pow_real_m0p7", [](const E3& u) { return pow(u, -0.7); },
       [](double u) {
         return array{std::pow(u, -0.7), -0.7 * std::pow(u, -1.7), 1.19 * std::pow(u, -2.7)};
       },
       kPositive},
      {"pow_real_0p5", [](const E3& u) { return pow(u, 0.5); },
       [](double u) {
         const double s = std::sqrt(u);
         return array{s, 0.5 / s, -0.25 / (u * s)};
       },
       kPositive},
      {"pow_real_3_negative_base", [](const E3& u) { return pow(u, 3.0); },
       [](double u) { return array{u * u * u, 3.0 * u * u, 6.0 * u}; }, kAny},
      {"pow_real_m2_negative_base", [](const E3& u) { return pow(u, -2.0); },
       [](double u) { return array{1.0 / (u * u), -2.0 / (u * u * u), 6.0 / (u * u * u * u)}; },
       kNonzero},
      {"pow_float_exponent", [](const E3& u) { return pow(u, 2.0f); },
       [](double u) { return array{u * u, 2.0 * u, 2.0}; }, kAny},
      // constant base
      {"pow_double_base_2", [](const E3& u) { return pow(2.0, u); },
       [ln2](double u) {
         const double f = std::exp2(u);
         return array{f, f * ln2, f * ln2 * ln2};
       },
       kAny},
      {"pow_double_base_0p3", [](const E3& u) { return pow(0.3, u); },
       [ln03](double u) {
         const double f = std::exp(u * ln03);
         return array{f, f * ln03, f * ln03 * ln03};
       },
       kAny},
      {"pow_int_base_3", [](const E3& u) { return pow(3, u); },
       [ln3](double u) {
         const double f = std::exp(u * ln3);
         return array{f, f * ln3, f * ln3 * ln3};
       },
       kAny},
      // arithmetic with constants, double and int, on both sides
      {"double_plus", [](const E3& u) { return 2.5 + u; },
       [](double u) { return array{2.5 + u, 1.0, 0.0}; }, kAny},
      {"plus_double", [](const E3& u) { return u + 2.5; },
       [](double u) { return array{u + 2.5, 1.0, 0.0}; }, kAny},
      {"int_plus", [](const E3& u) { return 2 + u; },
       [](double u) { return array{2.0 + u, 1.0, 0.0}; }, kAny},
      {"plus_int", [](const E3& u) { return u + 2; },
       [](double u) { return array{u + 2.0, 1.0, 0.0}; }, kAny},
      {"double_minus", [](const E3& u) { return 2.5 - u; },
       [](double u) { return array{2.5 - u, -1.0, 0.0}; }, kAny},
      {"minus_double", [](const E3& u) { return u - 2.5; },
       [](double u) { return array{u - 2.5, 1.0, 0.0}; }, kAny},
      {"int_minus", [](const E3& u) { return 2 - u; },
       [](double u) { return array{2.0 - u, -1.0, 0.0}; }, kAny},
      {"minus_int", [](const E3& u) { return u - 2; },
       [](double u) { return array{u - 2.0, 1.0, 0.0}; }, kAny},
      {"double_times", [](const E3& u) { return -1.5 * u; },
       [](double u) { return array{-1.5 * u, -1.5, 0.0}; }, kAny},
      {"times_double", [](const E3& u) { return u * -1.5; },
       [](double u) { return array{-1.5 * u, -1.5, 0.0}; }, kAny},
      {"int_times", [](const E3& u) { return 3 * u; },
       [](double u) { return array{3.0 * u, 3.0, 0.0}; }, kAny},
      {"times_int", [](const E3& u) { return u * 3; },
       [](double u) { return array{3.0 * u, 3.0, 0.0}; }, kAny},
      {"double_divided", [](const E3& u) { return 2.5 / u; },
       [](double u) { return array{2.5 / u, -2.5 / (u * u), 5.0 / (u * u * u)}; }, kNonzero},
      {"divided_double", [](const E3& u) { return u / 2.5; },
       [](double u) { return array{u / 2.5, 0.4, 0.0}; }, kAny},
      {"int_divided", [](const E3& u) { return -3 / u; },
       [](double u) { return array{-3.0 / u, 3.0 / (u * u), -6.0 / (u * u * u)}; }, kNonzero},
      {"divided_int", [](const E3& u) { return u / 3; },
       [](double u) { return array{u / 3.0, 1.0 / 3.0, 0.0}; }, kAny},
      // two-argument functions with a constant on one side
      {"hypot_ad_double", [](const E3& u) { return hypot(u, 0.7); },
       [](double u) {
         const double r = std::sqrt(u * u + 0.49);
         return array{r, u / r, 0.49 / (r * r * r)};
       },
       kAny},
      {"hypot_int_ad", [](const E3& u) { return hypot(-2, u); },
       [](double u) {
         const double r = std::sqrt(u * u + 4.0);
         return array{r, u / r, 4.0 / (r * r * r)};
       },
       kAny},
  };
  // atan2 with a constant: all four quadrants (u of both signs against c of both signs)
  for (const auto& [k, label] : {std::pair{0.6, "0p6"}, std::pair{-0.6, "m0p6"},
                                std::pair{2.0, "2"}, std::pair{-1.3, "m1p3"}}) {
    c.push_back({std::string("atan2_ad_") + label, [k](const E3& u) { return atan2(u, k); },
                 [k](double u) {
                   const double w = u * u + k * k;
                   return array{std::atan2(u, k), k / w, -2.0 * u * k / (w * w)};
                 },
                 kAny});
    c.push_back({std::string("atan2_") + label + "_ad", [k](const E3& u) { return atan2(k, u); },
                 [k](double u) {
                   const double w = u * u + k * k;
                   return array{std::atan2(k, u), -k / w, 2.0 * u * k / (w * w)};
                 },
                 kAny});
  }
  c.push_back({"atan2_ad_int", [](const E3& u) { return atan2(u, -1); },
               [](double u) {
                 const double w = u * u + 1.0;
                 return array{std::atan2(u, -1.0), -1.0 / w, 2.0 * u / (w * w)};
               },
               kAny});
  // integer exponents, at negative and positive bases
  for (int n : {0, 1, 2, 3, 4, 5, -1, -2, -3}) {
    char name[32];
    std::snprintf(name, sizeof name, "pow_int_%s%d", n < 0 ? "m" : "", n < 0 ? -n : n);
    c.push_back({name, [n](const E3& u) { return pow(u, n); },
                 [n](double u) {
                   return array{power(u, n), n * power(u, n - 1), n * (n - 1) * power(u, n - 2)};
                 },
                 kNonzero});
  }
  return c;
}

class Unary : public ::testing::TestWithParam<UnaryCase> {};

TEST_P(Unary, MatchesClosedForm) {
  const UnaryCase& c = GetParam();
  for (double u : c.targets)
    for (const auto& [b, z] : {std::pair{0.9, 0.6}, std::pair{-1.4, -0.8}}) {
      const P3 p = point_for(u, b, z);
      const Jet<3> a = jet_a(p);
      ASSERT_NEAR(a.v, u, 1e-12);  // the point construction itself
      const auto [x, y, zz] = vars(p);
      const E3 r = c.ad(inner_a(x, y, zz));
      const auto [f, f1, f2] = c.closed(a.v);
      adtest::expect_jet_near(adtest::to_jet(r), adtest::compose(a, f, f1, f2), kTol, kGroup,
                              c.name + " at a = " + std::to_string(u) + ", point " +
                                  adtest::point_name(p));
    }
}

INSTANTIATE_TEST_SUITE_P(Rules, Unary, ::testing::ValuesIn(unary_cases()),
                         [](const auto& info) { return info.param.name; });

// ---- two-argument rules ---------------------------------------------------------------------
struct BinaryCase {
  std::string name;
  std::function<E3(const E3&, const E3&)> ad;
  std::function<std::array<double, 6>(double, double)> closed;  // f, fa, fb, faa, fab, fbb
  std::vector<std::pair<double, double>> targets;               // (a, b)
};

const std::vector<std::pair<double, double>> kPairs{
    {0.7, 1.3}, {-1.1, 0.6}, {2.0, -0.8}, {-0.4, -1.7}, {3.2, 0.25}};
const std::vector<std::pair<double, double>> kPowPairs{
    {0.6, 1.7}, {1.8, -0.9}, {2.5, 0.4}, {0.3, -2.2}, {4.0, 2.6}};
// atan2(a, b): all four quadrants, and near the branch cut on the negative b axis
const std::vector<std::pair<double, double>> kAtan2Pairs{
    {0.8, 0.5}, {0.6, -1.1}, {-0.9, -0.4}, {-0.7, 1.2}, {-0.3, -2.0}, {0.25, -2.0}, {1.5, 0.05}};

std::vector<BinaryCase> binary_cases() {
  using std::array;
  return {
      {"add", [](const E3& a, const E3& b) { return a + b; },
       [](double a, double b) { return array{a + b, 1.0, 1.0, 0.0, 0.0, 0.0}; }, kPairs},
      {"subtract", [](const E3& a, const E3& b) { return a - b; },
       [](double a, double b) { return array{a - b, 1.0, -1.0, 0.0, 0.0, 0.0}; }, kPairs},
      {"multiply", [](const E3& a, const E3& b) { return a * b; },
       [](double a, double b) { return array{a * b, b, a, 0.0, 1.0, 0.0}; }, kPairs},
      {"divide", [](const E3& a, const E3& b) { return a / b; },
       [](double a, double b) {
         return array{a / b, 1.0 / b, -a / (b * b), 0.0, -1.0 / (b * b), 2.0 * a / (b * b * b)};
       },
       kPairs},
      {"add_assign", [](const E3& a, const E3& b) { E3 s = a; s += b; return s; },
       [](double a, double b) { return array{a + b, 1.0, 1.0, 0.0, 0.0, 0.0}; }, kPairs},
      {"subtract_assign", [](const E3& a, const E3& b) { E3 s = a; s -= b; return s; },
       [](double a, double b) { return array{a - b, 1.0, -1.0, 0.0, 0.0, 0.0}; }, kPairs},
      {"multiply_assign", [](const E3& a, const E3& b) { E3 s = a; s *= b; return s; },
       [](double a, double b) { return array{a * b, b, a, 0.0, 1.0, 0.0}; }, kPairs},
      {"divide_assign", [](const E3& a, const E3& b) { E3 s = a; s /= b; return s; },
       [](double a, double b) {
         return array{a / b, 1.0 / b, -a / (b * b), 0.0, -1.0 / (b * b), 2.0 * a / (b * b * b)};
       },
       kPairs},
      {"pow", [](const E3& a, const E3& b) { return pow(a, b); },
       [](double a, double b) {
         const double f = std::pow(a, b), l = std::log(a);
         return array{f,
                      b * f / a,
                      f * l,
                      b * (b - 1.0) * f / (a * a),
                      f / a * (1.0 + b * l),
                      f * l * l};
       },
       kPowPairs},
      {"atan2", [](const E3& a, const E3& b) { return atan2(a, b); },
       [](double a, double b) {
         // with a = r sin t, b = r cos t: f_a = cos t / r, f_b = −sin t / r, ...
         const double r2 = a * a + b * b, r4 = r2 * r2;
         return array{std::atan2(a, b), b / r2, -a / r2, -2.0 * a * b / r4,
                      (a * a - b * b) / r4, 2.0 * a * b / r4};
       },
       kAtan2Pairs},
      {"hypot", [](const E3& a, const E3& b) { return hypot(a, b); },
       [](double a, double b) {
         const double r = std::hypot(a, b), r3 = r * r * r;
         return array{r, a / r, b / r, b * b / r3, -a * b / r3, a * a / r3};
       },
       kPairs},
  };
}

class Binary : public ::testing::TestWithParam<BinaryCase> {};

TEST_P(Binary, MatchesClosedForm) {
  const BinaryCase& c = GetParam();
  for (const auto& [at, bt] : c.targets)
    for (double z : {0.6, -0.8}) {
      const P3 p = point_for(at, bt, z);
      const Jet<3> a = jet_a(p), b = jet_b(p);
      ASSERT_NEAR(a.v, at, 1e-12);
      ASSERT_NEAR(b.v, bt, 1e-12);
      const auto [x, y, zz] = vars(p);
      const E3 r = c.ad(inner_a(x, y, zz), inner_b(x, y, zz));
      const auto [f, fa, fb, faa, fab, fbb] = c.closed(a.v, b.v);
      adtest::expect_jet_near(adtest::to_jet(r), adtest::compose(a, b, f, fa, fb, faa, fab, fbb),
                              kTol, kGroup,
                              c.name + " at (a, b) = (" + std::to_string(at) + ", " +
                                  std::to_string(bt) + "), point " + adtest::point_name(p));
    }
}

INSTANTIATE_TEST_SUITE_P(Rules, Binary, ::testing::ValuesIn(binary_cases()),
                         [](const auto& info) { return info.param.name; });

// The inner functions themselves (products, sums, exp, sin of independent variables) and the
// variables: the first links of every chain above.
TEST(Inner, MatchesClosedForm) {
  for (const P3& p : {P3{0.3, -1.2, 0.7}, P3{-2.1, 0.4, -1.9}}) {
    const auto [x, y, z] = vars(p);
    adtest::expect_jet_near(adtest::to_jet(inner_a(x, y, z)), jet_a(p), kTol, kGroup,
                            "inner a at " + adtest::point_name(p));
    adtest::expect_jet_near(adtest::to_jet(inner_b(x, y, z)), jet_b(p), kTol, kGroup,
                            "inner b at " + adtest::point_name(p));
    for (int i = 0; i < 3; ++i) {
      Jet<3> e;
      e.v = p[i];
      e.g[i] = 1.0;
      EXPECT_EQ(adtest::to_jet(vars(p)[i]).g, e.g);
      EXPECT_EQ(adtest::to_jet(vars(p)[i]).H, e.H);
    }
  }
}

}  // namespace
