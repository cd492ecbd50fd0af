// eom::Reference on a big model from a thread with a small stack (1 MB, less than the main
// thread's 8 MB): its AD numbers live on a heap stack of the thread's own (eom/reference/heap_stack.hpp),
// so it needs no big-stack thread (before, a 32-link chain overflowed any default stack and
// crashed without a message). Each kernel is checked for what it must satisfy, not only for
// running: τ(q̈) = 0 at the forward dynamics, M symmetric and matching its closed form
// (tests/runtime/test_chain.cpp), the derivatives against central differences, and an
// integration. (Not the Taylor coefficients: their jets over 64 variables take 0.5 GB here.)
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

#include <eom/integration/integrate.hpp>
#include <eom/reference/heap_stack.hpp>
#include <eom/reference/reference.hpp>

#include <models/chain.hpp>

#include "chain_mass_matrix.hpp"
#include "thread_stack.hpp"  // run_with_stack (tests/support)

namespace {

constexpr int N = 32;
using Model = eom::models::Chain<N>;
using R = eom::Reference<Model>;
constexpr std::size_t small_stack = std::size_t{1} << 20;

struct Point {
  std::array<double, N> q, qd;
  std::array<double, 4 * N + 1> p;
  Point() : p(R::parameter_values) {
    for (int i = 0; i < N; ++i) {
      q[i] = 0.4 + 0.13 * i;
      qd[i] = 0.3 - 0.07 * i;
    }
  }
};

double max_abs(const double* x, int n) {
  double m = 0;
  for (int i = 0; i < n; ++i) m = std::max(m, std::abs(x[i]));
  return m;
}

// Runs f on a fresh thread with a 1 MB stack; false when the thread could not be started.
template <class F> bool on_small_stack(F f) { return run_with_stack(small_stack, f); }

TEST(ReferenceStack, MassMatrixOnASmallStack) {
  const Point x;
  std::vector<double> M(N * N, 0.0);
  ASSERT_TRUE(on_small_stack([&] { R::mass_matrix(x.q.data(), x.p.data(), M.data()); }));
  EXPECT_LE(chain_mass_matrix_error<N>(x.q.data(), x.p.data(), M.data()), 1e-14);
}

TEST(ReferenceStack, DynamicsAndDerivativesOnASmallStack) {
  const Point x;
  std::vector<double> qdd(N), tau(N), dq(N * N), dqd(N * N), Mdot(N * N), c(N);
  bool fd = false, fdd = false;
  ASSERT_TRUE(on_small_stack([&] {
    fd = R::forward_dynamics(0.25, x.q.data(), x.qd.data(), nullptr, x.p.data(), qdd.data());
    R::inverse_dynamics(0.25, x.q.data(), x.qd.data(), qdd.data(), nullptr, x.p.data(), tau.data());
    R::mass_matrix_dot(x.q.data(), x.qd.data(), x.p.data(), Mdot.data());
    R::coriolis(x.q.data(), x.qd.data(), x.p.data(), c.data());
    fdd = R::forward_dynamics_derivatives(0.25, x.q.data(), x.qd.data(), nullptr, x.p.data(),
                                          dq.data(), dqd.data(), nullptr);
  }));
  ASSERT_TRUE(fd);
  ASSERT_TRUE(fdd);
  // The forward dynamics' q̈ needs no extra force.
  std::vector<double> M(N * N), f(N);
  R::mass_matrix(x.q.data(), x.p.data(), M.data());
  for (int i = 0; i < N; ++i) {
    double s = 0;
    for (int j = 0; j < N; ++j) s += std::abs(M[i + N * j] * qdd[j]);
    f[i] = s + std::abs(c[i]);
  }
  for (int i = 0; i < N; ++i) EXPECT_LE(std::abs(tau[i]), 1e-12 * f[i] + 1e-300) << "tau " << i;
  EXPECT_TRUE(std::all_of(Mdot.begin(), Mdot.end(), [](double v) { return std::isfinite(v); }));
  // ∂q̈/∂q and ∂q̈/∂q̇ against central differences, a few columns.
  for (int j : {0, N / 2, N - 1}) {
    const double h = 1e-6;
    auto at = [&](bool velocity, double s) {
      Point y = x;
      (velocity ? y.qd : y.q)[j] += s;
      std::vector<double> out(N);
      EXPECT_TRUE(R::forward_dynamics(0.25, y.q.data(), y.qd.data(), nullptr, y.p.data(), out.data()));
      return out;
    };
    for (bool velocity : {false, true}) {
      const auto a = at(velocity, h), b = at(velocity, -h);
      const double* column = (velocity ? dqd.data() : dq.data()) + N * j;
      double err = 0;
      for (int i = 0; i < N; ++i) err = std::max(err, std::abs((a[i] - b[i]) / (2 * h) - column[i]));
      EXPECT_LE(err, 1e-6 * std::max(1.0, max_abs(column, N)))
          << (velocity ? "dqdd/dqd" : "dqdd/dq") << " column " << j;
    }
  }
}

TEST(ReferenceStack, IntegratesOnASmallStack) {
  const Point x;
  eom::StateOf<N> x0;
  for (int i = 0; i < N; ++i) x0[i] = x.q[i], x0[N + i] = x.qd[i];
  eom::IntegrationOptions opt;
  opt.method = eom::Method::rk4;
  opt.step = 1e-3;
  eom::IntegrationResult<N> r{};
  ASSERT_TRUE(on_small_stack([&] { r = eom::integrate<R>(0.0, 0.01, x0, nullptr, x.p.data(), opt); }));
  EXPECT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status);
  EXPECT_EQ(r.t, 0.01);
}

#ifdef EOM_HEAP_STACK
// The heap stack is the thread's own: a second thread gets its own region, and a call from inside
// one (a kernel calling a kernel) runs on it directly.
TEST(ReferenceStack, OneRegionPerThreadNestedCallsRunDirectly) {
  const Point x;
  std::vector<double> M(N * N), M2(N * N);
  ASSERT_TRUE(on_small_stack([&] {
    eom::detail::on_heap_stack([&] {
      R::mass_matrix(x.q.data(), x.p.data(), M.data());  // nested: runs on the same region
    });
    R::mass_matrix(x.q.data(), x.p.data(), M2.data());
    EXPECT_GE(eom::detail::HeapStack::of_this_thread().reserved_bytes(), std::size_t{64} << 20);
  }));
  EXPECT_EQ(M, M2);
}
#endif

}  // namespace
