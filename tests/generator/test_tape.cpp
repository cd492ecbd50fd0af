// The recording scalar and the graph: hash-consing, folding, identities, sin/cos, branching,
// select, and the derivative sweeps on small hand-checked expressions.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <eomgen/derive.hpp>
#include <eomgen/graph.hpp>
#include <eomgen/tape.hpp>

namespace {

using namespace eom::gen;

// A graph with a tape recording into it and inputs x = q[0], y = q[1].
struct Fixture : ::testing::Test {
  Graph g;
  Tape tape{g, "model unit (UnitModel)"};
  Tape::Recording recording{tape, "kinetic_energy"};
  Expr x = Expr::node(g.input(InputKind::q, 0));
  Expr y = Expr::node(g.input(InputKind::q, 1));

  double at(const Expr& e, double xv, double yv) {
    Point p;
    p.q = {xv, yv};
    const NodeId out[] = {e.id()};
    return evaluate(g, out, p)[0];
  }
};

using Tape_ = Fixture;

TEST_F(Tape_, HashConsingMakesOneNodePerSubexpression) {
  const Expr a = sin(x * y) + 1.0;
  const Expr b = sin(x * y) + 1.0;
  EXPECT_EQ(a.id(), b.id());
  const std::size_t n = g.size();
  EXPECT_EQ((x * y).id(), (y * x).id()) << "commutative operations are canonical";
  EXPECT_EQ((x + y).id(), (y + x).id());
  (void)(x - y);
  (void)(x - y);
  EXPECT_EQ(g.size(), n + 2);  // x + y and x − y; the rest existed
}

TEST_F(Tape_, ConstantsFold) {
  const Expr c = Expr(2.0) * 3.0 + std::sqrt(4.0);
  EXPECT_TRUE(g.is_const(c.id(), 8.0));
  const Expr s = sin(Expr(0.5));
  EXPECT_TRUE(g.is_const(s.id(), std::sin(0.5)));
  EXPECT_TRUE(g.is_const(atan2(Expr(1.0), Expr(2.0)).id(), std::atan2(1.0, 2.0)));
}

TEST_F(Tape_, Identities) {
  EXPECT_EQ((x + 0.0).id(), x.id());
  EXPECT_EQ((0 + x).id(), x.id());
  EXPECT_EQ((x - 0.0).id(), x.id());
  EXPECT_EQ((x * 1.0).id(), x.id());
  EXPECT_EQ((1 * x).id(), x.id());
  EXPECT_EQ((x * 0.0).id(), Graph::zero);
  EXPECT_EQ((0.0 * sin(x)).id(), Graph::zero);
  EXPECT_EQ((x - x).id(), Graph::zero);
  EXPECT_EQ((x / 1.0).id(), x.id());
  EXPECT_EQ((0.0 / x).id(), Graph::zero);
  EXPECT_EQ((-(-x)).id(), x.id());
  EXPECT_EQ((x + (-y)).id(), (x - y).id());
  EXPECT_EQ((x - (-y)).id(), (x + y).id());
  EXPECT_EQ((x * -1.0).id(), (-x).id());
  EXPECT_EQ(((-x) * (-y)).id(), (x * y).id());
}

TEST_F(Tape_, SmallIntegerPowersAreProducts) {
  EXPECT_EQ(pow(x, 2).id(), (x * x).id());
  EXPECT_EQ(pow(x, 2.0).id(), (x * x).id());
  EXPECT_EQ(pow(x, 1).id(), x.id());
  EXPECT_TRUE(g.is_const(pow(x, 0).id(), 1.0));
  EXPECT_EQ(pow(x, 0.5).id(), sqrt(x).id());
  const Expr x3 = pow(x, 3), xm2 = pow(x, -2);
  EXPECT_EQ(g[x3.id()].op, Op::Mul);
  EXPECT_EQ(g[xm2.id()].op, Op::Div);
  EXPECT_DOUBLE_EQ(at(x3, 1.3, 0), std::pow(1.3, 3));
  EXPECT_DOUBLE_EQ(at(xm2, 1.3, 0), std::pow(1.3, -2));
  EXPECT_DOUBLE_EQ(at(pow(x, 7), 1.1, 0), std::pow(1.1, 7));
  EXPECT_EQ(g[pow(x, 0.75).id()].op, Op::Pow);
  EXPECT_EQ(g[pow(2.0, x).id()].op, Op::Pow);
  EXPECT_EQ(g[pow(x, y).id()].op, Op::Pow);
}

TEST_F(Tape_, SinAndCosOfOneArgumentAreComputedOnce) {
  // The derivative of sin x needs cos x: it is the model's own cos x node, not a second one.
  const Expr s = sin(x), c = cos(x);
  const NodeId wrt[] = {x.id()};
  const auto ds = gradient(g, s.id(), wrt);
  EXPECT_EQ(ds[0], c.id());
  const auto dc = gradient(g, c.id(), wrt);
  EXPECT_EQ(g[dc[0]].op, Op::Neg);
  EXPECT_EQ(g[dc[0]].arg[0], s.id());
  EXPECT_EQ(g.find(Op::Cos, x.id()), c.id()) << "the emitter pairs them through find()";
}

TEST_F(Tape_, ANegatedAngleSharesTheAnglesSineAndCosine) {
  // A joint about −z: sin(−x) = −sin x and cos(−x) = cos x, exactly, so one sincos serves both.
  EXPECT_EQ(sin(-x).id(), (-sin(x)).id());
  EXPECT_EQ(cos(-x).id(), cos(x).id());
  EXPECT_EQ(cos(0.0 - y).id(), cos(y).id());
  for (double v : {0.3, -1.7, 1e5, 3.0e300})
    EXPECT_EQ(at(sin(-x) + cos(-x), v, 0), -std::sin(v) + std::cos(v)) << v;
}

TEST_F(Tape_, BranchingOnATracedValueNamesModelAndFunction) {
  try {
    if (x < y) ADD_FAILURE() << "a comparison converted to bool";
    FAIL() << "no TraceError";
  } catch (const TraceError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("model unit (UnitModel)"), std::string::npos) << m;
    EXPECT_NE(m.find("kinetic_energy"), std::string::npos) << m;
    EXPECT_NE(m.find("eom::select"), std::string::npos) << m;
  }
  {
    Tape::Recording inner(tape, "potential_energy");
    EXPECT_THROW((void)static_cast<bool>(x >= 1.0), TraceError);
    try {
      (void)static_cast<bool>(!(x == y));
    } catch (const TraceError& e) {
      EXPECT_NE(std::string(e.what()).find("potential_energy"), std::string::npos);
    }
  }
  EXPECT_EQ(tape.function(), "kinetic_energy") << "recordings nest";
}

TEST_F(Tape_, SelectIsRecordedAndCorrectOnBothSides) {
  const Expr e = eom::select(x < y, x * y, sin(x));
  EXPECT_EQ(g[e.id()].op, Op::Select);
  EXPECT_DOUBLE_EQ(at(e, 0.3, 0.7), 0.3 * 0.7);
  EXPECT_DOUBLE_EQ(at(e, 0.9, 0.7), std::sin(0.9));
  const Expr f = eom::select(x >= 0.5 && y != 0.0, x, -x);
  EXPECT_DOUBLE_EQ(at(f, 0.6, 1.0), 0.6);
  EXPECT_DOUBLE_EQ(at(f, 0.4, 1.0), -0.4);
  EXPECT_DOUBLE_EQ(at(f, 0.6, 0.0), -0.6);
  // Its derivative is the derivative of the branch taken.
  const NodeId wrt[] = {x.id()};
  const Expr de = Expr::node(gradient(g, e.id(), wrt)[0]);
  EXPECT_DOUBLE_EQ(at(de, 0.3, 0.7), 0.7);
  EXPECT_DOUBLE_EQ(at(de, 0.9, 0.7), std::cos(0.9));
  const Seed seed{x.id(), Graph::one};
  const NodeId outs[] = {e.id()};
  const Expr te = Expr::node(directional(g, outs, std::span(&seed, 1))[0]);
  EXPECT_DOUBLE_EQ(at(te, 0.3, 0.7), 0.7);
  EXPECT_DOUBLE_EQ(at(te, 0.9, 0.7), std::cos(0.9));
  // A select with a constant condition or equal branches is no select at all.
  EXPECT_EQ(eom::select(Expr(1.0) < 2.0, x, y).id(), x.id());
  EXPECT_EQ(eom::select(x < y, y, y).id(), y.id());
}

TEST_F(Tape_, ForwardAndReverseAgreeOnEveryFunction) {
  const Expr f = sin(x) * cos(y) + tan(x / 3) + asin(x / 2) + acos(y / 2) + atan(x * y) + exp(x) +
                 log(1.0 + y * y) + sqrt(2.0 + x) + abs(y - x) + pow(x, 0.75) + pow(2.0, y) +
                 pow(1.5 + x, y) + atan2(y, x) + hypot(x, y) + x / y - 2 * x + 1 - y;
  const NodeId wrt[] = {x.id(), y.id()};
  const auto grad = gradient(g, f.id(), wrt);
  const NodeId outs[] = {f.id()};
  const Seed sx{x.id(), Graph::one}, sy{y.id(), Graph::one};
  const NodeId fx = directional(g, outs, std::span(&sx, 1))[0];
  const NodeId fy = directional(g, outs, std::span(&sy, 1))[0];
  const double xv = 0.7, yv = 0.4, h = 1e-6;
  const Expr gx = Expr::node(grad[0]), gy = Expr::node(grad[1]);
  EXPECT_NEAR(at(gx, xv, yv), at(Expr::node(fx), xv, yv), 1e-13);
  EXPECT_NEAR(at(gy, xv, yv), at(Expr::node(fy), xv, yv), 1e-13);
  EXPECT_NEAR(at(gx, xv, yv), (at(f, xv + h, yv) - at(f, xv - h, yv)) / (2 * h), 1e-8);
  EXPECT_NEAR(at(gy, xv, yv), (at(f, xv, yv + h) - at(f, xv, yv - h)) / (2 * h), 1e-8);
}

TEST_F(Tape_, SubstituteRebuildsAndSimplifies) {
  const Expr e = x * y + sin(y);
  const Seed zero_y{y.id(), Graph::zero};
  const NodeId outs[] = {e.id()};
  EXPECT_EQ(substitute(g, outs, std::span(&zero_y, 1))[0], Graph::zero) << "x·0 + sin 0 = 0";
}

TEST_F(Tape_, PassesAreIterative) {
  // A chain of 200 000 nodes: a recursive pass would overflow the stack.
  Expr e = x;
  for (int i = 0; i < 100000; ++i) e = sin(e) + y;
  const NodeId wrt[] = {x.id()};
  const NodeId d = gradient(g, e.id(), wrt)[0];
  const NodeId outs[] = {d};
  EXPECT_GT(count_ops(g, outs), 100000u);
  EXPECT_TRUE(std::isfinite(at(Expr::node(d), 0.1, 0.2)));
}

TEST(TapeWithoutRecording, ExprNeedsAnActiveTape) {
  EXPECT_THROW(Expr(1.0), TraceError);
  EXPECT_NO_THROW(Expr());
}

}  // namespace
