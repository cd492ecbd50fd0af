// (b) The recursive algorithms against each other and against finite differences of the energies;
// (c) on the branched robot (rtest::branched_robot: fixed joints into a moving body and into the
// world, a prismatic joint, two branches, file order not topological) and the double pendulum;
// (d) double and long double against dd_real.
#include "recursive_support.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <functional>

namespace {

using namespace rtest;

template <class S>
struct Tol;  // tolerances (the measured figures are in each test's comment)
template <>
struct Tol<double> {
  static constexpr double tight = 1e-13;
};
template <>
struct Tol<dd_real> {
  static constexpr double tight = 1e-28;
};

template <class S>
class RecursiveConsistency : public ::testing::Test {};
using Scalars = ::testing::Types<double, dd_real>;
TYPED_TEST_SUITE(RecursiveConsistency, Scalars);

Robot robot(int which) { return which == 0 ? branched_robot() : DoublePendulum{}.robot(); }

TEST(RecursiveBranched, Tree) {
  eomtest::RecursiveDynamics<double> model(branched_robot());
  ASSERT_EQ(model.nq(), 6);
  const std::vector<std::string> names{"j1", "j2", "j4", "j3", "j5", "j7"};
  EXPECT_EQ(model.coordinate_names(), names);
  const std::vector<int> parents{-1, 0, 3, 1, 0, -1};
  for (int i = 0; i < 6; ++i) EXPECT_EQ(model.parent(i), parents[static_cast<std::size_t>(i)]) << i;
  const std::vector<double> d{0.1, 0.05, 0.03, 0.5, 0.02, 0.0};
  EXPECT_EQ(model.damping(), d);
}

// ABA(q, q̇, RNEA(q, q̇, q̈)) = q̈ at 20 random states per robot.
// Measured (worst normwise): double 1.1e-14 (κ(M) of the branched robot), dd_real 7.7e-31.
TYPED_TEST(RecursiveConsistency, ArticulatedBodyInvertsInverseDynamics) {
  using S = TypeParam;
  double worst = 0;
  for (const int which : {0, 1}) {
    eomtest::RecursiveDynamics<S> model(robot(which));
    const int n = model.nq();
    std::mt19937 rng(11);
    for (int k = 0; k < 20; ++k) {
      const auto q = convert<S>(uniform(rng, n, 2.0)), qd = convert<S>(uniform(rng, n, 1.5)),
                 qdd = convert<S>(uniform(rng, n, 3.0));
      std::vector<S> tau(q.size()), back(q.size());
      model.inverse_dynamics(q, qd, qdd, tau);
      model.articulated_body(q, qd, tau, back);
      worst = std::max(worst, normwise(back, qdd));
    }
  }
  std::printf("ABA(RNEA(qdd)) vs qdd: %.2e\n", worst);
  EXPECT_LE(worst, Tol<S>::tight);
}

// Column k of M (CRBA) = RNEA(q, 0, e_k) − RNEA(q, 0, 0); M symmetric positive definite;
// 2T = q̇ᵀ M q̇; M_ij = 0 for joints on different branches; forward_dynamics(u) =
// articulated_body(u − d⊙q̇).
// Measured: M vs RNEA columns (relative to the column) double 5.9e-16, dd_real 7.9e-32; 2T
// double 7.6e-16, dd_real 7.6e-32; forward vs articulated: exact (same operations).
TYPED_TEST(RecursiveConsistency, MassMatrix) {
  using S = TypeParam;
  double worst_cols = 0, worst_T = 0, worst_fd = 0;
  for (const int which : {0, 1}) {
    eomtest::RecursiveDynamics<S> model(robot(which));
    const int n = model.nq();
    const auto un = static_cast<std::size_t>(n);
    std::mt19937 rng(5);
    for (int k = 0; k < 20; ++k) {
      const auto q = convert<S>(uniform(rng, n, 2.0)), qd = convert<S>(uniform(rng, n, 1.5)),
                 u = convert<S>(uniform(rng, n, 2.0));
      std::vector<S> M(un * un), g(un), col(un), zero(un, S(0.0)), e(un, S(0.0));
      model.mass_matrix(q, M);
      model.gravity_forces(q, g);
      std::vector<S> Mcol(un), diff(un);
      for (std::size_t j = 0; j < un; ++j) {
        e.assign(un, S(0.0));
        e[j] = S(1.0);
        model.inverse_dynamics(q, zero, e, col);
        for (std::size_t i = 0; i < un; ++i) {
          diff[i] = col[i] - g[i];
          Mcol[i] = M[i + un * j];
          EXPECT_EQ(dbl(M[i + un * j]), dbl(M[j + un * i]));
        }
        // relative to the RNEA column itself: the subtraction cancels the gravity torques
        // (~10 N·m against M entries down to ~1e-3), and its rounding is relative to them
        double err = 0, scale = 0;
        for (std::size_t i = 0; i < un; ++i) {
          err = std::max(err, std::abs(dbl(Mcol[i] - diff[i])));
          scale = std::max(scale, std::abs(dbl(col[i])));
        }
        worst_cols = std::max(worst_cols, err / scale);
      }
      // positive definite: Cholesky (in double) succeeds
      std::vector<double> L(un * un, 0.0);
      for (std::size_t j = 0; j < un; ++j) {
        double s = dbl(M[j + un * j]);
        for (std::size_t p = 0; p < j; ++p) s -= L[j + un * p] * L[j + un * p];
        ASSERT_GT(s, 0.0) << "M not positive definite";
        L[j + un * j] = std::sqrt(s);
        for (std::size_t i = j + 1; i < un; ++i) {
          double t = dbl(M[i + un * j]);
          for (std::size_t p = 0; p < j; ++p) t -= L[i + un * p] * L[j + un * p];
          L[i + un * j] = t / L[j + un * j];
        }
      }
      S qMq(0.0);
      for (std::size_t i = 0; i < un; ++i)
        for (std::size_t j = 0; j < un; ++j) qMq += qd[i] * M[i + un * j] * qd[j];
      worst_T = std::max(worst_T, normwise(std::vector<S>{qMq}, std::vector<S>{S(2.0) * model.kinetic_energy(q, qd)}));
      std::vector<S> a(un), b(un), tau(un);
      for (std::size_t i = 0; i < un; ++i) tau[i] = u[i] - model.damping()[i] * qd[i];
      model.forward_dynamics(q, qd, u, a);
      model.articulated_body(q, qd, tau, b);
      worst_fd = std::max(worst_fd, normwise(a, b));
      if (which == 0) {  // branches: {j1 → j2 → j3 → j4, j1 → j5}, {j7}
        for (const auto& [i, j] : {std::pair{1, 4}, {3, 4}, {2, 4}, {5, 0}, {5, 1}, {5, 2}, {5, 3}, {5, 4}}) {
          EXPECT_EQ(dbl(M[static_cast<std::size_t>(i) + un * static_cast<std::size_t>(j)]), 0.0) << i << ' ' << j;
        }
      }
    }
  }
  std::printf("M vs RNEA columns %.2e, 2T vs qd'M qd %.2e, forward vs ABA(u - d qd) %.2e\n",
              worst_cols, worst_T, worst_fd);
  EXPECT_LE(worst_cols, Tol<S>::tight);
  EXPECT_LE(worst_T, Tol<S>::tight);
  EXPECT_LE(worst_fd, Tol<S>::tight);
}

// ---- against finite differences of the energies, in dd_real ---------------------------------
// Fourth-order central differences with h = 1e-6: truncation ~h⁴ = 1e-24 and rounding
// ~1e-32/h = 1e-26, so the differences are good to ~1e-22 (relative to O(1) quantities).
dd_real derivative(const std::function<dd_real(dd_real)>& f) {
  const dd_real h(1e-6);
  return (f(-2.0 * h) - 8.0 * f(-h) + 8.0 * f(h) - f(2.0 * h)) / (12.0 * h);
}

using DD = std::vector<dd_real>;
DD along(const DD& x, const DD& dx, const dd_real& t) {
  DD r(x);
  for (std::size_t i = 0; i < r.size(); ++i) r[i] += t * dx[i];
  return r;
}

// ∂V/∂q (RNEA(q, 0, 0)) against differences of V; RNEA(q, q̇, q̈) against Lagrange's equations
// τ = d/dt(M q̇) − ∂T/∂q + ∂V/∂q with d/dt(M q̇) differenced along q(t) = q + t q̇, q̇(t) = q̇ + t q̈
// (M from CRBA, T and V from their own functions); and the energy balance
// dT/dt + dV/dt = q̇ᵀ(u − d⊙q̇) along the motion (q̈ from forward_dynamics).
// Measured (worst, 10 states per robot): ∂V/∂q 4.8e-25, Lagrange 8.9e-25 (normwise), energy
// balance 6.1e-22 (relative to Σ|q̇ᵢQᵢ|) — a wrong term anywhere would show at O(1).
TEST(RecursiveFiniteDifferences, EnergiesAndLagrange) {
  double worst_V = 0, worst_L = 0, worst_E = 0;
  for (const int which : {0, 1}) {
    eomtest::RecursiveDynamics<dd_real> model(robot(which));
    const int n = model.nq();
    const auto un = static_cast<std::size_t>(n);
    std::mt19937 rng(3);
    for (int k = 0; k < 10; ++k) {
      const DD q = convert<dd_real>(uniform(rng, n, 2.0)), qd = convert<dd_real>(uniform(rng, n, 1.5)),
               qdd = convert<dd_real>(uniform(rng, n, 3.0)), u = convert<dd_real>(uniform(rng, n, 2.0));
      DD g(un), gfd(un), tau(un), lag(un), M(un * un), Mqd(un);
      model.gravity_forces(q, g);
      for (std::size_t j = 0; j < un; ++j) {
        DD e(un, dd_real(0.0));
        e[j] = 1.0;
        gfd[j] = derivative([&](dd_real t) { return model.potential_energy(along(q, e, t)); });
        const dd_real dTdq = derivative([&](dd_real t) { return model.kinetic_energy(along(q, e, t), qd); });
        const dd_real dMqd = derivative([&](dd_real t) {
          const DD qt = along(q, qd, t), qdt = along(qd, qdd, t);
          model.mass_matrix(qt, M);
          dd_real s(0.0);
          for (std::size_t i = 0; i < un; ++i) s += M[j + un * i] * qdt[i];
          return s;
        });
        lag[j] = dMqd - dTdq + gfd[j];
      }
      worst_V = std::max(worst_V, normwise(g, gfd));
      model.inverse_dynamics(q, qd, qdd, tau);
      worst_L = std::max(worst_L, normwise(tau, lag));

      DD acc(un);
      model.forward_dynamics(q, qd, u, acc);
      const dd_real dE = derivative([&](dd_real t) {
        const DD qt = along(q, qd, t), qdt = along(qd, acc, t);
        return model.kinetic_energy(qt, qdt) + model.potential_energy(qt);
      });
      dd_real power(0.0), scale(0.0);
      for (std::size_t i = 0; i < un; ++i) {
        power += qd[i] * (u[i] - model.damping()[i] * qd[i]);
        scale += abs(qd[i] * u[i]) + model.damping()[i] * qd[i] * qd[i];
      }
      // relative to Σ|q̇ᵢ Qᵢ| (the power's terms): the power itself can nearly cancel
      worst_E = std::max(worst_E, to_double(abs(dE - power) / scale));
    }
  }
  std::printf("finite differences (dd_real): dV/dq %.2e, Lagrange %.2e, energy balance %.2e\n",
              worst_V, worst_L, worst_E);
  EXPECT_LE(worst_V, 1e-20);
  EXPECT_LE(worst_L, 1e-20);
  EXPECT_LE(worst_E, 1e-20);
}

// The same energy balance in double with a second-order difference (h = 1e-5: truncation
// ~1e-10, rounding ~1e-11): a quick check that the double model is the same physics.
// Measured: 2.9e-9 (relative to Σ|q̇ᵢQᵢ|).
TEST(RecursiveFiniteDifferences, EnergyBalanceDouble) {
  eomtest::RecursiveDynamics<double> model(branched_robot());
  std::mt19937 rng(9);
  double worst = 0;
  for (int k = 0; k < 10; ++k) {
    const auto q = uniform(rng, 6, 2.0), qd = uniform(rng, 6, 1.5), u = uniform(rng, 6, 2.0);
    std::vector<double> acc(6);
    model.forward_dynamics(q, qd, u, acc);
    const auto E = [&](double t) {
      std::vector<double> qt(q), qdt(qd);
      for (int i = 0; i < 6; ++i) qt[i] += t * qd[i], qdt[i] += t * acc[i];
      return model.kinetic_energy(qt, qdt) + model.potential_energy(qt);
    };
    const double h = 1e-5, dE = (E(h) - E(-h)) / (2 * h);
    double power = 0, scale = 0;
    for (int i = 0; i < 6; ++i) {
      power += qd[i] * (u[i] - model.damping()[i] * qd[i]);
      scale += std::abs(qd[i] * u[i]) + model.damping()[i] * qd[i] * qd[i];
    }
    worst = std::max(worst, std::abs(dE - power) / scale);
  }
  std::printf("energy balance (double, 2nd-order differences): %.2e\n", worst);
  EXPECT_LE(worst, 1e-8);
}

// (d) double and long double against dd_real on the branched robot: M, c + ∂V/∂q, ∂V/∂q, τ,
// q̈ (forward_dynamics), T, V at 20 random states (inputs exactly representable in all three).
// Measured (worst normwise): double 1.1e-15, long double 7.1e-19.
template <class S>
double against_dd(int states) {
  eomtest::RecursiveDynamics<S> lo(branched_robot());
  eomtest::RecursiveDynamics<dd_real> hi(branched_robot());
  const int n = lo.nq();
  const auto un = static_cast<std::size_t>(n);
  std::mt19937 rng(21);
  double worst = 0;
  const auto cmp = [&](const std::vector<S>& a, const DD& b) {
    DD a2;
    for (const S& x : a) a2.push_back(dd_real(static_cast<double>(x)) + dd_real(static_cast<double>(x - static_cast<S>(static_cast<double>(x)))));
    worst = std::max(worst, normwise(a2, b));
  };
  for (int k = 0; k < states; ++k) {
    const auto q = uniform(rng, n, 2.0), qd = uniform(rng, n, 1.5), qdd = uniform(rng, n, 3.0),
               u = uniform(rng, n, 2.0);
    const auto ql = convert<S>(q), qdl = convert<S>(qd), qddl = convert<S>(qdd), ul = convert<S>(u);
    const auto qh = convert<dd_real>(q), qdh = convert<dd_real>(qd), qddh = convert<dd_real>(qdd),
               uh = convert<dd_real>(u);
    std::vector<S> Ml(un * un), xl(un);
    DD Mh(un * un), xh(un);
    lo.mass_matrix(ql, Ml);
    hi.mass_matrix(qh, Mh);
    cmp(Ml, Mh);
    lo.bias_forces(ql, qdl, xl);
    hi.bias_forces(qh, qdh, xh);
    cmp(xl, xh);
    lo.gravity_forces(ql, xl);
    hi.gravity_forces(qh, xh);
    cmp(xl, xh);
    lo.inverse_dynamics(ql, qdl, qddl, xl);
    hi.inverse_dynamics(qh, qdh, qddh, xh);
    cmp(xl, xh);
    lo.forward_dynamics(ql, qdl, ul, xl);
    hi.forward_dynamics(qh, qdh, uh, xh);
    cmp(xl, xh);
    cmp({lo.kinetic_energy(ql, qdl)}, {hi.kinetic_energy(qh, qdh)});
    cmp({lo.potential_energy(ql)}, {hi.potential_energy(qh)});
  }
  return worst;
}

TEST(RecursivePrecision, DoubleAndLongDoubleAgainstDoubleDouble) {
  const double d = against_dd<double>(20), ld = against_dd<long double>(20);
  std::printf("against dd_real: double %.2e, long double %.2e\n", d, ld);
  EXPECT_LE(d, 1e-14);
  EXPECT_LE(ld, 1e-17);
}

}  // namespace
