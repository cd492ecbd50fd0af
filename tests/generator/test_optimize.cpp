// The optimize stage (eomgen/optimize.hpp): collected forms that are cheaper and equal in value.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <thread>
#include <vector>

#include <eomgen/graph.hpp>
#include <eomgen/trace.hpp>
#include <eomgen/optimize.hpp>

#include "../../models/chain.hpp"

namespace {

using namespace eom::gen;

TEST(Collect, SineSquaredPlusCosineSquaredIsOne) {
  Graph g;
  const NodeId x = g.input(InputKind::q, 0), m = g.input(InputKind::p, 0);
  const NodeId s = g.make(Op::Sin, x), c = g.make(Op::Cos, x);
  // m·(2 sin x)·sin x + 2 m cos²x = 2m
  const NodeId e = g.add(g.mul(g.mul(m, g.mul(g.constant(2), s)), s),
                         g.mul(g.mul(g.constant(2), m), g.mul(c, c)));
  const NodeId roots[] = {e};
  const std::vector<NodeId> out = collect(g, roots);
  EXPECT_EQ(count_ops(g, out), 1u);
  EXPECT_EQ(out[0], g.mul(g.constant(2), m));
}

TEST(Collect, FactorsACommonCoefficient) {
  Graph g;
  const NodeId a = g.input(InputKind::p, 0), b = g.input(InputKind::p, 1);
  const NodeId x = g.input(InputKind::q, 0), y = g.input(InputKind::q, 1);
  // (a·b)·x + y·(b·a)  ->  (a·b)·(x + y): 3 operations instead of 5
  const NodeId e = g.add(g.mul(g.mul(a, b), x), g.mul(y, g.mul(b, a)));
  const NodeId roots[] = {e};
  EXPECT_EQ(count_ops(g, roots), 4u);
  const std::vector<NodeId> out = collect(g, roots);
  EXPECT_EQ(count_ops(g, out), 3u);
}

// A product of three or more atoms reuses a product of two of them that an earlier output made:
// the spring pendulum's Coriolis terms −m·x·v₁² and 2m·x·v₀·v₁ share x·v₁ (7 operations, as
// SymPy's cse finds; multiplied in id order, x·v₀·v₁ would make x·v₀ and take 8).
TEST(Collect, ReusesAProductOfTwoFactors) {
  Graph g;
  const NodeId m = g.input(InputKind::p, 0), x = g.input(InputKind::q, 0);
  const NodeId v0 = g.input(InputKind::qd, 0), v1 = g.input(InputKind::qd, 1);
  const NodeId c0 = g.neg(g.mul(m, g.mul(g.mul(x, v1), v1)));
  const NodeId c1 = g.mul(g.mul(g.constant(2), m), g.mul(g.mul(x, v0), v1));
  const NodeId roots[] = {c0, c1};
  EXPECT_EQ(count_ops(g, roots), 8u);
  const std::vector<NodeId> out = collect(g, roots);
  EXPECT_EQ(count_ops(g, out), 7u);
}

TEST(Collect, NeverMakesAVectorBigger) {
  Graph g;
  const NodeId x = g.input(InputKind::q, 0), y = g.input(InputKind::q, 1);
  // (x + y)⁴ expands into 5 terms of higher degree: the product form is kept.
  const NodeId s = g.add(x, y), s2 = g.mul(s, s);
  const NodeId roots[] = {g.mul(s2, s2)};
  EXPECT_EQ(collect(g, roots), std::vector<NodeId>(roots, roots + 1));
}

// Random nested sums and products of sin, cos, inputs and parameters: collected and original
// agree to rounding at random points.
TEST(Collect, RandomPolynomialsKeepTheirValues) {
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<int> pick(0, 99);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (int trial = 0; trial < 50; ++trial) {
    Graph g;
    std::vector<NodeId> pool;
    for (int i = 0; i < 3; ++i) {
      const NodeId q = g.input(InputKind::q, i);
      pool.insert(pool.end(), {g.make(Op::Sin, q), g.make(Op::Cos, q), g.input(InputKind::qd, i),
                               g.input(InputKind::p, i)});
    }
    pool.push_back(g.constant(0.5));
    pool.push_back(g.constant(3.0));
    for (int k = 0; k < 40; ++k) {
      const NodeId a = pool[pick(rng) % pool.size()], b = pool[pick(rng) % pool.size()];
      const int r = pick(rng);
      pool.push_back(r < 40 ? g.add(a, b) : r < 60 ? g.sub(a, b) : r < 95 ? g.mul(a, b) : g.neg(a));
    }
    const std::vector<NodeId> roots(pool.end() - 6, pool.end());
    const std::vector<NodeId> out = collect(g, roots);
    Point x;
    for (int i = 0; i < 3; ++i) {
      x.q.push_back(u(rng));
      x.qd.push_back(u(rng));
      x.p.push_back(u(rng));
    }
    const std::vector<double> before = evaluate(g, roots, x), after = evaluate(g, out, x);
    for (std::size_t i = 0; i < roots.size(); ++i)
      EXPECT_NEAR(after[i], before[i], 1e-12 * (1 + std::abs(before[i]))) << "trial " << trial;
  }
}

// The planar chain's mass matrix comes out in the collected O(N²) form a hand coder writes:
// Mⱼₖ = aⱼₖ·(sⱼsₖ + cⱼcₖ) with aⱼₖ a constant once the parameters are fixed. Without collection
// it costs O(N³) operations (943 for N = 10). Counted: the operations per call.
template <int N>
std::size_t mass_matrix_ops(bool fixed) {
  using Chain = eom::models::Chain<N>;
  std::vector<std::optional<double>> values(4 * N + 1);
  if (fixed)
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = Chain::parameter_values[i];
  TracedModel m = trace<Chain>("chain", "Chain", values);
  const KernelId k[] = {KernelId::mass_matrix};
  const std::vector<NodeId> M = build_kernels(m, k)[0].outputs;
  // per call: what depends on p alone is computed once per parameter set
  std::size_t ops = 0;
  for (NodeId n : cone(m.graph, M)) ops += arity(m.graph[n].op) > 0 && !m.graph.parameter_only(n);
  return ops;
}

TEST(Collect, ChainMassMatrixIsQuadraticInTheLinks) {
  const std::size_t ops10 = mass_matrix_ops<10>(true), ops20 = mass_matrix_ops<20>(true);
  std::printf("chain mass_matrix operations, parameters fixed: N = 10: %zu, N = 20: %zu\n", ops10, ops20);
  // N sin/cos pairs plus 4 per entry of the lower triangle below the diagonal
  EXPECT_LE(ops10, 2 * 10 + 4 * 45u);
  EXPECT_LT(static_cast<double>(ops20) / static_cast<double>(ops10), 4.5);
  // with the parameters free, the coefficients aⱼₖ are computed once per parameter set
  EXPECT_LE(mass_matrix_ops<10>(false), 2 * 10 + 4 * 45u);
}

// Each thread's collector allocates from its own pool: two threads may generate at once (a
// process-wide pool, as the stage once had, raced here).
TEST(Collect, TwoThreadsCollectAtOnce) {
  const std::size_t alone = mass_matrix_ops<10>(true);
  std::size_t ops[4] = {};
  std::vector<std::thread> threads;
  for (std::size_t& o : ops) threads.emplace_back([&o] { o = mass_matrix_ops<10>(true); });
  for (std::thread& t : threads) t.join();
  for (std::size_t o : ops) EXPECT_EQ(o, alone);
}

}  // namespace
