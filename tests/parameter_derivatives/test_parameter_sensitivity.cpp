// ∂x(t)/∂p integrated by eom::Sensitivity<K, eom::with_parameters> through eom::integrate, over
// eom::Reference and a generated double pendulum with the parameter kernel (CMakeLists.txt):
//
// 1. Against central differences of whole trajectories in p (adaptive methods: dop853, and
//    taylor over the reference).
// 2. RK4: the augmented RK4 step is the exact derivative of the RK4 map (variational equations
//    commute with Runge–Kutta methods), so S must match differences of RK4 trajectories with the
//    same steps to the difference quotient's own error, integration error aside.
// 3. Closed forms for the (chaotic) double pendulum started at rest, exact for any motion:
//    time scaling  x(t; g) = (a(√g t), √g a'(√g t)):  ∂q/∂g = t q̇ / (2g), ∂q̇/∂g = (q̇ + t q̈) / (2g);
//    mass scaling  q̈ depends on m1, m2 only through m2/m1:  m1 ∂x/∂m1 + m2 ∂x/∂m2 = 0;
//    length scaling  (l1, l2, g) → (βl1, βl2, βg) leaves q̈ unchanged:
//                  l1 ∂x/∂l1 + l2 ∂x/∂l2 + g ∂x/∂g = 0.
// 4. The API: Φ-only costs nothing more, failures of the base kernels become a Status, and
//    integrating the augmented model allocates nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <new>

#include <eom/integration/integrate.hpp>
#include <eom/integration/sensitivity.hpp>
#include <eom/reference/reference.hpp>

#include <double_pendulum.hpp>     // bundled: no parameter kernel
#include <ps_double_pendulum.hpp>  // with forward_dynamics_parameter_derivatives
#include <spring_pendulum.hpp>

#include <models/double_pendulum.hpp>
#include <models/spring_pendulum.hpp>

// Heap allocations made by this program (the replaceable new forwards here; the library's array
// and nothrow forms call it).
std::atomic<long> heap_allocations{0};
// The replaced operator delete frees what the replaced operator new took from malloc; GCC 12 at
// -O1 (tests/CMakeLists.txt: EOM_TEST_OPTIMIZATION) sees only "new" paired with free.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t size) {
  heap_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace {

using Ref = eom::Reference<eom::models::DoublePendulum>;
using Gen = ps_double_pendulum::Kernels;

// ---- the API ----------------------------------------------------------------------------------

// Φ alone: the augmented size of before, no parameter columns, no parameter kernel needed (the
// bundled Kernels lack it), no parameter_sensitivity accessor.
using PhiOnly = eom::Sensitivity<double_pendulum::Kernels>;
static_assert(PhiOnly::nq == 2 * (1 + 4) && !PhiOnly::has_parameters);
template <class S>
concept HasParameterSensitivity =
    requires(const eom::StateOf<S::nq>& y) { S::parameter_sensitivity(y); };
static_assert(!HasParameterSensitivity<PhiOnly>);
using WithP = eom::Sensitivity<Gen, eom::with_parameters>;
static_assert(WithP::nq == 2 * (1 + 4 + 5) && WithP::has_parameters);
static_assert(HasParameterSensitivity<WithP>);
static_assert(noexcept(WithP::forward_dynamics(0, nullptr, nullptr, nullptr, nullptr, nullptr)));
// Taylor over the reference only (generated kernels cannot be expanded on jets).
static_assert(eom::TaylorDynamics<eom::Sensitivity<Ref, eom::with_parameters>>);
static_assert(eom::TaylorDynamics<eom::Sensitivity<Ref>>);
static_assert(!eom::TaylorDynamics<WithP>);

constexpr eom::StateOf<2> kRest{2.0, 2.5, 0.0, 0.0};  // the chaotic start, at rest

template <class M>
eom::IntegrationResult<M::nq> run(eom::Method method, double t1, const eom::StateOf<M::nq>& x0,
                                  const double* p, double tol, double step = 0) {
  eom::IntegrationOptions opt;
  opt.method = method;
  opt.rtol = opt.atol = tol;
  opt.step = step;
  return eom::integrate<M>(0, t1, x0, nullptr, p, opt);
}

struct Comparison {
  double worst = 0, scale = 0;  // max |S − FD|, max |S|
};

// S = ∂x(t1)/∂p from `method` against D(h) = (x(t1; p + hₖeₖ) − x(t1; p − hₖeₖ)) / 2hₖ,
// hₖ = δ|pₖ|, the trajectories by `fd_method` (same fixed step when `step` > 0). With
// `richardson`, against (4 D(h/2) − D(h)) / 3, whose truncation error is O(h⁴) instead of O(h²).
template <class K>
Comparison against_differences(const eom::StateOf<K::nq>& x0, double t1, eom::Method method,
                               double tol, eom::Method fd_method, double fd_tol, double delta,
                               double step = 0, bool richardson = false) {
  using S = eom::Sensitivity<K, eom::with_parameters>;
  constexpr int m = 2 * K::nq, np = K::np;
  const auto p = K::parameter_values;
  const auto r = run<S>(method, t1, S::start(x0), p.data(), tol, step);
  EXPECT_EQ(r.status, eom::Status::ok) << eom::to_string(method);
  const auto sens = S::parameter_sensitivity(r.x);
  Comparison c;
  auto quotient = [&](int k, double h) {
    auto plus = p, minus = p;
    plus[k] += h;
    minus[k] -= h;
    const auto a = run<K>(fd_method, t1, x0, plus.data(), fd_tol, step);
    const auto b = run<K>(fd_method, t1, x0, minus.data(), fd_tol, step);
    EXPECT_EQ(a.status, eom::Status::ok);
    EXPECT_EQ(b.status, eom::Status::ok);
    eom::StateOf<K::nq> d;
    for (int i = 0; i < m; ++i) d[i] = (a.x[i] - b.x[i]) / (plus[k] - minus[k]);
    return d;
  };
  for (int k = 0; k < np; ++k) {
    const double h = delta * std::abs(p[k]);
    const auto whole = quotient(k, h);
    eom::StateOf<K::nq> half{};
    if (richardson) half = quotient(k, h / 2);
    for (int i = 0; i < m; ++i) {
      const double fd = richardson ? (4 * half[i] - whole[i]) / 3 : whole[i];
      c.worst = std::max(c.worst, std::abs(fd - sens[i + m * k]));
      c.scale = std::max(c.scale, std::abs(sens[i + m * k]));
    }
  }
  // The state part is the plain model's trajectory (to the integration tolerance).
  const auto plain = run<K>(method, t1, x0, p.data(), tol, step);
  for (int i = 0; i < m; ++i) EXPECT_NEAR(S::state(r.x)[i], plain.x[i], 1e-9);
  std::printf("  %-7s max |∂x/∂p − FD| = %.2e (max |∂x/∂p| = %.2e) at t = %g, %ld steps\n",
              eom::to_string(method), c.worst, c.scale, t1, r.accepted);
  return c;
}

// Adaptive runs. S at tolerance 1e-12, the differenced trajectories at 1e-13 with δ = 1e-5: the
// quotient's truncation is δ²pₖ²|∂³x/∂pₖ³|/6 ~ 1e-10 |S| and the integration error of each
// trajectory (~1e-12 over these spans) enters as 1e-12 / (2δ|pₖ|) ≲ 1e-7, and much less in
// practice because neighbouring runs take nearly the same steps (errors correlated); S's own
// integration error is ~1e-11. So 1e-6·max|S| has margin and still catches any wrong term
// (a missing ∂q̈/∂p or a dropped product is an O(1) relative error).
constexpr double kAdaptiveBound = 1e-6;

TEST(ParameterSensitivity, ReferenceDoublePendulumDop853MatchesTrajectoryDifferences) {
  const auto c = against_differences<Ref>(kRest, 1.0, eom::Method::dop853, 1e-12,
                                          eom::Method::dop853, 1e-13, 1e-5);
  EXPECT_LT(c.worst, kAdaptiveBound * c.scale);
}

TEST(ParameterSensitivity, ReferenceDoublePendulumTaylorMatchesTrajectoryDifferences) {
  const auto c = against_differences<Ref>(kRest, 1.0, eom::Method::taylor, 1e-12,
                                          eom::Method::dop853, 1e-13, 1e-5);
  EXPECT_LT(c.worst, kAdaptiveBound * c.scale);
}

TEST(ParameterSensitivity, GeneratedDoublePendulumDop853MatchesTrajectoryDifferences) {
  const auto c = against_differences<Gen>(kRest, 1.0, eom::Method::dop853, 1e-12,
                                          eom::Method::dop853, 1e-13, 1e-5);
  EXPECT_LT(c.worst, kAdaptiveBound * c.scale);
}

TEST(ParameterSensitivity, ReferenceSpringPendulumDop853MatchesTrajectoryDifferences) {
  // Moving start (velocities nonzero), parameters m, k, r0, g of very different sizes.
  using K = eom::Reference<eom::models::SpringPendulum>;
  const auto c = against_differences<K>({0.55, 0.0, 0.01, 2.5}, 2.0, eom::Method::dop853, 1e-12,
                                        eom::Method::dop853, 1e-13, 1e-5);
  EXPECT_LT(c.worst, kAdaptiveBound * c.scale);
}

// RK4 with a fixed step: S is the exact derivative of the discrete map (the RK4 trajectories are
// smooth in p, no step-size control), so the only error left is the difference quotient's. Plain
// central differences at δ = 1e-4: truncation δ²pₖ²|∂³x/∂pₖ³|/6 ~ 1e-8·|S| (measured 1e-8..1e-7
// relative), bound 1e-6·max|S|. Richardson-extrapolated at δ = 1e-3: truncation O(δ⁴) ~ 1e-12,
// rounding ~1e-16·|x|·(steps)^½ / (δ|pₖ|) ~ 1e-11: bound 1e-9·max|S|, which an integration error
// (~1e-3 at step 0.05) or any wrong term would exceed by orders of magnitude.
TEST(ParameterSensitivity, Rk4IsTheExactDerivativeOfTheRk4Map) {
  for (double step : {1e-3, 5e-2}) {
    // (the tolerances are not used by rk4, but must be valid)
    const auto c = against_differences<Gen>(kRest, 1.0, eom::Method::rk4, 1e-8, eom::Method::rk4,
                                            1e-8, 1e-4, step);
    EXPECT_LT(c.worst, 1e-6 * c.scale) << "step " << step;
    const auto e = against_differences<Gen>(kRest, 1.0, eom::Method::rk4, 1e-8, eom::Method::rk4,
                                            1e-8, 1e-3, step, true);
    EXPECT_LT(e.worst, 1e-9 * e.scale) << "step " << step << ", Richardson";
  }
}

// ---- closed forms -----------------------------------------------------------------------------

template <class K> void check_closed_forms(eom::Method method, double t1, double tol, double bound) {
  using S = eom::Sensitivity<K, eom::with_parameters>;
  constexpr int n = 2, m = 4;
  constexpr int m1 = 0, m2 = 1, l1 = 2, l2 = 3, g = 4;
  const auto p = K::parameter_values;
  const auto r = run<S>(method, t1, S::start(kRest), p.data(), tol);
  ASSERT_EQ(r.status, eom::Status::ok);
  const auto x = S::state(r.x);
  const auto s = S::parameter_sensitivity(r.x);
  auto col = [&](int k, int i) { return s[i + m * k]; };
  std::array<double, n> qdd;
  ASSERT_TRUE(K::forward_dynamics(t1, x.data(), x.data() + n, nullptr, p.data(), qdd.data()));
  double scale = 0, err_g = 0, err_mass = 0, err_length = 0;
  for (int i = 0; i < m; ++i) {
    for (int k = 0; k < K::np; ++k) scale = std::max(scale, std::abs(col(k, i)));
    // ∂q/∂g = t q̇ / 2g (rows 0..n−1); ∂q̇/∂g = (q̇ + t q̈) / 2g (rows n..m−1).
    const double want_g = i < n ? t1 * x[n + i] / (2 * p[g])
                                : (x[i] + t1 * qdd[i - n]) / (2 * p[g]);
    err_g = std::max(err_g, std::abs(col(g, i) - want_g));
    err_mass = std::max(err_mass, std::abs(p[m1] * col(m1, i) + p[m2] * col(m2, i)));
    err_length = std::max(
        err_length, std::abs(p[l1] * col(l1, i) + p[l2] * col(l2, i) + p[g] * col(g, i)));
  }
  std::printf("  %-7s t = %g: |∂x/∂g − closed form| = %.2e, |m·∂x/∂m| = %.2e, "
              "|l·∂x/∂l + g·∂x/∂g| = %.2e (max |∂x/∂p| = %.2e), %ld steps\n",
              eom::to_string(method), t1, err_g, err_mass, err_length, scale, r.accepted);
  EXPECT_LT(err_g, bound * scale);
  EXPECT_LT(err_mass, bound * scale);
  EXPECT_LT(err_length, bound * scale);
}

// The identities are exact, so what is left is S's integration error: tolerance 1e-12 per step
// (relative to |S| ~ 10), amplified by the flow (max |Φ| ~ 10 at t = 1, ≲ 1e2 at t = 2): at
// most ~1e-10·max|S|, the bound. A wrong term in S̈ would be an O(1) relative error.
TEST(ParameterSensitivity, ClosedFormsHoldForTheReferenceDop853) {
  check_closed_forms<Ref>(eom::Method::dop853, 2.0, 1e-12, 1e-10);
}
TEST(ParameterSensitivity, ClosedFormsHoldForTheReferenceTaylor) {
  check_closed_forms<Ref>(eom::Method::taylor, 2.0, 1e-12, 1e-10);
}
TEST(ParameterSensitivity, ClosedFormsHoldForGeneratedKernelsDop853) {
  check_closed_forms<Gen>(eom::Method::dop853, 2.0, 1e-12, 1e-10);
}
TEST(ParameterSensitivity, ClosedFormsHoldForGeneratedKernelsDopri5) {
  check_closed_forms<Gen>(eom::Method::dopri5, 2.0, 1e-12, 1e-10);
}

// ---- Φ alongside S, and failures ----------------------------------------------------------------

// Φ from Sensitivity<K, with_parameters> is the Φ of Sensitivity<K> (different step sequences:
// the parameter columns join the error control; both to the tolerance).
TEST(ParameterSensitivity, TransitionMatrixIsUnchangedByTheParameterColumns) {
  using A = eom::Sensitivity<Gen>;
  using B = eom::Sensitivity<Gen, eom::with_parameters>;
  const auto p = Gen::parameter_values;
  const auto a = run<A>(eom::Method::dop853, 1.0, A::start(kRest), p.data(), 1e-12);
  const auto b = run<B>(eom::Method::dop853, 1.0, B::start(kRest), p.data(), 1e-12);
  ASSERT_EQ(a.status, eom::Status::ok);
  ASSERT_EQ(b.status, eom::Status::ok);
  const auto pa = A::transition(a.x), pb = B::transition(b.x);
  double worst = 0, scale = 0;
  for (std::size_t i = 0; i < pa.size(); ++i) {
    worst = std::max(worst, std::abs(pa[i] - pb[i]));
    scale = std::max(scale, std::abs(pa[i]));
  }
  EXPECT_LT(worst, 1e-9 * scale);
}

// dop853 over the augmented generated model: no heap allocation in the whole integration (the
// augmented state and every temporary are fixed-size arrays).
TEST(ParameterSensitivity, IntegrationAllocatesNothing) {
  const auto p = Gen::parameter_values;
  const auto y0 = WithP::start(kRest);
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = opt.atol = 1e-10;
  double sum = 0;
  const long before = heap_allocations.load();
  ASSERT_GT(before, 0) << "the counting operator new is not in use (gtest allocates at start-up)";
  const auto r = eom::integrate<WithP>(0, 1, y0, nullptr, p.data(), opt,
                                       [&](double, const eom::StateOf<WithP::nq>& y) { sum += y[0]; });
  const long made = heap_allocations.load() - before;
  ASSERT_EQ(r.status, eom::Status::ok);
  EXPECT_TRUE(std::isfinite(sum));
  EXPECT_EQ(made, 0);
}

// Taylor over generated kernels is not offered: a Status, not a wrong answer.
TEST(ParameterSensitivity, TaylorOverGeneratedKernelsIsUnavailable) {
  const auto p = Gen::parameter_values;
  const auto r = run<WithP>(eom::Method::taylor, 1.0, WithP::start(kRest), p.data(), 1e-10);
  EXPECT_EQ(r.status, eom::Status::method_unavailable);
}

// Massless pendulum: M = 0 is singular, forward_dynamics fails, and so does the augmented model
// (false, then a Status from the integrator) over generated kernels, the reference and Taylor.
TEST(ParameterSensitivity, BaseKernelFailureIsReported) {
  const std::array<double, 5> massless{0.0, 0.0, 1.0, 1.0, 9.81};
  const auto y = WithP::start(kRest);
  std::array<double, WithP::nq> ydd;
  EXPECT_FALSE(WithP::forward_dynamics(0, y.data(), y.data() + WithP::nq, nullptr,
                                       massless.data(), ydd.data()));
  using R = eom::Sensitivity<Ref, eom::with_parameters>;
  for (auto method : {eom::Method::dop853, eom::Method::taylor}) {
    const auto r = run<R>(method, 1.0, R::start(kRest), massless.data(), 1e-10);
    EXPECT_NE(r.status, eom::Status::ok) << eom::to_string(method);
    for (double v : r.x) EXPECT_FALSE(std::isnan(v)) << eom::to_string(method);
  }
}

}  // namespace
