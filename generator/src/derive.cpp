#include "eomgen/derive.hpp"

#include <limits>
#include <stdexcept>

#include "ops/table.hpp"

namespace eom::gen {
namespace {

constexpr NodeId none = std::numeric_limits<NodeId>::max();  // a zero derivative, not yet a node

// (∂n/∂argᵢ)·w: the operation's derivative rule (ops/), shared by both modes.
NodeId chain(Graph& g, NodeId n, int i, NodeId w) { return ops::info(g[n].op).derivative(g, n, i, w); }

// The arguments an operation is differentiable in (a select's condition is not).
int first_real_arg(Op op) { return ops::info(op).conditions; }
bool differentiable(Op op) { return ops::info(op).kind == ops::Kind::real; }

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
