// The emitted code, compiled (with the project's warnings as errors and -fno-exceptions) and run
// against eom::Reference: the spring pendulum, the Cartesian pendulum (constraints) and a
// 10-link chain whose large kernels the emitter splits into parts. The files come from tracers
// built here by hand, as add_eom_model() builds them. Taylor mode: the emitted
// taylor_coefficients against the generator's own evaluator (eom::gen::taylor_ode, the same
// recurrences interpreted) and against eom::Reference in double-double, on a model that uses
// every operation (ops_model.hpp) and on the split chain.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <models/cartesian_pendulum.hpp>
#include <models/chain.hpp>
#include <eom/model/kernels.hpp>
#include <eom/reference/reference.hpp>
#include <models/spring_pendulum.hpp>

#include <qd/dd_real.h>

#include <eomgen/trace.hpp>
#include <eomgen/taylor.hpp>

#include "chain_model.hpp"
#include "gen_angles.hpp"
#include "gen_cartesian_looped.hpp"
#include "gen_cartesian_pendulum.hpp"
#include "gen_chain10.hpp"
#include "gen_chain10_looped.hpp"
#include "gen_closed_chain5_looped.hpp"
#include "gen_ops_looped.hpp"
#include "gen_ops.hpp"
#include "gen_ops_batch.hpp"
#include "gen_spring_pendulum.hpp"
#include "ops_model.hpp"

namespace {

static_assert(eom::Dynamics<gen_spring_pendulum::Kernels>);
static_assert(eom::Dynamics<gen_cartesian_pendulum::Kernels>);
static_assert(eom::Dynamics<gen_chain10::Kernels>);
static_assert(eom::Dynamics<gen_ops::Kernels>);

using Vec = std::vector<double>;

double relative_error(const Vec& x, const Vec& r) {
  double diff = 0, scale = 1;
  for (std::size_t i = 0; i < r.size(); ++i) {
    diff = std::max(diff, std::abs(x[i] - r[i]));
    scale = std::max(scale, std::abs(r[i]));
  }
  return std::isfinite(diff) ? diff / scale : INFINITY;
}

// Every kernel of G against R at a few generic points (error norm as in differential.hpp).
template <class G, class R> void agree(double tolerance) {
  constexpr int nq = R::nq, nc = R::nc, nu = R::nu;
  static_assert(G::nq == nq && G::nc == nc && G::nu == nu && G::np == R::np);
  const double* p = R::parameter_values.data();
  for (int trial = 0; trial < 3; ++trial) {
    Vec q(nq), qd(nq), qdd(nq), u(nu + 1, 0.3);
    for (int i = 0; i < nq; ++i) {
      q[i] = 0.3 * std::sin(0.7 * i + trial) + 0.6;
      qd[i] = 0.4 * std::cos(1.3 * i - trial);
      qdd[i] = 0.1 * i - 0.2 * trial;
    }
    const double t = 0.1 * trial;
    auto both = [&](const char* what, int n, auto&& g, auto&& r) {
      Vec a(n), b(n);
      g(a.data());
      r(b.data());
      EXPECT_LE(relative_error(a, b), tolerance) << what << ", trial " << trial;
    };
    both("M", nq * nq, [&](double* x) { G::mass_matrix(q.data(), p, x); },
         [&](double* x) { R::mass_matrix(q.data(), p, x); });
    both("Mdot", nq * nq, [&](double* x) { G::mass_matrix_dot(q.data(), qd.data(), p, x); },
         [&](double* x) { R::mass_matrix_dot(q.data(), qd.data(), p, x); });
    both("c", nq, [&](double* x) { G::coriolis(q.data(), qd.data(), p, x); },
         [&](double* x) { R::coriolis(q.data(), qd.data(), p, x); });
    both("dVdq", nq, [&](double* x) { G::potential_gradient(q.data(), p, x); },
         [&](double* x) { R::potential_gradient(q.data(), p, x); });
    both("Q", nq, [&](double* x) { G::generalized_forces(t, q.data(), qd.data(), u.data(), p, x); },
         [&](double* x) { R::generalized_forces(t, q.data(), qd.data(), u.data(), p, x); });
    both("T", 1, [&](double* x) { *x = G::kinetic_energy(q.data(), qd.data(), p); },
         [&](double* x) { *x = R::kinetic_energy(q.data(), qd.data(), p); });
    both("V", 1, [&](double* x) { *x = G::potential_energy(q.data(), p); },
         [&](double* x) { *x = R::potential_energy(q.data(), p); });
    both("qdd", nq, [&](double* x) { EXPECT_TRUE(G::forward_dynamics(t, q.data(), qd.data(), u.data(), p, x)); },
         [&](double* x) { EXPECT_TRUE(R::forward_dynamics(t, q.data(), qd.data(), u.data(), p, x)); });
    both("dqdd", 2 * nq * nq + nq * nu,
         [&](double* x) {
           EXPECT_TRUE(G::forward_dynamics_derivatives(t, q.data(), qd.data(), u.data(), p, x,
                                                       x + nq * nq, x + 2 * nq * nq));
         },
         [&](double* x) {
           EXPECT_TRUE(R::forward_dynamics_derivatives(t, q.data(), qd.data(), u.data(), p, x,
                                                       x + nq * nq, x + 2 * nq * nq));
         });
    both("tau", nq, [&](double* x) { G::inverse_dynamics(t, q.data(), qd.data(), qdd.data(), u.data(), p, x); },
         [&](double* x) { R::inverse_dynamics(t, q.data(), qd.data(), qdd.data(), u.data(), p, x); });
    if constexpr (nc > 0) {
      both("phi", nc, [&](double* x) { G::constraint_residual(q.data(), p, x); },
           [&](double* x) { R::constraint_residual(q.data(), p, x); });
      both("C", nc * nq, [&](double* x) { G::constraint_jacobian(q.data(), p, x); },
           [&](double* x) { R::constraint_jacobian(q.data(), p, x); });
      both("gamma", nc, [&](double* x) { G::constraint_bias(q.data(), qd.data(), p, x); },
           [&](double* x) { R::constraint_bias(q.data(), qd.data(), p, x); });
    }
  }
}

// Parameter-only values are cached per parameter set and thread (docs/CONTRACT.md §3): a kernel
// called with new parameters, back and forth and from several threads at once, agrees with
// eom::Reference at each set, so the cache is refreshed whenever p changes.
TEST(Compiled, ParameterCacheFollowsEveryChangeOfParameters) {
  using G = gen_chain10::Kernels;
  using R = eom::Reference<eomtest::ChainModel<10>>;
  constexpr int nq = G::nq;
  std::vector<Vec> sets;
  for (int k = 0; k < 3; ++k) {
    Vec p(G::parameter_values.begin(), G::parameter_values.end());
    for (std::size_t i = 0; i < p.size(); ++i) p[i] *= 1 + 0.1 * k + 0.01 * static_cast<double>(i % 7);
    sets.push_back(p);
  }
  Vec q(nq), qd(nq);
  for (int i = 0; i < nq; ++i) q[i] = 0.3 * i - 1, qd[i] = 0.2 * std::cos(i);
  std::vector<Vec> expected;
  for (const Vec& p : sets) {
    Vec a(nq);
    EXPECT_TRUE(R::forward_dynamics(0, q.data(), qd.data(), nullptr, p.data(), a.data()));
    expected.push_back(a);
  }
  auto run = [&](int offset, int calls) {
    int bad = 0;
    for (int c = 0; c < calls; ++c) {
      const int k = (c + offset) % 3;
      Vec a(nq), M(nq * nq), Mr(nq * nq);
      bad += !G::forward_dynamics(0, q.data(), qd.data(), nullptr, sets[k].data(), a.data());
      bad += relative_error(a, expected[k]) > 1e-12;
      G::mass_matrix(q.data(), sets[k].data(), M.data());
      R::mass_matrix(q.data(), sets[k].data(), Mr.data());
      bad += relative_error(M, Mr) > 1e-13;
    }
    return bad;
  };
  EXPECT_EQ(run(0, 30), 0);
  int bad[2] = {0, 0};
  std::thread a([&] { bad[0] = run(1, 300); }), b([&] { bad[1] = run(2, 300); });
  a.join();
  b.join();
  EXPECT_EQ(bad[0] + bad[1], 0);
}

TEST(Compiled, SpringPendulumAgreesWithReference) {
  agree<gen_spring_pendulum::Kernels, eom::Reference<eom::models::SpringPendulum>>(1e-13);
}
// A kernel with stack arrays (split into parts, or the looped solve) has an overload taking them
// from the caller: the same bits, whatever the work array held before; the plain signature stays.
TEST(Compiled, CallerOwnedWorkspaceGivesTheSameBits) {
  constexpr int nq = 10;
  static_assert(gen_chain10::forward_dynamics_derivatives_workspace > 0 &&
                gen_chain10_looped::forward_dynamics_workspace > 0);
  Vec q(nq), qd(nq);
  for (int i = 0; i < nq; ++i) q[i] = 0.3 * std::sin(0.7 * i), qd[i] = 0.2 * std::cos(1.3 * i);
  const double* p = gen_chain10::parameter_values.data();
  auto bits = [](const Vec& a, const Vec& b) { return std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0; };
  for (double garbage : {0.0, std::numeric_limits<double>::quiet_NaN(), 1e300}) {
    Vec a(nq), b(nq);
    Vec work(gen_chain10::forward_dynamics_derivatives_workspace, garbage);
    Vec da(nq * nq), dqa(nq * nq), db(nq * nq), dqb(nq * nq);
    ASSERT_TRUE(gen_chain10::forward_dynamics_derivatives(0, q.data(), qd.data(), nullptr, p, da.data(),
                                                          dqa.data(), nullptr));
    ASSERT_TRUE(gen_chain10::forward_dynamics_derivatives(0, q.data(), qd.data(), nullptr, p, db.data(),
                                                          dqb.data(), nullptr, work.data()));
    EXPECT_TRUE(bits(da, db) && bits(dqa, dqb));
    Vec looped(gen_chain10_looped::forward_dynamics_workspace, garbage);
    ASSERT_TRUE(gen_chain10_looped::forward_dynamics(0, q.data(), qd.data(), nullptr, p, a.data()));
    ASSERT_TRUE(gen_chain10_looped::Kernels::forward_dynamics(0, q.data(), qd.data(), nullptr, p, b.data(),
                                                              looped.data()));
    EXPECT_TRUE(bits(a, b));
  }
}

TEST(Compiled, CartesianPendulumAgreesWithReference) {
  agree<gen_cartesian_pendulum::Kernels, eom::Reference<eom::models::CartesianPendulum>>(1e-13);
}
TEST(Compiled, SplitChainAgreesWithReference) {
  using G = gen_chain10::Kernels;
  using R = eom::Reference<eomtest::ChainModel<10>>;
  constexpr int nq = 10;
  Vec q(nq), qd(nq), qdd(nq), a(nq * nq), b(nq * nq);
  for (int i = 0; i < nq; ++i) {
    q[i] = 0.3 * std::sin(0.7 * i);
    qd[i] = 0.2 * std::cos(1.3 * i);
    qdd[i] = 0.1 * i;
  }
  const double* p = R::parameter_values.data();
  G::mass_matrix_dot(q.data(), qd.data(), p, a.data());
  R::mass_matrix_dot(q.data(), qd.data(), p, b.data());
  EXPECT_LE(relative_error(a, b), 1e-13);
  ASSERT_TRUE(G::forward_dynamics(0, q.data(), qd.data(), nullptr, p, a.data()));
  ASSERT_TRUE(R::forward_dynamics(0, q.data(), qd.data(), nullptr, p, b.data()));
  EXPECT_LE(relative_error(Vec(a.begin(), a.begin() + nq), Vec(b.begin(), b.begin() + nq)), 1e-12);
  G::inverse_dynamics(0, q.data(), qd.data(), qdd.data(), nullptr, p, a.data());
  R::inverse_dynamics(0, q.data(), qd.data(), qdd.data(), nullptr, p, b.data());
  EXPECT_LE(relative_error(Vec(a.begin(), a.begin() + nq), Vec(b.begin(), b.begin() + nq)), 1e-13);
  Vec dq(nq * nq), dqd(nq * nq), rq(nq * nq), rqd(nq * nq);
  ASSERT_TRUE(G::forward_dynamics_derivatives(0, q.data(), qd.data(), nullptr, p, dq.data(),
                                              dqd.data(), nullptr));
  ASSERT_TRUE(R::forward_dynamics_derivatives(0, q.data(), qd.data(), nullptr, p, rq.data(),
                                              rqd.data(), nullptr));
  EXPECT_LE(relative_error(dq, rq), 1e-12);
  EXPECT_LE(relative_error(dqd, rqd), 1e-12);

  std::ifstream in(EOMGEN_TEST_GENERATED_DIR "/gen_chain10.cpp");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("forward_dynamics_derivatives_part2("), std::string::npos)
      << "expected the emitter to split this kernel";
}

TEST(Compiled, RejectsNonFiniteInputsAndSingularSystems) {
  const double* p = gen_cartesian_pendulum::parameter_values.data();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  double q[2] = {0.6, -0.5}, qd[2] = {0.1, 0.2}, qdd[2] = {1, 1};
  double bad[2] = {nan, 0.2};
  EXPECT_FALSE(gen_cartesian_pendulum::forward_dynamics(0, bad, qd, nullptr, p, qdd));
  EXPECT_TRUE(std::isnan(qdd[0]) && std::isnan(qdd[1]));
  EXPECT_FALSE(gen_cartesian_pendulum::forward_dynamics(INFINITY, q, qd, nullptr, p, qdd));
  // At the origin the constraint Jacobian vanishes: C M⁻¹ Cᵀ = 0 is singular.
  double origin[2] = {0, 0};
  EXPECT_FALSE(gen_cartesian_pendulum::forward_dynamics(0, origin, qd, nullptr, p, qdd));
  EXPECT_TRUE(std::isnan(qdd[0]));
  double d1[4], d2[4];
  EXPECT_FALSE(gen_cartesian_pendulum::forward_dynamics_derivatives(0, origin, qd, nullptr, p, d1,
                                                                    d2, nullptr));
  EXPECT_TRUE(std::isnan(d1[3]) && std::isnan(d2[0]));
  // A massless spring pendulum: M singular.
  const double massless[4] = {0.0, 75.0, 0.5, 9.81};
  EXPECT_FALSE(gen_spring_pendulum::forward_dynamics(0, q, qd, nullptr, massless, qdd));
  EXPECT_TRUE(gen_spring_pendulum::forward_dynamics(0, q, qd, nullptr,
                                                    gen_spring_pendulum::parameter_values.data(), qdd));
}

// ---- forward_dynamics in the looped form (eomgen/emit.hpp) ----

std::string generated_source(const std::string& name) {
  std::ifstream in(EOMGEN_TEST_GENERATED_DIR "/" + name + ".cpp");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The looped q̈ of G against eom::Reference<Model> at 20 generic states: the two solve the same
// system by the same factorization with sums in another order, so they agree to round-off
// amplified by the conditioning of M (and of C M⁻¹Cᵀ): bound 1e-12 relative.
template <class G, class Model> double looped_against_reference() {
  using R = eom::Reference<Model>;
  constexpr int nq = G::nq;
  const double* p = G::parameter_values.data();
  double worst = 0;
  for (int trial = 0; trial < 20; ++trial) {
    Vec q(nq), qd(nq), a(nq), b(nq), u(G::nu + 1, 0.2);
    for (int i = 0; i < nq; ++i) {
      q[i] = 0.9 * std::sin(0.7 * i + 1.1 * trial) + 0.3;
      qd[i] = 0.8 * std::cos(1.3 * i - 0.6 * trial);
    }
    EXPECT_TRUE(G::forward_dynamics(0.1, q.data(), qd.data(), u.data(), p, a.data()));
    EXPECT_TRUE(R::forward_dynamics(0.1, q.data(), qd.data(), u.data(), p, b.data()));
    worst = std::max(worst, relative_error(a, b));
  }
  return worst;
}

TEST(CompiledLooped, AgreesWithReference) {
  const double chain = looped_against_reference<gen_chain10_looped::Kernels, eomtest::ChainModel<10>>();
  const double cartesian =
      looped_against_reference<gen_cartesian_looped::Kernels, eom::models::CartesianPendulum>();
  const double closed =
      looped_against_reference<gen_closed_chain5_looped::Kernels, eom::models::ClosedChain5>();
  std::printf("  looped forward_dynamics vs Reference: chain10 %.2e, Cartesian pendulum %.2e, "
              "closed chain %.2e\n", chain, cartesian, closed);
  EXPECT_LE(chain, 1e-12);
  EXPECT_LE(cartesian, 1e-12);
  EXPECT_LE(closed, 1e-12);
  // The forms are what they say: the forced one loops, the default one at nq = 10 is unrolled.
  EXPECT_NE(generated_source("gen_chain10_looped").find("solve_dense_system<10, 0>(system, qdd)"),
            std::string::npos);
  EXPECT_NE(generated_source("gen_closed_chain5_looped").find("solve_dense_system<5, 2>(system, qdd)"),
            std::string::npos);
  EXPECT_EQ(generated_source("gen_chain10").find("solve_dense_system"), std::string::npos);
}

// The looped derivative kernels (the right-hand sides as statements at the dense routine's q̈
// and μ, solved on its factors) against eom::Reference<Model>, forward-mode AD through the
// whole forward dynamics: ∂q̈/∂(q, q̇, u) and ∂q̈/∂p at 20 generic states, 1e-11 relative.
template <class G, class Model> double looped_derivatives_against_reference() {
  using R = eom::Reference<Model>;
  constexpr int nq = G::nq, nu = G::nu, np = G::np;
  const double* p = G::parameter_values.data();
  double worst = 0;
  for (int trial = 0; trial < 20; ++trial) {
    Vec q(nq), qd(nq), u(nu + 1, 0.2);
    for (int i = 0; i < nq; ++i) {
      q[i] = 0.9 * std::sin(0.7 * i + 1.1 * trial) + 0.3;
      qd[i] = 0.8 * std::cos(1.3 * i - 0.6 * trial);
    }
    const int n = 2 * nq * nq + nq * nu;
    Vec a(n, 7.0), b(n), ap(nq * np, 7.0), bp(nq * np);
    EXPECT_TRUE(G::forward_dynamics_derivatives(0.1, q.data(), qd.data(), u.data(), p, a.data(),
                                                a.data() + nq * nq, a.data() + 2 * nq * nq));
    EXPECT_TRUE(R::forward_dynamics_derivatives(0.1, q.data(), qd.data(), u.data(), p, b.data(),
                                                b.data() + nq * nq, b.data() + 2 * nq * nq));
    EXPECT_TRUE(G::forward_dynamics_parameter_derivatives(0.1, q.data(), qd.data(), u.data(), p, ap.data()));
    EXPECT_TRUE(R::forward_dynamics_parameter_derivatives(0.1, q.data(), qd.data(), u.data(), p, bp.data()));
    worst = std::max({worst, relative_error(a, b), relative_error(ap, bp)});
  }
  return worst;
}

TEST(CompiledLooped, DerivativesAgreeWithReference) {
  const double chain =
      looped_derivatives_against_reference<gen_chain10_looped::Kernels, eomtest::ChainModel<10>>();
  const double cartesian =
      looped_derivatives_against_reference<gen_cartesian_looped::Kernels, eom::models::CartesianPendulum>();
  const double closed =
      looped_derivatives_against_reference<gen_closed_chain5_looped::Kernels, eom::models::ClosedChain5>();
  const double ops = looped_derivatives_against_reference<gen_ops_looped::Kernels, eomtest::OpsModel>();
  std::printf("  looped derivatives vs Reference: chain10 %.2e, Cartesian pendulum %.2e, closed chain "
              "%.2e, every operation %.2e\n", chain, cartesian, closed, ops);
  EXPECT_LE(chain, 1e-11);
  EXPECT_LE(cartesian, 1e-11);
  EXPECT_LE(closed, 1e-11);
  EXPECT_LE(ops, 1e-11);
  // Looped indeed: the right-hand sides are solved by the routine (∂q̈/∂q, ∂q̈/∂q̇, ∂q̈/∂u).
  const std::string text = generated_source("gen_ops_looped");
  EXPECT_NE(text.find("solve_dense_rows<3, 1, 7>(system, rhs, 3, dqdd_dq);"), std::string::npos);
  EXPECT_NE(text.find("solve_dense_rows<3, 1, 7>(system, rhs + 3, 3, dqdd_dqd);"), std::string::npos);
  EXPECT_NE(text.find("solve_dense_rows<3, 1, 7>(system, rhs + 6, 1, dqdd_du);"), std::string::npos);
  EXPECT_NE(text.find("solve_dense_rows<3, 1, 3>(system, rhs, 3, dqdd_dp);"), std::string::npos);
}

// Where forward_dynamics fails, its looped derivatives fail too (false, every output NaN).
TEST(CompiledLooped, DerivativesFailWhereTheSolveFails) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double* p = gen_cartesian_looped::parameter_values.data();
  double qd[2] = {0.1, 0.2}, bad[2] = {nan, 0.2}, origin[2] = {0, 0};
  for (const double* q : {bad, origin}) {
    double dq[4] = {1, 1, 1, 1}, dqd[4] = {1, 1, 1, 1}, dp[2 * gen_cartesian_looped::np];
    EXPECT_FALSE(gen_cartesian_looped::forward_dynamics_derivatives(0, q, qd, nullptr, p, dq, dqd, nullptr));
    EXPECT_TRUE(std::all_of(dq, dq + 4, [](double v) { return std::isnan(v); }));
    EXPECT_TRUE(std::all_of(dqd, dqd + 4, [](double v) { return std::isnan(v); }));
    EXPECT_FALSE(gen_cartesian_looped::forward_dynamics_parameter_derivatives(0, q, qd, nullptr, p, dp));
    EXPECT_TRUE(std::all_of(std::begin(dp), std::end(dp), [](double v) { return std::isnan(v); }));
  }
}

TEST(CompiledLooped, RejectsNonFiniteInputsAndSingularSystems) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto all_nan = [](const double* x, int n) {
    return std::all_of(x, x + n, [](double v) { return std::isnan(v); });
  };
  {  // the Cartesian pendulum: a NaN input; at the origin C = 0, so C M⁻¹Cᵀ = 0
    const double* p = gen_cartesian_looped::parameter_values.data();
    double qd[2] = {0.1, 0.2}, qdd[2] = {1, 1}, bad[2] = {nan, 0.2}, origin[2] = {0, 0};
    EXPECT_FALSE(gen_cartesian_looped::forward_dynamics(0, bad, qd, nullptr, p, qdd));
    EXPECT_TRUE(all_nan(qdd, 2));
    qdd[0] = qdd[1] = 1;
    EXPECT_FALSE(gen_cartesian_looped::forward_dynamics(0, origin, qd, nullptr, p, qdd));
    EXPECT_TRUE(all_nan(qdd, 2));
  }
  {  // the closed chain at its dead point (straight between pins 5 m apart: C loses rank)
    auto p = gen_closed_chain5_looped::parameter_values;
    p[21] = 5.0;
    double q[5] = {}, qd[5] = {}, qdd[5];
    EXPECT_FALSE(gen_closed_chain5_looped::forward_dynamics(0, q, qd, nullptr, p.data(), qdd));
    EXPECT_TRUE(all_nan(qdd, 5));
  }
  {  // the chain with massless links and no inertia: M = 0 fails the first pivot
    Vec p(gen_chain10_looped::parameter_values.begin(), gen_chain10_looped::parameter_values.end());
    for (int i = 0; i < gen_chain10_looped::np; ++i)
      if (gen_chain10_looped::parameter_names[i][0] != 'g') p[i] = 0;
    Vec q(10, 0.3), qd(10, 0.1), qdd(10, 1.0);
    EXPECT_FALSE(gen_chain10_looped::forward_dynamics(0, q.data(), qd.data(), nullptr, p.data(),
                                                     qdd.data()));
    EXPECT_TRUE(all_nan(qdd.data(), 10));
  }
}

// ---- Taylor mode ----

// A state of model G: q, q̇ near the traced point's scale, u, p at their defaults, t.
struct TaylorCase {
  double t;
  Vec q, qd, u, p;
};
template <class G> std::vector<TaylorCase> taylor_cases() {
  std::vector<TaylorCase> cs;
  for (int trial = 0; trial < 3; ++trial) {
    TaylorCase c{0.3 + 0.4 * trial, Vec(G::nq), Vec(G::nq), Vec(G::nu + 1, 0.7 - 0.2 * trial),
                 Vec(G::parameter_values.begin(), G::parameter_values.end())};
    for (int i = 0; i < G::nq; ++i) {
      c.q[i] = 0.3 * std::sin(0.7 * i + trial) + 0.2;
      c.qd[i] = 0.5 * std::cos(1.3 * i - trial);
    }
    cs.push_back(c);
  }
  return cs;
}

template <class G> std::array<Vec, 2> generated_taylor(const TaylorCase& c, int order) {
  Vec qk(G::nq * (order + 1)), qdk(G::nq * (order + 1)), work(G::taylor_workspace * (order + 1));
  EXPECT_TRUE(G::taylor_coefficients(order, c.t, c.q.data(), c.qd.data(), c.u.data(), c.p.data(),
                                     qk.data(), qdk.data(), work.data()));
  return {qk, qdk};
}

// The emitted kernel and the evaluator run the same operations in the same order (taylor.hpp):
// they agree to the last bit unless a compiler contracts a*b + c into one fused operation, whose
// differences the recurrences carry on: bound 1e-13 relative per order (measured: 0; 4.3e-15 for
// the split 10-link chain).
template <class G, class Model>
void taylor_matches_evaluator(const char* name, eom::gen::SolveForm form = eom::gen::SolveForm::automatic) {
  using namespace eom::gen;
  TracedModel m = trace<Model>(name, name);
  const std::vector<KernelId> ks{KernelId::taylor_coefficients};
  const Kernel k = build_kernels(m, ks, form).at(0);
  EXPECT_EQ(k.looped, form == SolveForm::looped) << name;
  constexpr int order = 20, nq = G::nq;
  double worst = 0;
  for (const TaylorCase& c : taylor_cases<G>()) {
    Point x;
    x.t = c.t;
    x.q = c.q;
    x.qd = c.qd;
    x.u = Vec(c.u.begin(), c.u.begin() + G::nu);
    x.p = c.p;
    const auto expected = taylor_ode(m.graph, *k.system, x, order);
    const auto got = generated_taylor<G>(c, order);
    for (int which = 0; which < 2; ++which)
      for (int j = 0; j <= order; ++j) {
        double diff = 0, scale = 0;
        for (int i = 0; i < nq; ++i) {
          diff = std::max(diff, std::abs(got[which][j * nq + i] - expected[which][j * nq + i]));
          scale = std::max(scale, std::abs(expected[which][j * nq + i]));
        }
        const double e = diff / std::max(scale, 1e-300);
        worst = std::max(worst, e);
        EXPECT_LE(e, 1e-13) << name << (which ? " qdk" : " qk") << " order " << j;
      }
  }
  std::printf("  %s: generated taylor_coefficients against taylor_ode: worst relative error %.2e\n",
              name, worst);
}

TEST(CompiledTaylor, EveryOperationRunsTheEvaluatorsRecurrences) {
  taylor_matches_evaluator<gen_ops::Kernels, eomtest::OpsModel>("ops");
}
TEST(CompiledTaylor, SplitChainRunsTheEvaluatorsRecurrences) {
  taylor_matches_evaluator<gen_chain10::Kernels, eomtest::ChainModel<10>>("chain10");
  std::ifstream in(EOMGEN_TEST_GENERATED_DIR "/gen_chain10.cpp");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("taylor_coefficients_order0_part2("), std::string::npos)
      << "expected the emitter to split the Taylor kernel";
}

// Against eom::Reference<Model, dd_real> (Taylor arithmetic by operator overloading on the
// model source, ~1e-32), to `order`: the worst error / (1 + k) over the orders k ≥ 1. Norm per
// order as in tests/taylor: max_i |gen − truth| / max_i |truth|; coefficient k sums ~k products
// of lower ones and the dynamics' conditioning amplifies that, hence the 1 + k.
template <class G, class Model> double taylor_against_reference(int order) {
  using Truth = eom::Reference<Model, dd_real>;
  constexpr int nq = G::nq;
  double worst = 0;
  for (const TaylorCase& c : taylor_cases<G>()) {
    const auto got = generated_taylor<G>(c, order);
    std::vector<dd_real> q(c.q.begin(), c.q.end()), qd(c.qd.begin(), c.qd.end()),
        u(c.u.begin(), c.u.end()), p(c.p.begin(), c.p.end()), tk(nq * (order + 1)),
        tdk(nq * (order + 1));
    EXPECT_TRUE(Truth::taylor_coefficients(order, dd_real(c.t), q.data(), qd.data(), u.data(),
                                           p.data(), tk.data(), tdk.data(), nullptr));
    for (int which = 0; which < 2; ++which)
      for (int j = 1; j <= order; ++j) {
        double diff = 0, scale = 0;
        for (int i = 0; i < nq; ++i) {
          const dd_real truth = which ? tdk[j * nq + i] : tk[j * nq + i];
          diff = std::max(diff, std::abs(to_double(got[which][j * nq + i] - truth)));
          scale = std::max(scale, std::abs(to_double(truth)));
        }
        worst = std::max(worst, diff / scale / (1 + j));
      }
  }
  return worst;
}

// Every rule inside the dynamics, to order 20: bound 1e-14 (1 + k) (measured 7.4e-16 (1 + k)).
TEST(CompiledTaylor, EveryOperationAgainstTheReferenceInDoubleDouble) {
  const double worst = taylor_against_reference<gen_ops::Kernels, eomtest::OpsModel>(20);
  std::printf("  ops: generated against Reference<dd_real>: worst error / (1 + k) %.2e\n", worst);
  EXPECT_LE(worst, 1e-14);
}

// The looped Taylor kernels (the dense routine's solve at order 0, its factors for every
// coefficient), to order 16, with the same bound.
TEST(CompiledLooped, TaylorAgreesWithReference) {
  const double chain = taylor_against_reference<gen_chain10_looped::Kernels, eomtest::ChainModel<10>>(16);
  const double cartesian =
      taylor_against_reference<gen_cartesian_looped::Kernels, eom::models::CartesianPendulum>(16);
  const double closed =
      taylor_against_reference<gen_closed_chain5_looped::Kernels, eom::models::ClosedChain5>(16);
  const double ops = taylor_against_reference<gen_ops_looped::Kernels, eomtest::OpsModel>(16);
  std::printf("  looped taylor_coefficients vs Reference<dd_real>, worst error / (1 + k): chain10 %.2e, "
              "Cartesian pendulum %.2e, closed chain %.2e, every operation %.2e\n",
              chain, cartesian, closed, ops);
  EXPECT_LE(chain, 1e-14);
  EXPECT_LE(cartesian, 1e-14);
  EXPECT_LE(closed, 1e-14);
  EXPECT_LE(ops, 1e-14);
  const std::string text = generated_source("gen_closed_chain5_looped");
  EXPECT_NE(text.find("solve_dense_columns<5, 2>(dense, dense + "), std::string::npos);
}

// ... and run the evaluator's steps: the dense routine's text, compiled into the generator with
// run-time sizes, in taylor_ode.
TEST(CompiledLooped, TaylorRunsTheEvaluatorsSteps) {
  using eom::gen::SolveForm;
  taylor_matches_evaluator<gen_chain10_looped::Kernels, eomtest::ChainModel<10>>("chain10 looped", SolveForm::looped);
  taylor_matches_evaluator<gen_cartesian_looped::Kernels, eom::models::CartesianPendulum>("Cartesian looped",
                                                                                          SolveForm::looped);
  taylor_matches_evaluator<gen_closed_chain5_looped::Kernels, eom::models::ClosedChain5>("closed chain looped",
                                                                                         SolveForm::looped);
  taylor_matches_evaluator<gen_ops_looped::Kernels, eomtest::OpsModel>("ops looped", SolveForm::looped);
}

// forward_dynamics_batch prints every operation for vector lanes (constants broadcast where an
// operator needs a vector; sin and cos paired; select on lane masks): on the ops model, lane by
// lane, it equals the scalar kernel bitwise, spoiled lanes (NaN in t, Inf in u) fail alone.
TEST(CompiledBatch, EveryOperationLaneByLaneEqualsTheScalarKernel) {
  using S = gen_ops::Kernels;
  using B = gen_ops_batch::Kernels;
  constexpr int W = B::batch_lanes, nq = S::nq, nu = S::nu, np = S::np;
  std::mt19937_64 rng(16);
  std::uniform_real_distribution<double> x(-1.0, 1.0);
  int good = 0;
  for (int call = 0; call < 50; ++call) {
    std::vector<double> t(W), q(nq * W), qd(nq * W), u(nu * W), p(np * W), qdd(nq * W);
    std::vector<std::vector<double>> lane(W);
    for (int l = 0; l < W; ++l) {
      t[l] = 2 * x(rng);
      for (int i = 0; i < nq; ++i) q[i * W + l] = x(rng), qd[i * W + l] = 2 * x(rng);
      for (int i = 0; i < nu; ++i) u[i * W + l] = x(rng);
      for (int i = 0; i < np; ++i) p[i * W + l] = S::parameter_values[i] * (1 + 0.3 * x(rng));
    }
    if (call % 5 == 1) t[call % W] = std::numeric_limits<double>::quiet_NaN();
    if (call % 5 == 2) u[(call + 1) % W] = std::numeric_limits<double>::infinity();
    const unsigned mask = B::forward_dynamics_batch(t.data(), q.data(), qd.data(), u.data(),
                                                    p.data(), qdd.data());
    for (int l = 0; l < W; ++l) {
      Vec ql(nq), qdl(nq), ul(nu), pl(np), expected(nq);
      for (int i = 0; i < nq; ++i) ql[i] = q[i * W + l], qdl[i] = qd[i * W + l];
      for (int i = 0; i < nu; ++i) ul[i] = u[i * W + l];
      for (int i = 0; i < np; ++i) pl[i] = p[i * W + l];
      const bool ok = S::forward_dynamics(t[l], ql.data(), qdl.data(), ul.data(), pl.data(),
                                          expected.data());
      ASSERT_EQ(((mask >> l) & 1u) != 0, ok) << "call " << call << ", lane " << l;
      good += ok;
      for (int i = 0; i < nq; ++i) {
        if (!ok) {
          EXPECT_TRUE(std::isnan(qdd[i * W + l]));
          continue;
        }
#if defined(__FMA__)
        EXPECT_NEAR(qdd[i * W + l], expected[i], 1e-14 * (1 + std::abs(expected[i])));
#else
        EXPECT_EQ(qdd[i * W + l], expected[i])
            << "call " << call << ", lane " << l << ", qdd " << i;
#endif
      }
    }
  }
  EXPECT_GT(good, 150);
}


// The generated source's sines and cosines of the inputs (its sincos_n: fdlibm's reduction and
// polynomials, vectorized): within 1 ulp of double-double ones for |x| < 1e5 (0.78 measured),
// std::sin's and std::cos's bits beyond; the batch kernel's lanes have the scalar kernel's bits.
TEST(CompiledAngles, SinesAndCosinesWithinOneUlpAndLanesBitwise) {
  using K = gen_angles::Kernels;
  constexpr int W = K::batch_lanes;
  constexpr double pi = std::numbers::pi;
  std::mt19937_64 rng(50);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-30, 17);
  const double m[] = {1.0}, qd[8] = {};
  double worst = 0;
  auto ulps = [](double got, const dd_real& exact) {
    const double r = std::abs(to_double(exact));
    return std::abs(to_double(dd_real(got) - exact)) / (std::nextafter(r, 2 * r + 1) - r);
  };
  for (int call = 0; call < 5000; ++call) {
    std::vector<double> q(8 * W), qdd(8 * W), lanes_q(8 * W, 0.0), lanes_qd(8 * W, 0.0),
        lanes_m(W, 1.0), t(W, 0.0);
    for (int l = 0; l < W; ++l)
      for (int i = 0; i < 4; ++i) {
        double& x = q[8 * l + i];
        x = call == 0 ? std::array{pi / 2, -pi, 3 * pi / 4, -0.0}[i] * (l + 1)
            : call % 50 == 1 ? unit(rng) * 1e9  // beyond 1e5: std::sin and std::cos
                             : std::ldexp(unit(rng), exponent(rng));
        lanes_q[i * W + l] = x;
      }
    const unsigned mask = K::forward_dynamics_batch(t.data(), lanes_q.data(), lanes_qd.data(), nullptr,
                                                    lanes_m.data(), qdd.data());
    ASSERT_EQ(mask, (1u << W) - 1);
    for (int l = 0; l < W; ++l) {
      double x[8];
      ASSERT_TRUE(K::forward_dynamics(0.0, &q[8 * l], qd, nullptr, m, x));
      for (int i = 0; i < 8; ++i)
        EXPECT_EQ(std::bit_cast<std::uint64_t>(qdd[i * W + l]), std::bit_cast<std::uint64_t>(x[i]));
      for (int i = 0; i < 4; ++i) {
        const double a = q[8 * l + i];
        if (std::abs(a) >= 1e5) {
          EXPECT_EQ(x[i], std::sin(a));
          EXPECT_EQ(x[4 + i], std::cos(a));
          continue;
        }
        worst = std::max({worst, ulps(x[i], sin(dd_real(a))), ulps(x[4 + i], cos(dd_real(a)))});
      }
    }
  }
  EXPECT_LE(worst, 1.0);
  std::printf("sincos_n: worst %.2f ulp\n", worst);
}

}  // namespace
