#include "eomgen/graph.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include <eom/numeric/linalg.hpp>

#include "ops/table.hpp"

namespace eom::gen {

std::string_view name(InputKind k) {
  switch (k) {
    case InputKind::t: return "t";
    case InputKind::q: return "q";
    case InputKind::qd: return "qd";
    case InputKind::qdd: return "qdd";
    case InputKind::u: return "u";
    case InputKind::p: return "p";
    case InputKind::rhs: return "rhs";
    case InputKind::mu: return "mu";
    case InputKind::kd: return "kd";
    case InputKind::rho: return "rho";
    case InputKind::restitution: return "restitution";
  }
  return "?";
}

int arity(Op op) { return ops::info(op).arity; }
bool is_boolean(Op op) { return ops::info(op).kind == ops::Kind::boolean; }
std::string_view name(Op op) { return ops::info(op).name; }

bool pivot_ok(double pivot, double diagonal) { return linalg::pivot_ok(pivot, diagonal); }

double apply(Op op, double a, double b, double c) {
  const auto eval = ops::info(op).eval;
  if (!eval) throw std::logic_error("eomgen: apply() on a leaf node");
  return eval(a, b, c);
}

bool operator==(const Node& a, const Node& b) {
  // Constants compare by bit pattern: -0.0 and 0.0 stay distinct, a NaN equals itself.
  return a.op == b.op && a.arg == b.arg &&
         std::bit_cast<std::uint64_t>(a.value) == std::bit_cast<std::uint64_t>(b.value);
}

namespace {
std::uint64_t hash(const Node& n) {
  std::uint64_t h = static_cast<std::uint64_t>(n.op) * 0x9E3779B97F4A7C15ull;
  auto mix = [&h](std::uint64_t x) { h = (h ^ x) * 0x100000001B3ull + (h >> 29); };
  mix(n.arg[0]);
  mix(n.arg[1]);
  mix(n.arg[2]);
  mix(std::bit_cast<std::uint64_t>(n.value));
  h ^= h >> 33;  // the low bits pick the slot: let every bit reach them
  h *= 0xFF51AFD7ED558CCDull;
  return h ^ (h >> 33);
}
}  // namespace

Graph::Graph() : slots_(1024, empty_slot) {
  intern(Node{Op::Const, {0, 0, 0}, 0.0});
  intern(Node{Op::Const, {0, 0, 0}, 1.0});
}

// The slot holding n, or the empty slot where it would go.
std::size_t Graph::slot_of(const Node& n) const {
  const std::size_t mask = slots_.size() - 1;
  for (std::size_t i = hash(n) & mask;; i = (i + 1) & mask)
    if (slots_[i] == empty_slot || nodes_[slots_[i]] == n) return i;
}

NodeId Graph::intern(const Node& n) {
  std::size_t at = slot_of(n);
  if (slots_[at] != empty_slot) return slots_[at];
  if (nodes_.size() >= std::numeric_limits<NodeId>::max() - 1)
    throw std::length_error("eomgen: expression graph too large");
  const auto id = static_cast<NodeId>(nodes_.size());
  nodes_.push_back(n);
  // of p alone: constants, inputs p, and operations on those only
  bool p = n.op != Op::Input || static_cast<InputKind>(n.arg[0]) == InputKind::p;
  for (int i = 0; i < arity(n.op); ++i) p = p && parameter_only_[n.arg[i]];
  parameter_only_.push_back(p);
  if (2 * nodes_.size() > slots_.size()) {  // keep it at most half full: rebuild twice as large
    slots_.assign(2 * slots_.size(), empty_slot);
    for (NodeId k = 0; k < nodes_.size(); ++k) slots_[slot_of(nodes_[k])] = k;
  } else {
    slots_[at] = id;
  }
  return id;
}

NodeId Graph::constant(double v) { return intern(Node{Op::Const, {0, 0, 0}, v}); }

NodeId Graph::input(InputKind kind, int index) {
  return intern(Node{Op::Input, {static_cast<NodeId>(kind), static_cast<NodeId>(index), 0}, 0.0});
}

std::optional<NodeId> Graph::find(Op op, NodeId a, NodeId b, NodeId c) const {
  const NodeId id = slots_[slot_of(Node{op, {a, b, c}, 0.0})];
  if (id == empty_slot) return std::nullopt;
  return id;
}

NodeId Graph::powi(NodeId a, long long n) {
  if (n < 0) return div(one, powi(a, -n));
  NodeId r = one;
  while (n) {
    if (n & 1) r = mul(r, a);
    n >>= 1;
    if (n) a = mul(a, a);
  }
  return r;
}

NodeId Graph::make(Op op, NodeId a, NodeId b, NodeId c) {
  const int n = arity(op);
  if (n == 0) throw std::logic_error("eomgen: make() of a leaf; use constant() or input()");
  if (n < 3) c = 0;
  if (n < 2) b = 0;
  if (a >= size() || b >= size() || c >= size())
    throw std::logic_error("eomgen: make() with an argument that is not a node of this graph");
  // Constant folding.
  if (is_const(a) && (n < 2 || is_const(b)) && (n < 3 || is_const(c)))
    return constant(apply(op, nodes_[a].value, nodes_[b].value, nodes_[c].value));
  if (auto s = simplify(op, a, b, c)) return *s;
  // Canonical order for commutative operations, so a·b and b·a are one node.
  if (ops::info(op).commutative && b < a) std::swap(a, b);
  return intern(Node{op, {a, b, c}, 0.0});
}

// The identities that keep derivative graphs small. Each returns an equivalent existing (or
// simpler) node; IEEE special cases (x·0 with x infinite) follow the algebra, as every symbolic
// differentiator does.
std::optional<NodeId> Graph::simplify(Op op, NodeId a, NodeId b, NodeId c) {
  const Node na = nodes_[a], nb = nodes_[b];  // copies: make() below may grow nodes_
  switch (op) {
    case Op::Neg:
      if (na.op == Op::Neg) return na.arg[0];                       // −(−x) = x
      if (na.op == Op::Sub) return make(Op::Sub, na.arg[1], na.arg[0]);  // −(x−y) = y−x
      break;
    case Op::Add:
      if (is_const(a, 0)) return b;
      if (is_const(b, 0)) return a;
      if (nb.op == Op::Neg) return make(Op::Sub, a, nb.arg[0]);  // x + (−y) = x − y
      if (na.op == Op::Neg) return make(Op::Sub, b, na.arg[0]);
      if (a == b) return make(Op::Mul, constant(2), a);  // so that constant factors can merge
      break;
    case Op::Sub:
      if (a == b) return zero;
      if (is_const(b, 0)) return a;
      if (is_const(a, 0)) return make(Op::Neg, b);
      if (nb.op == Op::Neg) return make(Op::Add, a, nb.arg[0]);  // x − (−y) = x + y
      break;
    case Op::Mul:
      if (is_const(a, 0) || is_const(b, 0)) return zero;
      if (is_const(a, 1)) return b;
      if (is_const(b, 1)) return a;
      if (is_const(a, -1)) return make(Op::Neg, b);
      if (is_const(b, -1)) return make(Op::Neg, a);
      // Signs move outward, where Add/Sub absorb them: (−x)·y = −(x·y).
      if (na.op == Op::Neg && nb.op == Op::Neg) return make(Op::Mul, na.arg[0], nb.arg[0]);
      if (na.op == Op::Neg) return make(Op::Neg, make(Op::Mul, na.arg[0], b));
      if (nb.op == Op::Neg) return make(Op::Neg, make(Op::Mul, a, nb.arg[0]));
      // Constant factors merge: c·(d·x) = (cd)·x, e.g. 2·(½·m) = m.
      for (auto [c, x] : {std::pair{na, nb}, std::pair{nb, na}})
        if (c.op == Op::Const && x.op == Op::Mul)
          for (int i = 0; i < 2; ++i)
            if (is_const(x.arg[i]))
              return make(Op::Mul, constant(c.value * nodes_[x.arg[i]].value), x.arg[1 - i]);
      break;
    case Op::Div:
      if (is_const(a, 0)) return zero;
      if (is_const(b, 1)) return a;
      if (is_const(b, -1)) return make(Op::Neg, a);
      if (a == b) return one;
      if (na.op == Op::Neg) return make(Op::Neg, make(Op::Div, na.arg[0], b));
      if (nb.op == Op::Neg) return make(Op::Neg, make(Op::Div, a, nb.arg[0]));
      break;
    // sin is odd and cos even, exactly (libm reduces |x|): a negated angle (a joint about −z)
    // then shares its sine and cosine, one sincos call, with the angle itself.
    case Op::Sin:
      if (na.op == Op::Neg) return make(Op::Neg, make(Op::Sin, na.arg[0]));
      break;
    case Op::Cos:
      if (na.op == Op::Neg) return make(Op::Cos, na.arg[0]);
      break;
    case Op::Pow:
      if (is_const(b)) {
        const double r = nb.value;
        if (r == std::nearbyint(r) && std::abs(r) <= 64) return powi(a, static_cast<long long>(r));
        if (r == 0.5) return make(Op::Sqrt, a);
      }
      if (is_const(a, 1)) return one;
      break;
    case Op::Select:
      if (is_const(a)) return na.value != 0 ? b : c;
      if (b == c) return b;
      if (na.op == Op::Not) return make(Op::Select, na.arg[0], c, b);
      break;
    case Op::Not:
      if (na.op == Op::Not) return na.arg[0];
      break;
    case Op::And:
      if (is_const(a)) return na.value != 0 ? b : zero;
      if (is_const(b)) return nb.value != 0 ? a : zero;
      if (a == b) return a;
      break;
    case Op::Or:
      if (is_const(a)) return na.value != 0 ? one : b;
      if (is_const(b)) return nb.value != 0 ? one : a;
      if (a == b) return a;
      break;
    default: break;
  }
  return std::nullopt;
}

std::vector<NodeId> cone(const Graph& g, std::span<const NodeId> roots) {
  std::vector<char> seen(g.size(), 0);
  std::vector<NodeId> stack(roots.begin(), roots.end()), order;
  while (!stack.empty()) {
    const NodeId n = stack.back();
    stack.pop_back();
    if (seen[n]) continue;
    seen[n] = 1;
    order.push_back(n);
    for (int i = 0; i < arity(g[n].op); ++i) stack.push_back(g[n].arg[i]);
  }
  // Id order: a small cone of a big graph (one direction of a derivative kernel) is sorted; a
  // large one is read off the marks, which is cheaper than sorting it.
  if (order.size() < g.size() / 16) {
    std::sort(order.begin(), order.end());
    return order;
  }
  order.clear();
  for (NodeId n = 0; n < g.size(); ++n)
    if (seen[n]) order.push_back(n);
  return order;
}

std::size_t count_ops(const Graph& g, std::span<const NodeId> roots) {
  std::size_t count = 0;
  for (NodeId n : cone(g, roots)) count += arity(g[n].op) > 0;
  return count;
}

std::size_t dependent_steps(const Graph& g, std::span<const NodeId> roots) {
  std::vector<std::size_t> depth(g.size(), 0);
  std::size_t longest = 0;
  for (NodeId n : cone(g, roots)) {  // arguments first
    const Node& x = g[n];
    std::size_t d = 0;
    for (int i = 0; i < arity(x.op); ++i) d = std::max(d, depth[x.arg[i]]);
    depth[n] = d + step_cost(x.op);
    longest = std::max(longest, d);
  }
  return longest;
}

std::vector<double> evaluate(const Graph& g, std::span<const NodeId> outputs, const Point& x) {
  const std::vector<NodeId> order = cone(g, outputs);
  std::vector<double> value(g.size(), 0.0);
  for (NodeId n : order) {
    const Node& node = g[n];
    if (node.op == Op::Const) {
      value[n] = node.value;
    } else if (node.op == Op::Input) {
      const auto kind = static_cast<InputKind>(node.arg[0]);
      const std::size_t i = node.arg[1];
      auto at = [&](const std::vector<double>& v) {
        if (i >= v.size())
          throw std::out_of_range("eomgen: evaluate() needs " + std::string(name(kind)) + "[" +
                                  std::to_string(i) + "]");
        return v[i];
      };
      switch (kind) {
        case InputKind::t: value[n] = x.t; break;
        case InputKind::q: value[n] = at(x.q); break;
        case InputKind::qd: value[n] = at(x.qd); break;
        case InputKind::qdd: value[n] = at(x.qdd); break;
        case InputKind::u: value[n] = at(x.u); break;
        case InputKind::p: value[n] = at(x.p); break;
        case InputKind::mu: value[n] = at(x.mu); break;
        case InputKind::kd: value[n] = x.kd; break;
        case InputKind::rho: value[n] = x.rho; break;
        case InputKind::restitution: value[n] = x.restitution; break;
        case InputKind::rhs:
          throw std::logic_error("eomgen: evaluate() of Taylor mode's internal right-hand side");
      }
    } else {
      value[n] = apply(node.op, value[node.arg[0]], value[node.arg[1]], value[node.arg[2]]);
    }
  }
  std::vector<double> out;
  out.reserve(outputs.size());
  for (NodeId n : outputs) out.push_back(value[n]);
  return out;
}

}  // namespace eom::gen
