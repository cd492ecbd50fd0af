// The expression DAG every stage of the generator works on (tape -> derive -> optimize -> emit).
//
// A node is an operation and up to three argument ids. Nodes are hash-consed: make() returns the
// existing id for a node it has seen before, so a common sub-expression is one node and CSE is
// inherent. make() also folds constants and applies the algebraic identities that matter after
// differentiation (x+0, x·1, x·0, x−x, −(−x), small integer powers as products), so derivative
// code that is structurally zero vanishes as it is built.
//
// Ids grow in creation order and an argument is always created before its user: the id order is
// a topological order. Every pass walks ids in a loop (no recursion), so chains with thousands of
// nodes never touch the call stack's depth. Nothing depends on pointer or hash order, so the same
// model always yields the same ids, and the emitted code is byte-identical run to run.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace eom::gen {

using NodeId = std::uint32_t;

// The operations. Each has one entry in the operation table (src/ops/table.hpp), which owns all
// that the generator knows about it: arity, value, derivative, Taylor rule, spelling.
enum class Op : std::uint8_t {
  Const,  // value
  Input,  // arg[0] = InputKind, arg[1] = index
  // real-valued
  Neg, Add, Sub, Mul, Div,
  Sin, Cos, Tan, Tanh, Asin, Acos, Atan, Exp, Log, Sqrt, Abs,
  Pow, Atan2, Hypot,
  Select,  // arg[0] ? arg[1] : arg[2]
  // boolean-valued (conditions for Select, and run-time guards of the forward dynamics)
  Less, LessEqual, Equal, NotEqual, Not, And, Or,
  IsFinite,  // std::isfinite(arg[0])
  PivotOk,   // Cholesky pivot arg[0] is clearly positive relative to its diagonal entry arg[1]
  count      // (the number of operations)
};

// The arguments of a kernel function: the generated signatures name them exactly so. Two are
// internal, in no kernel signature: rhs, the right-hand side given to a solve built once in the
// graph (Taylor mode's order-0 solve at each coefficient, eomgen/taylor.hpp; the articulated-body
// algorithm's τ), and mu, the multipliers the looped form's dense routine computes, which the
// looped derivative kernels read as they read its q̈ (as qdd; eomgen/kernels.hpp). The contact
// kernels' scalars (kd, rho, restitution) are arguments as t is, `double`, not arrays.
enum class InputKind : std::uint8_t { t, q, qd, qdd, u, p, rhs, mu, kd, rho, restitution };
inline constexpr int input_kind_count = 11;
std::string_view name(InputKind k);
// Whether a kernel takes the input as one `double` (t and the contact scalars), not an array.
constexpr bool is_scalar(InputKind k) {
  return k == InputKind::t || k == InputKind::kd || k == InputKind::rho || k == InputKind::restitution;
}

// Facts from the operation table.
int arity(Op op);
bool is_boolean(Op op);  // yields a condition, not a real
std::string_view name(Op op);

// The numeric meaning of every operation; constant folding and the evaluator both use it, so a
// folded constant is the value the emitted code would compute. Booleans are 1.0 / 0.0.
double apply(Op op, double a, double b = 0, double c = 0);

// The relative pivot test (eom::linalg::pivot_ok), for double.
bool pivot_ok(double pivot, double diagonal);

struct Node {
  Op op;
  std::array<NodeId, 3> arg;  // unused slots are 0
  double value;               // Const only; 0 otherwise

  friend bool operator==(const Node& a, const Node& b);
};

class Graph {
 public:
  static constexpr NodeId zero = 0, one = 1;  // present in every graph

  Graph();

  NodeId constant(double v);
  NodeId input(InputKind kind, int index);
  // The node op(a, b, c) after folding and simplification; an existing id when it is known.
  NodeId make(Op op, NodeId a, NodeId b = 0, NodeId c = 0);
  // The id of op(a, b, c) exactly as written, if it exists (no simplification, no insertion).
  std::optional<NodeId> find(Op op, NodeId a, NodeId b = 0, NodeId c = 0) const;

  NodeId add(NodeId a, NodeId b) { return make(Op::Add, a, b); }
  NodeId sub(NodeId a, NodeId b) { return make(Op::Sub, a, b); }
  NodeId mul(NodeId a, NodeId b) { return make(Op::Mul, a, b); }
  NodeId div(NodeId a, NodeId b) { return make(Op::Div, a, b); }
  NodeId neg(NodeId a) { return make(Op::Neg, a); }
  NodeId powi(NodeId a, long long n);  // a^n as products (repeated squaring)

  const Node& operator[](NodeId id) const { return nodes_[id]; }
  std::size_t size() const { return nodes_.size(); }
  bool is_const(NodeId id) const { return nodes_[id].op == Op::Const; }
  bool is_const(NodeId id, double v) const { return is_const(id) && nodes_[id].value == v; }
  // Whether a node depends on nothing but parameters and constants (known when it is made).
  bool parameter_only(NodeId id) const { return parameter_only_[id]; }

 private:
  NodeId intern(const Node& n);
  std::optional<NodeId> simplify(Op op, NodeId a, NodeId b, NodeId c);
  std::size_t slot_of(const Node& n) const;

  std::vector<Node> nodes_;
  std::vector<bool> parameter_only_;
  // The index from a node's contents to its id: open addressing over ids (linear probing, at most
  // half full), each slot's key the node it names, so interning allocates nothing per node.
  static constexpr NodeId empty_slot = ~NodeId{0};
  std::vector<NodeId> slots_;
};

// The nodes the roots depend on (roots included), in ascending id order: a topological order.
std::vector<NodeId> cone(const Graph& g, std::span<const NodeId> roots);

// Operation count: the non-leaf nodes in the cone of the roots (what the emitter writes).
std::size_t count_ops(const Graph& g, std::span<const NodeId> roots);

// The longest chain of dependent operations in the cone of the roots, a division counted as 4
// (its latency, about four additions'): what bounds straight-line code's time where its
// operations do not (a long chain's articulated-body algorithm).
std::size_t dependent_steps(const Graph& g, std::span<const NodeId> roots);
// The steps dependent_steps counts for one operation of op (0 for a leaf).
inline std::size_t step_cost(Op op) { return arity(op) == 0 ? 0 : op == Op::Div ? 4 : 1; }

// A point at which to evaluate a graph: the values of its inputs, by kind.
struct Point {
  double t = 0, kd = 0, rho = 0, restitution = 0;
  std::vector<double> q, qd, qdd, u, p, mu;
};

// The values of `outputs` at `x`, computed in double exactly as the emitted code computes them
// (booleans as 1.0 / 0.0). Lets tests check derived graphs without compiling anything.
std::vector<double> evaluate(const Graph& g, std::span<const NodeId> outputs, const Point& x);

}  // namespace eom::gen
