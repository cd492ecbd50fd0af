// eom::Embedded against high-precision central differences.
//
// Six test functions of (x, y, z), written once as templates on the scalar (like a model), cover
// every operation a model may use. Each is evaluated
//   * in qd's dd_real (~32 digits) and differentiated by sixth-order central differences
//     (ad_test_support.hpp: agreement with dd_real AD ~1e-20, far below every tolerance here);
//   * with Embedded<3, double, 2>, Embedded<3, double, 1>, Embedded<3, long double, 2> and
//     Embedded<3, dd_real, 2>;
//   * with the nested Embedded<3, Embedded<1, double, 1>, 2>, whose inner derivative along a
//     direction d gives ∇f·d, H·d and the directional derivative of the Hessian, checked against
//     central differences (in t) of the dd_real AD Hessian at x + t·d.
// Error measure: normwise relative in the max norm, value, gradient and Hessian separately.
#include "ad_test_support.hpp"

#include <eom/model/model.hpp>

namespace {

using adtest::Jet;
using P3 = std::array<double, 3>;

// ---- the test functions -------------------------------------------------------------------
// Points stay clear (by > 100 steps) of kinks (abs, select) and of domain limits.

struct Trig {
  static constexpr const char* name = "trig";
  static constexpr std::array<P3, 3> points{{{0.7, -1.3, 0.4}, {-1.1, 0.6, -0.9}, {2.3, 1.7, 0.2}}};
  template <class S>
  S operator()(const S& x, const S& y, const S& z) const {
    using std::cos, std::sin, std::tan;
    return sin(x * y) * cos(z - x) + tan(0.3 * y + z) / (1.0 + x * x) - (-z) * cos(y) +
           sin(z) * sin(z);
  }
};

// (x, y) in all four quadrants for atan2(y, x)
struct InverseTrig {
  static constexpr const char* name = "inverse_trig";
  static constexpr std::array<P3, 4> points{
      {{0.8, 0.5, 0.3}, {-0.9, 0.7, -0.4}, {-0.6, -1.2, 0.8}, {1.3, -0.4, -1.1}}};
  template <class S>
  S operator()(const S& x, const S& y, const S& z) const {
    using std::acos, std::asin, std::atan, std::atan2;
    return asin(0.4 * x * y) + acos(z / (2.0 + y * y)) * atan(x - 2.0 * z) + atan2(y, x) +
           atan2(x * z, 1.0 + y) + atan2(0.5, y - 2.0) * atan2(x, -1.5) + adtest::hyp(y, z);
  }
};

struct ExpLog {
  static constexpr const char* name = "exp_log";
  static constexpr std::array<P3, 3> points{{{0.5, -0.8, 1.2}, {-1.4, 0.3, -0.6}, {1.9, 1.1, 0.7}}};
  template <class S>
  S operator()(const S& x, const S& y, const S& z) const {
    using std::exp, std::log, std::sin, std::sqrt;
    return exp(x * z - y) * log(1.0 + x * x + y * y) + sqrt(2.0 + sin(x * y * z)) -
           log(exp(y) + 3.0) / (x * x + 1.0) + sqrt(x * x + z * z);
  }
};

// integer and real exponents (also at negative bases), AD^AD and double^AD
struct Powers {
  static constexpr const char* name = "powers";
  static constexpr std::array<P3, 3> points{
      {{0.6, -1.2, 0.9}, {-1.3, 0.8, -0.7}, {1.7, 2.1, -1.4}}};
  template <class S>
  S operator()(const S& x, const S& y, const S& z) const {
    using adtest::cpow, adtest::rpow, std::pow;
    return rpow(1.0 + x * x + y * y, 0.7) + pow(x, 3) * pow(y, -2) + cpow(2.0, z * x) +
           pow(1.5 + y * y, x - z) + rpow(z, 3.0) + pow(x - y, -1) + rpow(z * z + 0.5, -1.5) +
           pow(x * z, 2) + pow(y, 0) * x + pow(z, 1) * y + rpow(y, 2.0) + cpow(0.4, y * z);
  }
};

// + − × ÷ between numbers and with constants on both sides, unary minus, abs, hypot
struct Arithmetic {
  static constexpr const char* name = "arithmetic";
  static constexpr std::array<P3, 3> points{
      {{0.4, -0.7, 1.1}, {-1.2, 0.9, -0.3}, {2.2, 0.35, -1.6}}};
  template <class S>
  S operator()(const S& x, const S& y, const S& z) const {
    using std::abs;
    return (3.0 - x) / (2.0 + y * y) - 2.0 * z * x + 1.0 / (x + 3.0) + x / 2.0 + abs(y - 0.1) +
           adtest::hyp(x, z + 0.5) + x * y * z - (y - z) / (x * x + 0.3) + (-x) * y - z / 3.0 +
           2.5 * (z - y) * x - abs(x * z);
  }
};

// compound assignment and eom::select with bool conditions; points take every branch
struct Piecewise {
  static constexpr const char* name = "piecewise";
  static constexpr std::array<P3, 4> points{
      {{0.9, 0.2, -0.6}, {-0.5, 0.8, 1.3}, {1.4, -0.3, 0.6}, {-1.6, -0.2, 0.1}}};
  template <class S>
  S operator()(const S& x, const S& y, const S& z) const {
    using std::abs, std::exp, std::sin;
    S s = x;
    s += y * z;
    s *= 1.0 + z * z;
    s -= 2.0;
    s /= 1.5 + sin(x);
    s -= y;
    s *= z - 3.0;
    s += eom::select(x > y, x * x * y, sin(y) * z);
    s += eom::select(z < 0.25, exp(z), 1.0 / (1.0 + z));
    s += eom::select(abs(x) >= 1.0, adtest::hyp(x, y), S(0.5) * y);
    return s;
  }
};

template <class S, class F>
S call(const F& f, const std::array<S, 3>& v) {
  return f(v[0], v[1], v[2]);
}

template <class F>
Jet<3, dd_real> reference(const P3& p) {
  return adtest::central_differences<3>([](const std::array<dd_real, 3>& v) { return call(F{}, v); },
                                        p);
}

template <class F>
class CentralDifference : public ::testing::Test {};

struct FunctionNames {
  template <class F>
  static std::string GetName(int) {
    return F::name;
  }
};
using Functions = ::testing::Types<Trig, InverseTrig, ExpLog, Powers, Arithmetic, Piecewise>;
TYPED_TEST_SUITE(CentralDifference, Functions, FunctionNames);

std::string where(const char* name, const P3& p) { return std::string(name) + " at " + adtest::point_name(p); }

// Embedded<3, double, 2>: value, gradient and Hessian within 1e-12 of the dd_real differences.
TYPED_TEST(CentralDifference, DoubleOrder2) {
  using F = TypeParam;
  using A = eom::Embedded<3, double, 2>;
  for (const P3& p : F::points) {
    const A r = call(F{}, adtest::variables<A>(p));
    adtest::expect_jet_near(adtest::to_jet(r), adtest::to_double_jet(reference<F>(p)), 1e-12,
                            "double AD, order 2 vs dd central diff", where(F::name, p));
  }
}

// Embedded<3, double, 1>: the gradient alone, within 1e-12 of the differences, and the same as
// the second-order number's (the gradient takes the same operations: 4e-16 normwise).
TYPED_TEST(CentralDifference, DoubleOrder1) {
  using F = TypeParam;
  using A1 = eom::Embedded<3, double, 1>;
  using A2 = eom::Embedded<3, double, 2>;
  for (const P3& p : F::points) {
    const A1 r1 = call(F{}, adtest::variables<A1>(p));
    const A2 r2 = call(F{}, adtest::variables<A2>(p));
    adtest::expect_jet_near(adtest::to_jet(r1), adtest::to_double_jet(reference<F>(p)), 1e-12,
                            "double AD, order 1 vs dd central diff", where(F::name, p), false);
    adtest::expect_jet_near(adtest::to_jet(r1), adtest::to_jet(r2), 4e-16,
                            "order 1 vs order 2 gradient", where(F::name, p), false);
  }
}

// Embedded<3, long double, 2>: within 1e-15 (x87 extended precision carries ~19 digits, so
// this also fails if the computation were silently done in double).
TYPED_TEST(CentralDifference, LongDoubleOrder2) {
  using F = TypeParam;
  using A = eom::Embedded<3, long double, 2>;
  for (const P3& p : F::points) {
    const A r = call(F{}, adtest::variables<A>(p));
    const Jet<3, dd_real> e = reference<F>(p);
    Jet<3, long double> el;
    auto ld = [](const dd_real& d) { return static_cast<long double>(d.x[0]) + d.x[1]; };
    el.v = ld(e.v);
    for (int i = 0; i < 3; ++i) el.g[i] = ld(e.g[i]);
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) el.H[i][k] = ld(e.H[i][k]);
    adtest::expect_jet_near(adtest::to_jet<long double>(r), el, 1e-15,
                            "long double AD, order 2 vs dd central diff", where(F::name, p));
  }
}

// Embedded<3, dd_real, 2>: the rules hold to double-double precision (tolerance 1e-18).
TYPED_TEST(CentralDifference, DdRealOrder2) {
  using F = TypeParam;
  using A = eom::Embedded<3, dd_real, 2>;
  for (const P3& p : F::points) {
    const A r = call(F{}, adtest::variables<A>(p));
    adtest::expect_jet_near(adtest::to_jet<dd_real>(r), reference<F>(p), 1e-18,
                            "dd_real AD, order 2 vs dd central diff", where(F::name, p));
  }
}

// Embedded<3, Embedded<1, double, 1>, 2> with inner direction d: its bottom level is the plain
// order-2 result, and its inner derivatives are ∇f·d, H·d and D_d H (third derivatives).
TYPED_TEST(CentralDifference, NestedDirectional) {
  using F = TypeParam;
  using D = eom::Embedded<1, double, 1>;
  using A = eom::Embedded<3, D, 2>;
  using A2 = eom::Embedded<3, double, 2>;
  using Add = eom::Embedded<3, dd_real, 2>;
  const P3 d{0.3, -0.7, 0.5};
  for (const P3& p : F::points) {
    std::array<A, 3> v;
    for (int i = 0; i < 3; ++i) {
      D inner(p[i]);
      inner.g[0] = d[i];
      v[i] = A::variable(inner, i);
    }
    const A r = call(F{}, v);
    const A2 r2 = call(F{}, adtest::variables<A2>(p));
    adtest::expect_jet_near(adtest::to_jet(r), adtest::to_jet(r2), 4e-16,
                            "nested (bottom level) vs order 2", where(F::name, p));

    // expected directional derivatives from dd_real AD Hessians at p + t·d (sixth-order
    // central differences in t, step 2^-13), and ∇f·d, H·d from the same dd_real AD at p
    auto hessian_at = [&](double t) {
      std::array<Add, 3> w;
      for (int i = 0; i < 3; ++i)
        w[i] = Add::variable(dd_real(p[i]) + dd_real(t) * dd_real(d[i]), i);
      return adtest::to_jet<dd_real>(call(F{}, w));
    };
    const Jet<3, dd_real> j0 = hessian_at(0.0);
    Jet<3, dd_real> e;
    for (int i = 0; i < 3; ++i) {
      e.v += j0.g[i] * dd_real(d[i]);
      for (int k = 0; k < 3; ++k) e.g[i] += j0.H[i][k] * dd_real(d[k]);
    }
    const double h = adtest::kStep;
    for (int s = 1; s <= 3; ++s) {
      const Jet<3, dd_real> jp = hessian_at(s * h), jm = hessian_at(-s * h);
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k)
          e.H[i][k] += dd_real(adtest::kW1[s - 1]) * (jp.H[i][k] - jm.H[i][k]);
    }
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) e.H[i][k] /= dd_real(60.0 * h);

    Jet<3> got;
    got.v = r.v.g[0];
    for (int i = 0; i < 3; ++i) got.g[i] = r.g[i].g[0];
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) got.H[i][k] = r.hessian(i, k).g[0];
    adtest::expect_jet_near(got, adtest::to_double_jet(e), 1e-12,
                            "nested directional (grad.d, H.d, D_d H) vs dd", where(F::name, p));
  }
}

}  // namespace
