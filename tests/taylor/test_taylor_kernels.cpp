// The generated taylor_coefficients kernel of every bundled model (contract: generator/README.md,
// "Taylor mode"):
//   - its low orders are the state and the forward dynamics;
//   - 2·qdk[2] (the third derivative q⃛) matches central differences of forward_dynamics along the
//     motion;
//   - its degree-p Taylor polynomial converges to the motion at order p + 1 (against RK4 with
//     tiny steps);
//   - it agrees with eom::Reference::taylor_coefficients when the runtime provides it;
//   - it rejects bad input (order, non-finite values, singular configurations) with NaN outputs.
// Measured figures are printed; assertions use the bounds justified next to each.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <bundled_models.hpp>  // the cases: generated Kernels, Reference, sampling

namespace {

using namespace eom_cases;
using Vec = std::vector<double>;
constexpr double eps = std::numeric_limits<double>::epsilon();
constexpr double nan = std::numeric_limits<double>::quiet_NaN();

template <class K>
concept HasTaylor = requires(int order, double t, const double* x, double* y) {
  { K::taylor_workspace } -> std::convertible_to<int>;
  { K::taylor_max_order } -> std::convertible_to<int>;
  { K::taylor_coefficients(order, t, x, x, x, x, y, y, y) } -> std::same_as<bool>;
};
static_assert(HasTaylor<spring_pendulum::Kernels> && HasTaylor<double_pendulum::Kernels> &&
              HasTaylor<cartesian_pendulum::Kernels> && HasTaylor<chain10::Kernels> &&
              HasTaylor<closed_chain5::Kernels> && HasTaylor<spacecraft_boom::Kernels>);

// The kernel's outputs for one state: qk, qdk (nq·(order + 1) each) and its result.
struct Series {
  bool ok = false;
  Vec qk, qdk;
};

template <class K>
Series taylor(int order, double t, const double* q, const double* qd, const double* u, const double* p) {
  Series s;
  const int n = std::max(order + 1, 1);
  s.qk.assign(K::nq * n, 0.0);
  s.qdk.assign(K::nq * n, 0.0);
  Vec work(K::taylor_workspace * n + 1);
  s.ok = K::taylor_coefficients(order, t, q, qd, u, p, s.qk.data(), s.qdk.data(), work.data());
  return s;
}

// A few random states (tests/support's sampler) and the case's own initial state.
template <class Case> std::vector<Sample<Case>> states(std::size_t count) {
  std::vector<Sample<Case>> s = random_samples<Case>(count, 7717);
  Sample<Case> start = s.front();
  constexpr int nq = Case::Gen::nq;
  for (int i = 0; i < nq; ++i) {
    start.q[i] = Case::x0[i];
    start.qd[i] = Case::x0[nq + i];
  }
  start.t = 0;
  for (int i = 0; i < Sample<Case>::np; ++i) start.p[i] = Case::Ref::parameter_values[i];
  s.push_back(start);
  return s;
}

template <class Case> Series taylor_at(const Sample<Case>& s, int order) {
  return taylor<typename Case::Gen>(order, s.t, s.q.data(), s.qd.data(), s.up(), s.p.data());
}

double max_abs(const Vec& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

// The radius of convergence in time, estimated from the root test on orders 10 and 20:
// ρ ≈ (max|c₁₀| / max|c₂₀|)^(1/10) (over q and q̇).
template <class Case> double radius(const Sample<Case>& s) {
  constexpr int nq = Case::Gen::nq;
  const Series c = taylor_at(s, 20);
  auto at = [&](int k) {
    double m = 0;
    for (int i = 0; i < nq; ++i) m = std::max({m, std::abs(c.qk[k * nq + i]), std::abs(c.qdk[k * nq + i])});
    return m;
  };
  return std::min(10.0, std::pow(at(10) / at(20), 0.1));
}

template <class Case> class TaylorKernel : public ::testing::Test {};
using Cases = ::testing::Types<SpringPendulumCase, CartesianPendulumCase, DoublePendulumCase,
                               Chain10Case, ClosedChain5Case, SpacecraftBoomCase>;
TYPED_TEST_SUITE(TaylorKernel, Cases);

// Coefficient 0 is the state, coefficient 1 of q is q̇ and of q̇ the forward dynamics (computed by
// the same operations in the same order as the forward_dynamics kernel, so equal to a few ulps),
// and qk[k + 1] = qdk[k] / (k + 1) at every order.
TYPED_TEST(TaylorKernel, LowOrdersAreTheStateAndTheForwardDynamics) {
  using Case = TypeParam;
  using G = typename Case::Gen;
  constexpr int nq = G::nq, order = 8;
  for (const auto& s : states<Case>(20)) {
    const Series c = taylor_at(s, order);
    ASSERT_TRUE(c.ok);
    std::array<double, nq> qdd{};
    ASSERT_TRUE(G::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), qdd.data()));
    for (int i = 0; i < nq; ++i) {
      EXPECT_EQ(c.qk[i], s.q[i]);
      EXPECT_EQ(c.qdk[i], s.qd[i]);
      EXPECT_EQ(c.qk[nq + i], s.qd[i]);
      EXPECT_NEAR(c.qdk[nq + i], qdd[i], 4 * eps * std::max(1.0, std::abs(qdd[i])));
      for (int k = 1; k < order; ++k) EXPECT_EQ(c.qk[(k + 1) * nq + i], c.qdk[k * nq + i] / (k + 1));
    }
  }
}

// q⃛ = d q̈/dt = 2·qdk[2], against the central difference of forward_dynamics along the tangent of
// the motion, v = (1, q̇, q̈) in (t, q, q̇): [f(x + δv) − f(x − δv)] / 2δ = Df·v + O(δ²) = q⃛ + O(δ²).
// With δ = 1e-4 ρ (ρ: the radius of convergence in time) the truncation is about (δ/ρ)² = 1e-8 and
// the cancellation about ε/(δ/ρ) = 2e-12, relative to max|q⃛|ρ + max|q̈|: bound 1e-7.
TYPED_TEST(TaylorKernel, ThirdDerivativeMatchesFiniteDifferences) {
  using Case = TypeParam;
  using G = typename Case::Gen;
  constexpr int nq = G::nq;
  double worst = 0;
  for (const auto& s : states<Case>(10)) {
    const Series c = taylor_at(s, 3);
    ASSERT_TRUE(c.ok);
    const double rho = radius(s), delta = 1e-4 * rho;
    std::array<double, nq> qp, qdp, qm, qdm, fp, fm;
    for (int i = 0; i < nq; ++i) {
      const double qdd = c.qdk[nq + i];
      qp[i] = s.q[i] + delta * s.qd[i];
      qm[i] = s.q[i] - delta * s.qd[i];
      qdp[i] = s.qd[i] + delta * qdd;
      qdm[i] = s.qd[i] - delta * qdd;
    }
    ASSERT_TRUE(G::forward_dynamics(s.t + delta, qp.data(), qdp.data(), s.up(), s.p.data(), fp.data()));
    ASSERT_TRUE(G::forward_dynamics(s.t - delta, qm.data(), qdm.data(), s.up(), s.p.data(), fm.data()));
    Vec third(nq), fd(nq), qdd(nq);
    for (int i = 0; i < nq; ++i) {
      third[i] = 2 * c.qdk[2 * nq + i];
      fd[i] = (fp[i] - fm[i]) / (2 * delta);
      qdd[i] = c.qdk[nq + i];
    }
    const double scale = max_abs(third) * rho + max_abs(qdd);
    for (int i = 0; i < nq; ++i) {
      const double e = std::abs(third[i] - fd[i]) * rho / scale;
      worst = std::max(worst, e);
      EXPECT_LE(e, 1e-7) << Case::name << " q⃛[" << i << "] = " << third[i] << " vs " << fd[i];
    }
  }
  std::printf("  %s: q⃛ against central differences: worst relative error %.2e\n", Case::name, worst);
}

// The reference motion: classical RK4 on forward_dynamics with `steps` steps over h.
template <class G>
bool rk4(double t, Vec q, Vec qd, const double* u, const double* p, double h, int steps, Vec& q_end,
         Vec& qd_end) {
  constexpr int nq = G::nq;
  const double dt = h / steps;
  std::array<double, nq> a1, a2, a3, a4;
  Vec q2(nq), qd2(nq);
  for (int step = 0; step < steps; ++step, t += dt) {
    auto f = [&](double tt, const Vec& x, const Vec& v, std::array<double, nq>& a) {
      return G::forward_dynamics(tt, x.data(), v.data(), u, p, a.data());
    };
    if (!f(t, q, qd, a1)) return false;
    for (int i = 0; i < nq; ++i) q2[i] = q[i] + dt / 2 * qd[i], qd2[i] = qd[i] + dt / 2 * a1[i];
    if (!f(t + dt / 2, q2, qd2, a2)) return false;
    Vec v2 = qd2;
    for (int i = 0; i < nq; ++i) q2[i] = q[i] + dt / 2 * v2[i], qd2[i] = qd[i] + dt / 2 * a2[i];
    if (!f(t + dt / 2, q2, qd2, a3)) return false;
    Vec v3 = qd2;
    for (int i = 0; i < nq; ++i) q2[i] = q[i] + dt * v3[i], qd2[i] = qd[i] + dt * a3[i];
    if (!f(t + dt, q2, qd2, a4)) return false;
    const Vec v4 = qd2;
    for (int i = 0; i < nq; ++i) {
      q[i] += dt / 6 * (qd[i] + 2 * v2[i] + 2 * v3[i] + v4[i]);
      qd[i] += dt / 6 * (a1[i] + 2 * a2[i] + 2 * a3[i] + a4[i]);
    }
  }
  q_end = q;
  qd_end = qd;
  return true;
}

// The degree-p Taylor polynomial at h against the motion: its error is c_(p+1) h^(p+1)(1 + O(h/ρ)),
// so halving h divides it by 2^(p+1). With h = ρ/20 the next term shifts the observed order
// log₂(e(h)/e(h/2)) by about log₂(1.05/1.025) ≈ 0.04 (a few times that where the low-order
// coefficients grow faster than ρ^−k): the bound is p + 1 ± 0.25. RK4 with 4000 steps of
// h/4000 ≤ ρ/80000 is accurate to (step/ρ)⁴ ≈ 1e-20 plus round-off, √4000 ε ≈ 1e-14 relative,
// below 1% of the smallest Taylor error used (≥ 1e-12 relative, checked): ≤ 0.015 on the order.
TYPED_TEST(TaylorKernel, PolynomialConvergesAtOrderPPlusOne) {
  using Case = TypeParam;
  using G = typename Case::Gen;
  constexpr int nq = G::nq;
  for (const auto& s : states<Case>(2)) {
    const double rho = radius(s);
    for (int p : {2, 3, 4, 5}) {
      const Series c = taylor_at(s, p);
      ASSERT_TRUE(c.ok);
      double e[2];
      for (int half = 0; half < 2; ++half) {
        const double h = rho / 20 / (1 << half);
        Vec q(s.q.begin(), s.q.end()), qd(s.qd.begin(), s.qd.end()), q_ref, qd_ref;
        ASSERT_TRUE(rk4<G>(s.t, q, qd, s.up(), s.p.data(), h, 4000, q_ref, qd_ref));
        double err = 0, scale = 0;
        for (int i = 0; i < nq; ++i) {
          double qh = 0, qdh = 0;
          for (int k = p; k >= 0; --k) {  // Horner
            qh = qh * h + c.qk[k * nq + i];
            qdh = qdh * h + c.qdk[k * nq + i];
          }
          err = std::max({err, std::abs(qh - q_ref[i]), std::abs(qdh - qd_ref[i]) * rho});
          scale = std::max({scale, std::abs(q_ref[i]), std::abs(qd_ref[i]) * rho});
        }
        e[half] = err;
        EXPECT_GE(err, 1e-12 * std::max(1.0, scale)) << "Taylor error too close to the reference's";
      }
      const double observed = std::log2(e[0] / e[1]);
      std::printf("  %s: p = %d, h = %.3g: errors %.2e, %.2e, observed order %.2f\n", Case::name, p,
                  rho / 20, e[0], e[1], observed);
      EXPECT_NEAR(observed, p + 1, 0.25) << Case::name << " p = " << p;
    }
  }
}


// Against eom::Reference<Model>::taylor_coefficients (operator-overloading Taylor arithmetic on
// the model's T, V, φ, Q), when the runtime has it, to order 20 at random states; both in double
// and measured against the same reference in double-double (qd's dd_real, ~1e-32), the truth here.
// Norm per order k: max_i |x_k,i − truth_k,i| / max_i |truth_k,i|. Both double implementations
// sum the same series in different operation orders: each coefficient sums ~k products of lower
// ones (round-off growing about linearly in k), and the problem's conditioning amplifies both
// alike, which the reference's own error e_ref(k) shows. Bound: the generated kernel is as
// accurate as the reference, e_gen(k) ≤ 1e-14 (1 + k) + 2 e_ref(k); and so the two differ by at
// most 1e-14 (1 + k) + 3 e_ref(k).
TYPED_TEST(TaylorKernel, AgreesWithReference) {
  using Case = TypeParam;
  using R = typename Case::Ref;
  static_assert(HasTaylor<R>, "eom::Reference must offer taylor_coefficients");
  {
    using Truth = eom::Reference<typename R::model_type, dd_real>;
    constexpr int nq = R::nq, nu = R::nu, np = R::np;
    constexpr int order = std::min(20, R::taylor_max_order);
    double worst_gen = 0, worst_ref = 0, worst_diff = 0;
    {
      // dd_real Taylor coefficients cost ~1 s per state for the 10-link chain: fewer states there.
      const std::size_t count = nq > 5 ? 2 : 4;
      for (const auto& s : random_samples<Case>(count, 9001)) {
        const Series g = taylor_at(s, order);
        const Series r = taylor<R>(order, s.t, s.q.data(), s.qd.data(), s.up(), s.p.data());
        ASSERT_TRUE(g.ok && r.ok);
        std::array<dd_real, nq> q, qd;
        std::array<dd_real, nu + 1> u;
        std::array<dd_real, np + 1> p;
        for (int i = 0; i < nq; ++i) q[i] = s.q[i], qd[i] = s.qd[i];
        for (int i = 0; i < nu; ++i) u[i] = s.u[i];
        for (int i = 0; i < np; ++i) p[i] = s.p[i];
        std::vector<dd_real> tk(nq * (order + 1)), tdk(nq * (order + 1));
        ASSERT_TRUE(Truth::taylor_coefficients(order, dd_real(s.t), q.data(), qd.data(), u.data(),
                                               p.data(), tk.data(), tdk.data(), nullptr));
        for (int which = 0; which < 2; ++which) {
          const Vec& a = which ? g.qdk : g.qk;
          const Vec& b = which ? r.qdk : r.qk;
          const std::vector<dd_real>& truth = which ? tdk : tk;
          for (int k = 1; k <= order; ++k) {
            double gen = 0, ref = 0, diff = 0, scale = 0;
            for (int i = 0; i < nq; ++i) {
              const int at = k * nq + i;
              gen = std::max(gen, std::abs(to_double(a[at] - truth[at])));
              ref = std::max(ref, std::abs(to_double(b[at] - truth[at])));
              diff = std::max(diff, std::abs(a[at] - b[at]));
              scale = std::max(scale, std::abs(to_double(truth[at])));
            }
            if (scale == 0) continue;  // e.g. a model at rest without forces
            gen /= scale, ref /= scale, diff /= scale;
            worst_gen = std::max(worst_gen, gen);
            worst_ref = std::max(worst_ref, ref);
            worst_diff = std::max(worst_diff, diff);
            EXPECT_LE(gen, 1e-14 * (1 + k) + 2 * ref) << Case::name << " k = " << k;
            EXPECT_LE(diff, 1e-14 * (1 + k) + 3 * ref) << Case::name << " k = " << k;
          }
        }
      }
    }
    std::printf("  %s, orders 1..%d against dd_real: worst error generated %.2e, Reference<double> "
                "%.2e; generated vs Reference<double> %.2e\n",
                Case::name, order, worst_gen, worst_ref, worst_diff);
  }
}

bool all_nan(const Vec& v, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i)
    if (!std::isnan(v[i])) return false;
  return true;
}

TYPED_TEST(TaylorKernel, RejectsBadInput) {
  using Case = TypeParam;
  using G = typename Case::Gen;
  constexpr int nq = G::nq;
  const Sample<Case> s = states<Case>(1).front();
  auto expect_rejected = [&](int order, double t, const double* q, const double* qd, const double* p,
                             const char* what) {
    const Series c = taylor<G>(order, t, q, qd, s.up(), p);
    EXPECT_FALSE(c.ok) << what;
    const std::size_t filled = order >= 0 ? std::size_t(nq) * (order + 1) : 0;
    EXPECT_TRUE(all_nan(c.qk, filled) && all_nan(c.qdk, filled)) << what << ": outputs not NaN";
  };
  static_assert(G::taylor_max_order >= 30);
  expect_rejected(0, s.t, s.q.data(), s.qd.data(), s.p.data(), "order 0");
  expect_rejected(-1, s.t, s.q.data(), s.qd.data(), s.p.data(), "order -1");
  expect_rejected(G::taylor_max_order + 1, s.t, s.q.data(), s.qd.data(), s.p.data(), "order > max");
  EXPECT_TRUE(taylor_at(s, G::taylor_max_order).ok) << "the highest order is accepted";
  auto q = s.q, qd = s.qd;
  auto p = s.p;
  q[nq - 1] = nan;
  expect_rejected(5, s.t, q.data(), s.qd.data(), s.p.data(), "NaN q");
  qd[0] = std::numeric_limits<double>::infinity();
  expect_rejected(5, s.t, s.q.data(), qd.data(), s.p.data(), "infinite qd");
  expect_rejected(5, nan, s.q.data(), s.qd.data(), s.p.data(), "NaN t");
  if constexpr (G::np > 0) {
    p[0] = nan;
    expect_rejected(5, s.t, s.q.data(), s.qd.data(), p.data(), "NaN p");
  }
  if constexpr (requires { Case::singular_q; }) {
    expect_rejected(5, s.t, Case::singular_q.data(), s.qd.data(), s.p.data(), "singular configuration");
  }
}

// A kernel split into parts keeps the values its parts share in scratch arrays; it has an overload
// taking them from the caller (taylor_coefficients_workspace doubles), so that it needs no large
// stack frame: the same bits as the plain signature, whatever the scratch held before. The split
// models must have it (a missing overload fails to compile); the small ones need none.
template <class K>
concept HasTaylorScratch = requires(int order, double t, const double* x, double* y) {
  { K::taylor_coefficients_workspace } -> std::convertible_to<int>;
  { K::taylor_coefficients(order, t, x, x, x, x, y, y, y, y) } -> std::same_as<bool>;
};
static_assert(HasTaylorScratch<chain10::Kernels> && HasTaylorScratch<spacecraft_boom::Kernels>);
static_assert(!HasTaylorScratch<double_pendulum::Kernels>);

TYPED_TEST(TaylorKernel, CallerScratchGivesTheSameBits) {
  using Case = TypeParam;
  using G = typename Case::Gen;
  if constexpr (HasTaylorScratch<G>) {
    constexpr int nq = G::nq, order = 12;
    const Sample<Case> s = states<Case>(1).front();
    const Series plain = taylor_at(s, order);
    ASSERT_TRUE(plain.ok);
    for (double garbage : {0.0, nan, 1e300}) {
      Vec qk(nq * (order + 1)), qdk(nq * (order + 1)), work(G::taylor_workspace * (order + 1), garbage),
          scratch(G::taylor_coefficients_workspace, garbage);
      ASSERT_TRUE(G::taylor_coefficients(order, s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), qk.data(),
                                         qdk.data(), work.data(), scratch.data()));
      EXPECT_EQ(0, std::memcmp(qk.data(), plain.qk.data(), qk.size() * sizeof(double))) << garbage;
      EXPECT_EQ(0, std::memcmp(qdk.data(), plain.qdk.data(), qdk.size() * sizeof(double))) << garbage;
    }
  }
}

}  // namespace
