#include "eomgen/program.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "ops/table.hpp"

namespace eom::gen {

namespace {

class Lowering {
 public:
  Lowering(const Graph& g, const Kernel& k, const Signature& sig, std::span<const int> cached,
           const LowerOptions& options)
      : g_(g), k_(k), sig_(sig), cached_(cached), options_(options) {}

  Program make() {
    schedule();
    store();
    for (NodeId n : statements_) {
      Instruction in{g_[n].op, is_guard_[n] != 0, place(n), {}};
      for (std::size_t i = 0; i < in.from.size(); ++i)
        if (static_cast<int>(i) < arity(in.op)) in.from[i] = place(g_[n].arg[i]);
      p_.code.push_back(in);
    }
    std::vector<std::size_t> at(g_.size(), 0);  // node -> its instruction
    for (std::size_t i = 0; i < statements_.size(); ++i) at[statements_[i]] = i;
    for (std::size_t k = 0; k < k_.outputs.size(); ++k) {
      const NodeId n = k_.outputs[k];
      Place where = place(n);
      if (where.kind == Place::Kind::output && where.index != static_cast<int>(k)) {
        p_.copies.push_back({at[n], static_cast<int>(k)});
        where.index = static_cast<int>(k);
      }
      p_.outputs.push_back(where);
    }
    std::stable_sort(p_.copies.begin(), p_.copies.end(),
                     [](const Copy& a, const Copy& b) { return a.after < b.after; });
    return std::move(p_);
  }

 private:
  bool cached(NodeId n) const { return n < cached_.size() && cached_[n] >= 0; }

  // The statements in emission order: the cone of outputs and guards in id order (by_steps: in
  // the order they can start, ties in id order), a cos right after the sin of the same argument.
  // Cached parameter-only values are read from pc[], not computed (the cone stops at them).
  void schedule() {
    std::vector<char> in_cone(g_.size(), 0), done(g_.size(), 0);
    std::vector<NodeId> stack = k_.roots();
    while (!stack.empty()) {
      const NodeId n = stack.back();
      stack.pop_back();
      if (in_cone[n]) continue;
      in_cone[n] = 1;
      if (cached(n)) {
        p_.reads_cache = true;
        continue;
      }
      for (int i = 0; i < arity(g_[n].op); ++i) stack.push_back(g_[n].arg[i]);
    }
    std::vector<NodeId> order;
    for (NodeId n = 0; n < g_.size(); ++n)
      if (in_cone[n] && !cached(n)) order.push_back(n);
    is_guard_.assign(g_.size(), 0);
    for (NodeId n : k_.guards) is_guard_[n] = 1;
    // sin and cos of inputs, when there are vector_trig_from angles or more: one sincos_n call
    // at the top instead of one call per angle.
    trig_.assign(g_.size(), -1);
    std::vector<NodeId> angles;
    for (NodeId n : order)
      if (is_angle(g_, n) && std::find(angles.begin(), angles.end(), g_[n].arg[0]) == angles.end())
        angles.push_back(g_[n].arg[0]);
    if (options_.vector_trig && angles.size() >= vector_trig_from) {
      angles_ = angles;
      const int k = static_cast<int>(angles.size());
      for (NodeId n : order)
        if (is_angle(g_, n)) {
          const int i = static_cast<int>(std::find(angles.begin(), angles.end(), g_[n].arg[0]) - angles.begin());
          trig_[n] = g_[n].op == Op::Sin ? i : k + i;
          done[n] = 1;
        }
    }
    if (k_.by_steps) {  // id order writes a long chain's passes one after the other, each its
                        // own dependency chain; by start they interleave, for the core to overlap
      std::vector<std::size_t> depth(g_.size(), 0), start(g_.size(), 0);  // cached: 0
      std::vector<char> used(g_.size(), 0);
      for (NodeId n : order) {  // ids: arguments first
        for (int i = 0; i < arity(g_[n].op); ++i) {
          start[n] = std::max(start[n], depth[g_[n].arg[i]]);
          used[g_[n].arg[i]] = 1;
        }
        depth[n] = start[n] + step_cost(g_[n].op);
      }
      // Guards that nothing reads go last, in id order: a branch between the chains cost the
      // 30-link chain's kernel 0.83x the old time against 0.73x with them at the end.
      for (NodeId n : k_.guards)
        if (!used[n]) start[n] = static_cast<std::size_t>(-1);
      std::stable_sort(order.begin(), order.end(), [&](NodeId a, NodeId b) { return start[a] < start[b]; });
    }
    for (NodeId n : order) {
      if (g_[n].op == Op::Input) p_.inputs.push_back(leaf(n));
      if (g_[n].op == Op::Input && !std::count(sig_.inputs.begin(), sig_.inputs.end(),
                                               static_cast<InputKind>(g_[n].arg[0])))
        throw std::logic_error(fmt::format("eomgen: kernel {} reads {}, not among its inputs",
                                           sig_.name, name(static_cast<InputKind>(g_[n].arg[0]))));
      if (done[n] || arity(g_[n].op) == 0) continue;
      statements_.push_back(n);
      done[n] = 1;
      if (const Op pair = ops::info(g_[n].op).partner; pair != ops::no_partner) {
        const auto partner = g_.find(pair, g_[n].arg[0]);
        if (partner && in_cone[*partner] && !done[*partner] && !cached(*partner)) {
          statements_.push_back(*partner);
          done[*partner] = 1;
        }
      }
    }
  }

  // Where values are stored. With more than one part, an output is written where it goes (its
  // first place among the outputs; later parts read it there), and any other value used outside
  // the part that computes it lives in the workspace w; a slot is reused once no later part reads
  // it. (Outputs through the workspace cost a copy each at the end: 900 for a 30-link chain's M.)
  void store() {
    slot_.assign(g_.size(), -1);
    output_.assign(g_.size(), -1);
    if (options_.split && statements_.size() > split_from) {
      if (sig_.result != "double")  // a kernel returning its value has no output array
        for (std::size_t k = k_.outputs.size(); k-- > 0;)
          if (const NodeId n = k_.outputs[k]; arity(g_[n].op) > 0 && !cached(n) && trig_[n] < 0 &&
                                              !is_boolean(g_[n].op))
            output_[n] = static_cast<int>(k);
      p_.parts = (statements_.size() + part_size - 1) / part_size;
      constexpr std::size_t none = static_cast<std::size_t>(-1);
      std::vector<std::size_t> part(g_.size(), none), last(g_.size(), 0);
      for (std::size_t i = 0; i < statements_.size(); ++i) part[statements_[i]] = i / part_size;
      const std::size_t main = statements_.size() / part_size + 1;  // after every part
      std::vector<char> shared(g_.size(), 0);
      for (NodeId n : statements_)
        for (int i = 0; i < arity(g_[n].op); ++i) {
          const NodeId a = g_[n].arg[i];
          if (part[a] != none && part[a] != part[n]) {
            shared[a] = 1;
            last[a] = std::max(last[a], part[n]);
          }
        }
      for (NodeId n : k_.outputs)
        if (part[n] != none) {
          shared[n] = 1;
          last[n] = main;
        }
      std::vector<NodeId> crossing;
      std::vector<std::size_t> written, last_read;
      for (NodeId n : statements_)
        if (shared[n] && output_[n] < 0) {
          crossing.push_back(n);
          written.push_back(part[n]);
          last_read.push_back(last[n]);
        }
      const std::vector<int> slots = allocate_slots(written, last_read, p_.slots);
      for (std::size_t i = 0; i < crossing.size(); ++i) slot_[crossing[i]] = slots[i];
    }

    for (NodeId a : angles_) p_.angles.push_back(leaf(a));
    // Locals are numbered in the order they are written (guards are conditions, not values).
    local_.assign(g_.size(), -1);
    int locals = 0;
    for (NodeId n : statements_)
      if (!is_guard_[n] && slot_[n] < 0 && output_[n] < 0) local_[n] = locals++;
  }

  Place place(NodeId n) const {
    Place at;
    if (cached(n)) {
      at.kind = Place::Kind::cached;
      at.index = cached_[n];
    } else if (trig_[n] >= 0) {
      at.kind = Place::Kind::trig;
      at.index = trig_[n];
    } else if (arity(g_[n].op) == 0) {
      at = leaf(n);
    } else if (output_[n] >= 0) {
      at.kind = Place::Kind::output;
      at.index = output_[n];
    } else if (slot_[n] >= 0) {
      at.kind = Place::Kind::workspace;
      at.index = slot_[n];
    } else {
      at.kind = Place::Kind::local;
      at.index = local_[n];
    }
    at.boolean = is_boolean(g_[n].op);
    return at;
  }

  Place leaf(NodeId n) const {
    Place at;
    if (g_[n].op == Op::Const) {
      at.kind = Place::Kind::constant;
      at.value = g_[n].value;
    } else {
      at.kind = Place::Kind::input;
      at.input = static_cast<InputKind>(g_[n].arg[0]);
      at.index = static_cast<int>(g_[n].arg[1]);
    }
    return at;
  }

  const Graph& g_;
  const Kernel& k_;
  const Signature& sig_;
  std::span<const int> cached_;
  const LowerOptions& options_;
  Program p_;
  std::vector<NodeId> statements_;  // non-leaf nodes, in emission order
  std::vector<char> is_guard_;
  std::vector<NodeId> angles_;  // inputs whose sin and cos come from sincos_n
  std::vector<int> trig_;       // node -> its place among sincos_n's results, or -1
  std::vector<int> slot_;       // node -> its workspace slot, or -1
  std::vector<int> output_;     // node -> the first output it is, in a split program, or -1
  std::vector<int> local_;      // node -> its local v<i>, or -1
};

}  // namespace

std::vector<int> allocate_slots(std::span<const std::size_t> written, std::span<const std::size_t> last_read,
                                int& count) {
  std::vector<int> slot(written.size());
  std::size_t parts = 0;
  for (std::size_t i = 0; i < written.size(); ++i) {
    if (last_read[i] < written[i] || (i > 0 && written[i] < written[i - 1]))
      throw std::logic_error("eomgen: allocate_slots() given values out of order");
    parts = std::max(parts, last_read[i] + 1);
  }
  // Slots freed by values whose last reader is part k become free for values of part k + 1.
  std::vector<std::vector<int>> released(parts);
  std::vector<int> free;
  std::size_t current = 0;
  for (std::size_t i = 0; i < written.size(); ++i) {
    for (; current < written[i]; ++current)
      free.insert(free.end(), released[current].begin(), released[current].end());
    if (free.empty()) {
      slot[i] = count++;
    } else {
      slot[i] = free.back();
      free.pop_back();
    }
    released[last_read[i]].push_back(slot[i]);
  }
  return slot;
}

bool is_angle(const Graph& g, NodeId n) {
  return (g[n].op == Op::Sin || g[n].op == Op::Cos) && g[g[n].arg[0]].op == Op::Input;
}

Program lower(const Graph& g, const Kernel& k, const Signature& sig, std::span<const int> cached,
              const LowerOptions& options) {
  return Lowering(g, k, sig, cached, options).make();
}

std::optional<std::vector<double>> run(const Program& p, const Point& x, std::span<const double> pc) {
  int locals = 0;
  for (const Instruction& in : p.code)
    if (in.to.kind == Place::Kind::local) locals = std::max(locals, in.to.index + 1);
  std::vector<double> v(static_cast<std::size_t>(locals)), w(static_cast<std::size_t>(p.slots));
  std::vector<double> out(p.outputs.size());
  std::vector<double> sc(2 * p.angles.size());
  const auto input = [&](const Place& at) {
    if (at.input == InputKind::t) return x.t;
    if (at.input == InputKind::kd) return x.kd;
    if (at.input == InputKind::rho) return x.rho;
    if (at.input == InputKind::restitution) return x.restitution;
    const std::vector<double>* from = nullptr;
    switch (at.input) {
      case InputKind::q: from = &x.q; break;
      case InputKind::qd: from = &x.qd; break;
      case InputKind::qdd: from = &x.qdd; break;
      case InputKind::u: from = &x.u; break;
      case InputKind::p: from = &x.p; break;
      case InputKind::mu: from = &x.mu; break;
      default: throw std::logic_error("eomgen: run() of Taylor mode's internal right-hand side");
    }
    if (static_cast<std::size_t>(at.index) >= from->size())
      throw std::out_of_range(fmt::format("eomgen: run() needs {}[{}]", name(at.input), at.index));
    return (*from)[static_cast<std::size_t>(at.index)];
  };
  const auto read = [&](const Place& at) -> double {
    switch (at.kind) {
      case Place::Kind::constant: return at.value;
      case Place::Kind::input: return input(at);
      case Place::Kind::cached:
        if (static_cast<std::size_t>(at.index) >= pc.size())
          throw std::out_of_range(fmt::format("eomgen: run() needs pc[{}]", at.index));
        return pc[static_cast<std::size_t>(at.index)];
      case Place::Kind::trig: return sc[static_cast<std::size_t>(at.index)];
      case Place::Kind::local: return v[static_cast<std::size_t>(at.index)];
      case Place::Kind::workspace: return w[static_cast<std::size_t>(at.index)];
      case Place::Kind::output: return out[static_cast<std::size_t>(at.index)];
    }
    return 0;
  };
  const std::size_t k = p.angles.size();
  for (std::size_t i = 0; i < k; ++i) {
    sc[i] = std::sin(input(p.angles[i]));
    sc[k + i] = std::cos(input(p.angles[i]));
  }
  auto copy = p.copies.begin();
  for (std::size_t i = 0; i < p.code.size(); ++i) {
    const Instruction& in = p.code[i];
    const double value = apply(in.op, read(in.from[0]), read(in.from[1]), read(in.from[2]));
    if (in.guard) {
      if (value == 0) return std::nullopt;
    } else {
      auto& to = in.to.kind == Place::Kind::local ? v : in.to.kind == Place::Kind::output ? out : w;
      to[static_cast<std::size_t>(in.to.index)] = value;
    }
    for (; copy != p.copies.end() && copy->after == i; ++copy) out[static_cast<std::size_t>(copy->output)] = value;
  }
  for (std::size_t k = 0; k < p.outputs.size(); ++k)
    if (p.outputs[k].kind != Place::Kind::output) out[k] = read(p.outputs[k]);
  return out;
}

}  // namespace eom::gen
