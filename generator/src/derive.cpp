#include "eomgen/derive.hpp"

#include <limits>
#include <stdexcept>

namespace eom::gen {
namespace {

constexpr NodeId none = std::numeric_limits<NodeId>::max();  // a zero derivative, not yet a node

// (∂n/∂argᵢ)·w: the chain rule of one operation, shared by both modes. The forms follow
// runtime/include/eom/ad.hpp so the derived kernels agree with the reference to round-off.
NodeId chain(Graph& g, NodeId n, int i, NodeId w) {
  const Node node = g[n];
  const NodeId a = node.arg[0], b = node.arg[1];
  switch (node.op) {
    case Op::Neg: return g.neg(w);
    case Op::Add: return w;
    case Op::Sub: return i == 0 ? w : g.neg(w);
    case Op::Mul: return g.mul(w, i == 0 ? b : a);
    case Op::Div:  // d(a/b) = da/b − (a/b)·db/b
      return i == 0 ? g.div(w, b) : g.neg(g.div(g.mul(w, n), b));
    case Op::Sin: return g.mul(w, g.make(Op::Cos, a));
    case Op::Cos: return g.neg(g.mul(w, g.make(Op::Sin, a)));
    case Op::Tan: return g.mul(w, g.add(Graph::one, g.mul(n, n)));
    case Op::Asin: return g.div(w, g.make(Op::Sqrt, g.sub(Graph::one, g.mul(a, a))));
    case Op::Acos: return g.neg(g.div(w, g.make(Op::Sqrt, g.sub(Graph::one, g.mul(a, a)))));
    case Op::Atan: return g.div(w, g.add(Graph::one, g.mul(a, a)));
    case Op::Exp: return g.mul(w, n);
    case Op::Log: return g.div(w, a);
    case Op::Sqrt: return g.div(w, g.mul(g.constant(2), n));
    case Op::Abs:  // sign(a), +1 at a = 0 as in the reference
      return g.make(Op::Select, g.make(Op::Less, a, Graph::zero), g.neg(w), w);
    case Op::Pow:
      if (i == 0) return g.mul(w, g.mul(b, g.make(Op::Pow, a, g.sub(b, Graph::one))));
      return g.mul(w, g.mul(n, g.make(Op::Log, a)));
    case Op::Atan2: {  // atan2(y, x): (x dy − y dx) / (x² + y²)
      const NodeId r2 = g.add(g.mul(a, a), g.mul(b, b));
      return i == 0 ? g.div(g.mul(w, b), r2) : g.neg(g.div(g.mul(w, a), r2));
    }
    case Op::Hypot: return g.div(g.mul(w, i == 0 ? a : b), n);
    case Op::Select:
      return i == 1 ? g.make(Op::Select, a, w, Graph::zero) : g.make(Op::Select, a, Graph::zero, w);
    default: break;
  }
  throw std::logic_error("eomgen: no derivative rule for " + std::string(name(node.op)));
}

// The arguments an operation is differentiable in (a Select's condition is not).
int first_real_arg(Op op) { return op == Op::Select ? 1 : 0; }
bool differentiable(Op op) { return !is_boolean(op) && arity(op) > 0; }

}  // namespace

std::vector<NodeId> gradient(Graph& g, NodeId f, std::span<const NodeId> wrt) {
  const NodeId roots[] = {f};
  const std::vector<NodeId> order = cone(g, roots);
  const std::size_t n0 = g.size();
  // Activity: a node matters only if it depends on some x in wrt.
  std::vector<char> active(n0, 0);
  for (NodeId x : wrt) active[x] = 1;
  for (NodeId n : order)
    if (differentiable(g[n].op))
      for (int i = first_real_arg(g[n].op); i < arity(g[n].op); ++i)
        active[n] = active[n] || active[g[n].arg[i]];
  std::vector<NodeId> adjoint(n0, none);
  if (active[f]) adjoint[f] = Graph::one;
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    const NodeId n = *it;
    const NodeId w = adjoint[n];
    if (w == none || !differentiable(g[n].op)) continue;
    const Node node = g[n];
    for (int i = first_real_arg(node.op); i < arity(node.op); ++i) {
      const NodeId x = node.arg[i];
      if (!active[x]) continue;
      const NodeId d = chain(g, n, i, w);
      adjoint[x] = adjoint[x] == none ? d : g.add(adjoint[x], d);
    }
  }
  std::vector<NodeId> out;
  out.reserve(wrt.size());
  for (NodeId x : wrt) out.push_back(x < n0 && adjoint[x] != none ? adjoint[x] : Graph::zero);
  return out;
}

std::vector<NodeId> directional(Graph& g, std::span<const NodeId> outputs,
                                std::span<const Seed> seeds) {
  const std::vector<NodeId> order = cone(g, outputs);
  std::vector<NodeId> tangent(g.size(), none);
  for (auto [x, dx] : seeds) tangent[x] = dx;
  for (NodeId n : order) {
    if (tangent[n] != none || !differentiable(g[n].op)) continue;
    const Node node = g[n];
    if (node.op == Op::Select) {  // the tangent of the branch taken
      const NodeId ta = tangent[node.arg[1]], tb = tangent[node.arg[2]];
      if (ta != none || tb != none)
        tangent[n] = g.make(Op::Select, node.arg[0], ta == none ? Graph::zero : ta,
                            tb == none ? Graph::zero : tb);
      continue;
    }
    NodeId sum = none;
    for (int i = 0; i < arity(node.op); ++i) {
      const NodeId t = tangent[node.arg[i]];
      if (t == none) continue;
      const NodeId d = chain(g, n, i, t);
      sum = sum == none ? d : g.add(sum, d);
    }
    tangent[n] = sum;
  }
  std::vector<NodeId> out;
  out.reserve(outputs.size());
  for (NodeId y : outputs) out.push_back(tangent[y] == none ? Graph::zero : tangent[y]);
  return out;
}

std::vector<NodeId> substitute(Graph& g, std::span<const NodeId> outputs,
                               std::span<const Seed> replacements) {
  const std::vector<NodeId> order = cone(g, outputs);
  std::vector<NodeId> image(g.size(), none);
  for (auto [x, y] : replacements) image[x] = y;
  for (NodeId n : order) {
    if (image[n] != none) continue;
    const Node node = g[n];
    const int k = arity(node.op);
    if (k == 0) {
      image[n] = n;
      continue;
    }
    std::array<NodeId, 3> arg = node.arg;
    bool changed = false;
    for (int i = 0; i < k; ++i) {
      changed = changed || image[arg[i]] != arg[i];
      arg[i] = image[arg[i]];
    }
    image[n] = changed ? g.make(node.op, arg[0], arg[1], arg[2]) : n;
  }
  std::vector<NodeId> out;
  out.reserve(outputs.size());
  for (NodeId y : outputs) out.push_back(image[y]);
  return out;
}

}  // namespace eom::gen
