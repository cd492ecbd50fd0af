// The lowered programs (eomgen/program.hpp): interpreted instruction by instruction from the places
// the emitter prints, they give exactly the values of the graph they were lowered from — split
// into parts with reused workspace slots, with sines and cosines from one call, and with
// parameter-only values read from a cache.
#include <gtest/gtest.h>

#include <algorithm>
#include <optional>
#include <stdexcept>
#include <string>
#include <random>
#include <vector>

#include <eomgen/graph.hpp>
#include <eomgen/trace.hpp>
#include <eomgen/program.hpp>

#include "../../models/chain.hpp"
#include "../../models/spacecraft_boom.hpp"

namespace {

using namespace eom::gen;

Point random_point(const TracedModel& m, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  Point x;
  x.t = u(rng);
  for (int i = 0; i < m.nq; ++i) {
    x.q.push_back(u(rng));
    x.qd.push_back(u(rng));
    x.qdd.push_back(u(rng));
  }
  for (int i = 0; i < m.nu; ++i) x.u.push_back(u(rng));
  for (double v : m.parameter_values) x.p.push_back(v * (1 + 0.1 * u(rng)));
  return x;
}

// Every requested kernel of m, lowered with and without a parameter cache, against evaluate().
void expect_programs_agree(TracedModel& m, std::span<const KernelId> ids) {
  const std::vector<Kernel> kernels = build_kernels(m, ids);
  const Graph& g = m.graph;
  // Cache every real-valued parameter-only operation (more than the emitter caches: the cone must
  // stop at any of them).
  std::vector<int> cached(g.size(), -1);
  std::vector<NodeId> cached_nodes;
  for (NodeId n = 0; n < g.size(); ++n)
    if (arity(g[n].op) > 0 && !is_boolean(g[n].op) && g.parameter_only(n)) {
      cached[n] = static_cast<int>(cached_nodes.size());
      cached_nodes.push_back(n);
    }
  std::mt19937_64 rng(11);
  for (const Kernel& k : kernels) {
    SCOPED_TRACE(std::string(signature(k.id).name));
    const Program plain = lower(g, k, signature(k.id));
    const Program with_cache = lower(g, k, signature(k.id), cached);
    const Program one_function = lower(g, k, signature(k.id), {}, {.split = false, .vector_trig = false});
    Kernel steps = k;  // emitted in the order its statements can start
    steps.by_steps = true;
    const Program by_steps = lower(g, steps, signature(k.id));
    EXPECT_FALSE(one_function.split());
    EXPECT_TRUE(one_function.angles.empty());
    EXPECT_FALSE(plain.reads_cache);
    for (int trial = 0; trial < 5; ++trial) {
      const Point x = random_point(m, rng);
      const std::vector<double> want = evaluate(g, k.outputs, x);
      const std::vector<double> guards = evaluate(g, k.guards, x);
      const bool ok = std::all_of(guards.begin(), guards.end(), [](double v) { return v != 0; });
      const std::vector<double> pc = evaluate(g, cached_nodes, x);
      for (const Program* p : {&plain, &with_cache, &one_function, &by_steps}) {
        const std::optional<std::vector<double>> got = run(*p, x, pc);
        ASSERT_EQ(got.has_value(), ok);
        if (!ok) continue;
        ASSERT_EQ(got->size(), want.size());
        for (std::size_t i = 0; i < want.size(); ++i) EXPECT_EQ((*got)[i], want[i]) << "output " << i;
      }
    }
  }
}

TEST(Program, ChainKernelsGiveTheGraphsValues) {
  using Chain = eom::models::Chain<10>;
  TracedModel m = trace<Chain>("chain10", "Chain<10>");
  const KernelId ids[] = {KernelId::mass_matrix, KernelId::coriolis, KernelId::potential_gradient,
                          KernelId::forward_dynamics, KernelId::inverse_dynamics,
                          KernelId::kinetic_energy};
  expect_programs_agree(m, ids);
}

// forward_dynamics_derivatives of the 10-link chain has several thousand statements: parts,
// workspace slots and their reuse.
TEST(Program, SplitKernelsGiveTheGraphsValues) {
  using Chain = eom::models::Chain<10>;
  TracedModel m = trace<Chain>("chain10", "Chain<10>");
  const KernelId ids[] = {KernelId::forward_dynamics_derivatives, KernelId::mass_matrix_dot};
  expect_programs_agree(m, ids);
  const Program p = lower(m.graph, build_kernels(m, ids)[0], signature(ids[0]));
  EXPECT_GE(p.parts, 5u);
  // values crossing parts share slots once their last reader is done
  std::size_t written = 0;
  for (const Instruction& in : p.code) written += in.to.kind == Place::Kind::workspace;
  EXPECT_GT(p.slots, 0);
  EXPECT_LT(static_cast<std::size_t>(p.slots), written);
}

// A split kernel writes each output where it goes, in the part that computes it (no workspace
// round trip); a repeated value (Ṁ's upper triangle) is copied right after it.
TEST(Program, SplitKernelsWriteTheirOutputsInPlace) {
  using Chain = eom::models::Chain<20>;
  TracedModel m = trace<Chain>("chain20", "Chain<20>");
  const KernelId ids[] = {KernelId::mass_matrix_dot};
  expect_programs_agree(m, ids);
  const Kernel k = build_kernels(m, ids)[0];
  const Program p = lower(m.graph, k, signature(ids[0]));
  ASSERT_TRUE(p.split());
  std::size_t computed = 0, repeated = 0;  // outputs that are operations; those met before
  for (std::size_t i = 0; i < p.outputs.size(); ++i) {
    const NodeId n = k.outputs[i];
    if (arity(m.graph[n].op) == 0) continue;
    ++computed;
    repeated += std::find(k.outputs.begin(), k.outputs.begin() + static_cast<std::ptrdiff_t>(i), n) !=
                k.outputs.begin() + static_cast<std::ptrdiff_t>(i);
    EXPECT_EQ(p.outputs[i].kind, Place::Kind::output) << "output " << i;
    EXPECT_EQ(p.outputs[i].index, static_cast<int>(i));
  }
  EXPECT_GT(repeated, 150u);  // most of the strict upper triangle
  ASSERT_EQ(p.copies.size(), repeated);
  for (std::size_t c = 0; c < p.copies.size(); ++c) {
    const Copy& copy = p.copies[c];
    ASSERT_LT(copy.after, p.code.size());
    const Place& to = p.code[copy.after].to;
    ASSERT_EQ(to.kind, Place::Kind::output);
    EXPECT_LT(to.index, copy.output);  // the first place of the value
    EXPECT_EQ(k.outputs[static_cast<std::size_t>(to.index)], k.outputs[static_cast<std::size_t>(copy.output)]);
    if (c > 0) {
      EXPECT_LE(p.copies[c - 1].after, copy.after);
    }
  }
}

// A constrained model (the guards of the constrained solve), and a 3D one whose
// forward_dynamics is split into parts.
TEST(Program, ConstrainedKernelsGiveTheGraphsValues) {
  TracedModel m = trace<eom::models::ClosedChain5>("closed_chain5", "ClosedChain5");
  ASSERT_GT(m.nc, 0);
  const KernelId ids[] = {KernelId::forward_dynamics, KernelId::constraint_jacobian,
                          KernelId::constraint_bias};
  expect_programs_agree(m, ids);
}

TEST(Program, SpatialKernelsGiveTheGraphsValues) {
  TracedModel m = trace<eom::models::SpacecraftBoom>("spacecraft_boom", "SpacecraftBoom");
  const KernelId ids[] = {KernelId::forward_dynamics, KernelId::mass_matrix};
  expect_programs_agree(m, ids);
}

TEST(Program, SinesAndCosinesOfManyAnglesComeFromOneCall) {
  using Chain = eom::models::Chain<10>;
  TracedModel m = trace<Chain>("chain10", "Chain<10>");
  const KernelId ids[] = {KernelId::mass_matrix};
  const Program p = lower(m.graph, build_kernels(m, ids)[0], signature(KernelId::mass_matrix));
  ASSERT_EQ(p.angles.size(), 10u);
  for (const Place& a : p.angles) EXPECT_EQ(a.kind, Place::Kind::input);
  for (const Instruction& in : p.code)  // no sine or cosine of an input is left to compute
    EXPECT_FALSE((in.op == Op::Sin || in.op == Op::Cos) && in.from[0].kind == Place::Kind::input);
}

// Kernel::by_steps: two independent chains, one made after the other (id order writes them so),
// come out interleaved, each statement after its arguments, with the graph's values; the guard
// last.
TEST(Program, ByStepsInterleavesIndependentChains) {
  Graph g;
  const NodeId x = g.input(InputKind::q, 0), y = g.input(InputKind::q, 1);
  NodeId a = x, b = y;
  for (int i = 0; i < 6; ++i) a = g.mul(a, x);            // steps 1, 2, ..., 6
  for (int i = 0; i < 6; ++i) b = g.add(g.div(b, x), y);  // 4 + 1 steps each
  Kernel k{KernelId::mass_matrix, {a, b}, {g.make(Op::IsFinite, a)}};  // a guard: last
  const Signature& sig = signature(KernelId::mass_matrix);
  const Program by_id = lower(g, k, sig);
  k.by_steps = true;
  const Program by_steps = lower(g, k, sig);
  ASSERT_EQ(by_id.code.size(), 19u);
  ASSERT_EQ(by_steps.code.size(), 19u);
  EXPECT_TRUE(by_steps.code.back().guard);  // by its step it would start seventh
  for (int i = 0; i < 6; ++i) EXPECT_EQ(by_id.code[i].op, Op::Mul) << i;
  // by steps: the first product and the first division start together, the second product and
  // the first sum after them
  EXPECT_EQ(by_steps.code[0].op, Op::Mul);
  EXPECT_EQ(by_steps.code[1].op, Op::Div);
  EXPECT_EQ(by_steps.code[2].op, Op::Mul);
  std::vector<Op> kinds;
  for (const Instruction& in : by_steps.code) kinds.push_back(in.op);
  EXPECT_LT(std::find(kinds.begin(), kinds.end(), Op::Add) - kinds.begin(), 8);  // before a's last
  Point at;
  at.q = {1.25, -0.75};
  const std::vector<double> want = evaluate(g, k.outputs, at);
  for (const Program* p : {&by_id, &by_steps}) {
    const std::optional<std::vector<double>> got = run(*p, at);
    ASSERT_TRUE(got.has_value());
    EXPECT_EQ(*got, want);
  }
}

TEST(Program, AKernelReadingAnInputItsSignatureLacksIsAnError) {
  Graph g;
  const NodeId x = g.input(InputKind::qd, 0);
  const Kernel k{KernelId::mass_matrix, {g.mul(x, x)}, {}};
  EXPECT_THROW(lower(g, k, signature(KernelId::mass_matrix)), std::logic_error);
}

}  // namespace
