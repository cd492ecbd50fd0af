// The taylor_coefficients kernel (eomgen/taylor.hpp has the plan, taylor_recurrences.inc the
// arithmetic). Its shape:
//
//   check order and inputs
//   order 0: the forward dynamics as in forward_dynamics (guards included); a stored series gets
//            its coefficient 0, auxiliary series theirs; the series of q̈ and μ start
//   for k = 1 .. order-1:
//            q_k = qd_(k-1)/k (with quaternions: coefficient k-1 of q̇ = G(q) v, over k)
//            coefficient k of every needed series of M, f, C, γ, in id order (linear nodes in
//            O(1), the others by their recurrence)
//            the right-hand side b (convolution tails of M, C against q̈, μ), the order-0 solve
//            of b, giving q̈_k and μ_k; qd_(k+1) = q̈_k/(k+1)
//   q_order = qd_(order-1)/order; every coefficient finite, else false
//
// Looped (Kernel::looped, big models): order 0 writes M, f, C, γ into the array `dense` and
// solve_dense_system solves it, keeping the factors; per coefficient, the right-hand side goes
// into `dense` too and solve_dense_columns solves it on those factors.
//
// Names: node number i is v<i> at order 0 (a scalar, or the first coefficient of a series that
// is not stored), y<i> its coefficient k when it is not stored, s<i> its series when it is
// (s<i>[k]; auxiliaries s<i>_<what>); sq<j>, sqd<j>, st the stored series of q_j, qd_j and t;
// sqdd<j>, smu<j> those of q̈ and μ; b<i> the right-hand side. Series live in `work`, order + 1
// consecutive doubles each.
//
// Large models: as the other kernels, a pass (order 0, or one coefficient) of more than part_size
// statements is written as functions of at most part_size statements: <kernel>_order0_part<p>
// and <kernel>_part<p>. A value computed in one function and read in another lives in an array
// of the kernel's scratch: w[] (order-0 values, read at every k), x[] (coefficient-k temporaries)
// or h[] (histories). The scratch is the caller's in the overload taking `scratch`; the plain
// signature lends it an array on its stack.
// Which values cross is found by writing everything once without output, recording reads.
#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <set>
#include <stdexcept>

#include "emit_detail.hpp"
#include "eomgen/program.hpp"
#include "eomgen/taylor.hpp"
#include "ops/print.hpp"

namespace eom::gen::detail {
namespace {

constexpr std::size_t history_group = 16;  // sums per history loop (x86-64 has 16 vector registers)

// "type name", or "type /*name*/" when `text` never mentions name (no unused parameters).
bool mentions(std::string_view text, std::string_view word) {
  auto identifier = [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
  };
  for (std::size_t at = text.find(word); at != std::string_view::npos; at = text.find(word, at + 1)) {
    const std::size_t end = at + word.size();
    if ((at == 0 || !identifier(text[at - 1])) && (end == text.size() || !identifier(text[end])))
      return true;
  }
  return false;
}
std::string parameter(std::string_view type, std::string_view name, std::string_view text) {
  return mentions(text, name) ? fmt::format("{} {}", type, name) : fmt::format("{} /*{}*/", type, name);
}

class TaylorWriter {
 public:
  TaylorWriter(const TracedModel& m, const Kernel& k)
      : m_(m), g_(m.graph), k_(k), plan_(make_taylor_plan(g_, k.system.value(), k.guards)),
        sys_(*plan_.system), nv_(m.floating() ? "nv" : "nq") {}

  // `workspace`: doubles per coefficient in `work`; `scratch`: the doubles of the overload taking
  // the crossing arrays from the caller (0: the kernel has none, and no such overload).
  std::size_t write(Buffer& out, std::size_t& workspace, std::size_t& scratch) {
    number();
    {  // the inputs' sines and cosines as the forward_dynamics kernel takes them (program.hpp)
      std::set<NodeId> angles;
      for (const TaylorStep& step : plan_.order0)
        if (is_angle(g_, step.node)) angles.insert(g_[step.node].arg[0]);
      by_sincos_n_ = angles.size() >= vector_trig_from;
    }
    split_ = std::max(plan_.order0.size(), plan_.coefficient.size()) > part_size;
    assign_slots();
    workspace = slot_count_;
    if (split_) {  // find the values that cross functions
      Buffer ignored;
      recording_ = true;
      emit_all(ignored);
      recording_ = false;
      for (const auto& [key, where] : defined_in_)
        if (crossing_.count(key) && kind(key) == Local::order0) shared_[key] = 0;
      int i = 0;
      for (auto& entry : shared_) entry.second = i++;
      // Coefficient-k temporaries live from their part to the last part that reads them, within
      // one coefficient: their slots in x[] are reused as the program's workspace slots are.
      std::vector<Key> crossing;
      std::vector<std::size_t> written, last_read;
      for (Key key : definitions_)
        if (crossing_.count(key) && kind(key) != Local::order0) {
          crossing.push_back(key);
          written.push_back(static_cast<std::size_t>(defined_in_.at(key)));
          last_read.push_back(static_cast<std::size_t>(last_read_.at(key)));
        }
      const std::vector<int> slots = allocate_slots(written, last_read, scratch_size_);
      for (std::size_t j = 0; j < crossing.size(); ++j) scratch_[crossing[j]] = slots[j];
    }
    emit_all(out);
    scratch = scratch_doubles_;
    return plan_.order0.size() + plan_.series + plan_.tails + plan_.solve_nodes.size();
  }

 private:
  // ---- the statements of the two passes (the plan's order0 and coefficient) ----

  using Kind = TaylorStep::Kind;

  void number() {
    index_.assign(g_.size(), -1);
    int next = 0;
    for (NodeId n : plan_.nodes)
      if (arity(g_[n].op) > 0) index_[n] = next++;
    for (NodeId n : plan_.solve_nodes) index_[n] = next++;
    is_guard_.assign(g_.size(), 0);
    for (NodeId n : k_.guards) is_guard_[n] = 1;
    for (std::size_t i = 0; i < sys_.qdd.size(); ++i) qdd_of_[sys_.qdd[i]].push_back(static_cast<int>(i));
    for (std::size_t i = 0; i < sys_.mu.size(); ++i) mu_of_[sys_.mu[i]].push_back(static_cast<int>(i));
  }

  // Slots in id order (a node's auxiliaries right after it), then q̈ and μ.
  void assign_slots() {
    slot_.assign(g_.size(), -1);
    aux_slot_.assign(plan_.aux.size(), -1);
    for (NodeId n : plan_.nodes) {
      if (plan_.stored[n]) slot_[n] = slot_count_++;
      if (plan_.first_aux[n] >= 0)
        for (std::size_t a = plan_.first_aux[n]; a < plan_.aux.size() && plan_.aux[a].owner == n; ++a)
          aux_slot_[a] = slot_count_++;
    }
    qdd_slot_ = slot_count_;
    slot_count_ += sys_.nq + sys_.nc;
  }

  // ---- values and their names in the function being written ----

  // A temporary: an order-0 value, a coefficient-k value, or a right-hand side entry.
  enum class Local : std::uint8_t { order0, coefficient, rhs };
  using Key = std::uint64_t;
  static Key key(Local kind, std::uint32_t id) { return (Key(kind) << 32) | id; }
  static Local kind(Key k) { return static_cast<Local>(k >> 32); }

  // The name of a temporary where it is read (recording reads that cross functions).
  std::string read(Local local, std::uint32_t id, bool boolean = false) {
    const Key k = key(local, id);
    if (recording_) {
      const auto at = defined_in_.find(k);
      if (at == defined_in_.end()) throw std::logic_error("eomgen: Taylor mode read before write");
      if (at->second != function_) {
        crossing_.insert(k);
        int& last = last_read_[k];
        last = std::max(last, function_);
      }
    }
    if (const auto w = shared_.find(k); w != shared_.end())
      return boolean ? fmt::format("(w[{}] != 0.0)", w->second) : fmt::format("w[{}]", w->second);
    if (const auto x = scratch_.find(k); x != scratch_.end()) return fmt::format("x[{}]", x->second);
    return plain_name(local, id);
  }
  std::string plain_name(Local local, std::uint32_t id) const {
    switch (local) {
      case Local::order0: return fmt::format("v{}", index_[id]);
      case Local::coefficient: return fmt::format("y{}", index_[id]);
      case Local::rhs: break;
    }
    return fmt::format("b{}", id);
  }
  // The statement defining a temporary: rhs is terms joined by `separator` (wrapped at 100
  // columns), or one expression.
  std::string define(Local local, std::uint32_t id, const std::vector<std::string>& terms,
                     std::string_view separator, bool boolean = false) {
    const Key k = key(local, id);
    if (recording_ && defined_in_.emplace(k, function_).second) definitions_.push_back(k);
    std::string head;
    if (const auto w = shared_.find(k); w != shared_.end())
      head = fmt::format("  w[{}] = ", w->second);
    else if (const auto x = scratch_.find(k); x != scratch_.end())
      head = fmt::format("  x[{}] = ", x->second);
    else
      head = fmt::format("  const {} {} = ", boolean ? "bool" : "double", plain_name(local, id));
    return wrap(head, terms, ";", separator) + "\n";
  }
  std::string define(Local local, std::uint32_t id, const std::string& rhs, bool boolean = false) {
    return define(local, id, std::vector<std::string>{rhs}, "", boolean);
  }

  // Series pointers, declared at the top of each function that uses them.
  std::string pointer(int slot, std::string name, std::string_view comment = {}) {
    pointers_[slot] = {name, std::string(comment)};
    pointer_slot_[name] = {slot, std::string(comment)};
    return name;
  }
  std::string series(NodeId n) {
    if (slot_[n] < 0) throw std::logic_error("eomgen: Taylor series of a node without a slot");
    const Node& node = g_[n];
    if (node.op == Op::Input) {
      const auto kind = static_cast<InputKind>(node.arg[0]);
      return pointer(slot_[n], kind == InputKind::t ? std::string("st")
                                                    : fmt::format("s{}{}", name(kind), node.arg[1]));
    }
    return pointer(slot_[n], fmt::format("s{}", index_[n]));
  }
  std::string aux(NodeId owner, int which = 0) {
    const int a = plan_.first_aux[owner] + which;
    const ops::AuxSeries& what = ops::info(g_[owner].op).aux[which];
    return pointer(aux_slot_[a], fmt::format("s{}_{}", index_[owner], what.suffix), what.comment);
  }
  std::string qdd_series(int i) { return pointer(qdd_slot_ + i, fmt::format("sqdd{}", i), i ? "" : "qdd"); }
  std::string mu_series(int i) {
    return pointer(qdd_slot_ + sys_.nq + i, fmt::format("smu{}", i), i ? "" : "multipliers");
  }
  std::string pointer_declarations() const {
    std::string s;
    for (const auto& [slot, what] : pointers_) {
      s += fmt::format("  double* const {} = {};", what.first,
                       slot == 0 ? std::string("work") : fmt::format("work + {} * n", slot));
      if (!what.second.empty()) s += "  // " + what.second;
      s += '\n';
    }
    return s;
  }

  // The order-0 value of n.
  std::string value(NodeId n) {
    const Node& node = g_[n];
    if (node.op == Op::Const) return literal(node.value);
    if (node.op == Op::Input) {
      const auto kind = static_cast<InputKind>(node.arg[0]);
      if (kind == InputKind::t) return "t";
      return fmt::format("{}[{}]", name(kind), node.arg[1]);
    }
    if (slot_[n] >= 0) return series(n) + "[0]";
    return read(Local::order0, n, is_boolean(node.op));
  }

  // Coefficient k >= 1 of a needed series, a solve node or the right-hand side.
  std::string coefficient(NodeId n) {
    const Node& node = g_[n];
    if (slot_[n] >= 0) return series(n) + "[k]";
    if (node.op == Op::Input) {
      const auto kind = static_cast<InputKind>(node.arg[0]);
      if (kind == InputKind::rhs) return read(Local::rhs, node.arg[1]);
      return input_coefficient(n);
    }
    return read(Local::coefficient, n);
  }

  // Coefficient k >= 1 of t, q_j or qd_j.
  std::string input_coefficient(NodeId n) const {
    const auto kind = static_cast<InputKind>(g_[n].arg[0]);
    if (kind == InputKind::t) return "(k == 1 ? 1.0 : 0.0)";
    if (kind == InputKind::q) return fmt::format("qk[k * nq + {}]", g_[n].arg[1]);
    return fmt::format("qdk[k * {} + {}]", nv_, g_[n].arg[1]);
  }

  // ---- histories: the sums over j = 1..k-1 of a coefficient, all in one loop ----

  // The name of the history of `kind` (a taylor_history_<kind> term) over series a and b.
  std::string history(std::string_view kind, const std::string& a, const std::string& b) {
    const std::string text = fmt::format("taylor_history_{}({}, {}, j, m)", kind, a, b);
    auto [at, added] = history_index_.try_emplace(text, static_cast<int>(histories_.size()));
    if (added) histories_.push_back({text, a, b});
    return split_ ? fmt::format("h[{}]", at->second) : fmt::format("h{}", at->second);
  }
  // Coefficient k of the convolutions of taylor_recurrences.inc, as finish(history).
  std::string product(const std::string& a, const std::string& b) {
    return fmt::format("taylor_product_finish({}, {}, {}, k)", history("product", a, b), a, b);
  }
  std::string square(const std::string& a) {
    return fmt::format("taylor_square_finish({}, {}, k)", history("product", a, a), a);
  }
  std::string integral(const std::string& a, const std::string& b) {
    return fmt::format("taylor_integral_finish({}, {}, {}, k)", history("integral", a, b), a, b);
  }
  std::string inverse_integral(const std::string& ak, const std::string& b, const std::string& c) {
    return fmt::format("taylor_inverse_integral_finish({}, {}, {}, k)", history("integral", c, b), ak, b);
  }
  std::string quotient(const std::string& ak, const std::string& b, const std::string& c) {
    return fmt::format("taylor_quotient_finish({}, {}, {}, {}, k)", history("product", b, c), ak, b, c);
  }
  std::string root(const std::string& ak, const std::string& c) {
    return fmt::format("taylor_sqrt_finish({}, {}, {})", history("product", c, c), ak, c);
  }
  std::string cross(const std::string& y, const std::string& x) {
    return fmt::format("taylor_cross_finish({}, {}, {}, k)", history("cross", y, x), y, x);
  }
  std::string tail(const std::string& a, const std::string& b) {
    return fmt::format("taylor_tail_finish({}, {}, {}, k)", history("product", a, b), a, b);
  }

  // The loops summing histories [first, last) into h<i>, or h[i] in a split kernel. Each loop
  // sums at most history_group of them, so that their accumulators stay in registers (chain10's
  // 350 sums in one loop spilled them, and were slower than separate sums); h[] is restrict, so
  // the compiler may keep h[i] in a register through its loop.
  std::string history_loop(std::size_t first, std::size_t last) {
    std::string s;
    if (first == last) return s;
    if (split_) {
      s += fmt::format("  for (int i = {}; i < {}; ++i) h[i] = 0.0;\n", first, last);
    } else {
      std::vector<std::string> zeros;
      for (std::size_t i = first; i < last; ++i) zeros.push_back(fmt::format("h{} = 0.0", i));
      s += wrap("  double ", zeros, ";\n", ",");
    }
    for (std::size_t group = first; group < last; group += history_group) {
      const std::size_t end = std::min(last, group + history_group);
      s += "  for (int j = 1, m = k - 1; j < k; ++j, --m) {\n";
      for (std::size_t i = group; i < end; ++i) {
        const History& h = histories_[i];
        for (const std::string* name : {&h.a, &h.b}) {
          const auto& [slot, comment] = pointer_slot_.at(*name);
          pointer(slot, *name, comment);
        }
        s += fmt::format("    {} += {};\n", split_ ? fmt::format("h[{}]", i) : fmt::format("h{}", i), h.text);
      }
      s += "  }\n";
    }
    return s;
  }

  // ---- statements ----

  // Node n at order 0 (its auxiliaries' first coefficients, and the q̈, μ it is, too).
  void order0_statement(std::string& body, NodeId n, std::string_view fail) {
    const Node& node = g_[n];
    const std::string e = by_sincos_n_ && is_angle(g_, n)
                              ? angle_call(node.op, value(node.arg[0]))
                              : expression(g_, n, [this](NodeId a) { return value(a); });
    if (is_guard_[n]) {
      body += fmt::format("  if (!{}) return {};\n", e, fail);
      return;
    }
    if (slot_[n] >= 0)
      body += fmt::format("  {}[0] = {};\n", series(n), e);
    else
      body += define(Local::order0, n, e, is_boolean(node.op));
    if (plan_.first_aux[n] >= 0) {
      Order0 x{*this, body, n};
      ops::visit(node.op, [&](auto entry) { decltype(entry)::taylor_order0(x); });
    }
    results0(body, n);
  }

  // q̈_0 (an output) and μ_0, when n is one of them.
  void results0(std::string& body, NodeId n) {
    if (const auto it = qdd_of_.find(n); it != qdd_of_.end())
      for (int i : it->second) {
        body += fmt::format("  {}[0] = {};\n", qdd_series(i), value(n));
        body += fmt::format("  qdk[{} + {}] = {}[0];\n", nv_, i, qdd_series(i));
      }
    if (const auto it = mu_of_.find(n); it != mu_of_.end())
      for (int i : it->second) body += fmt::format("  {}[0] = {};\n", mu_series(i), value(n));
  }

  // The looped form's order 0: M, f, C, γ into `dense`, the routine's solve (keeping the factors
  // for every coefficient), q̈_0 and μ_0. `dense` holds the routine's array, q̈_0, then the
  // right-hand side of coefficient k (μ_k after the solve) and q̈_k.
  int dense_column() const { return dense::DenseLayout(sys_.nq, sys_.nc).size + sys_.nq; }
  int dense_size() const { return sys_.looped ? dense_column() + 2 * sys_.nq + sys_.nc : 0; }
  void dense_order0(std::string& body) {
    const int n = sys_.nq, nc = sys_.nc, qdd = dense::DenseLayout(n, nc).size;
    // Entries that are series (most of M in a big model) are copied by one loop over index
    // tables: a statement and a series pointer each made the 50-link chain's kernel compile
    // slower than with the unrolled factorization.
    std::vector<std::string> to, slot;
    for (auto [node, position] : dense_system_entries(sys_))
      if (slot_[node] >= 0) {
        to.push_back(std::to_string(position));
        slot.push_back(std::to_string(slot_[node]));
      }
    const bool gather = to.size() >= gather_from;
    for (auto [node, position] : dense_system_entries(sys_))
      if (!gather || slot_[node] < 0) body += fmt::format("  dense[{}] = {};\n", position, value(node));
    if (gather) {
      body += wrap(fmt::format("  static constexpr int dense_to[{}] = {{", to.size()), to, "};\n");
      body += wrap(fmt::format("  static constexpr int dense_slot[{}] = {{", slot.size()), slot, "};\n");
      body += fmt::format("  for (int i = 0; i < {}; ++i) dense[dense_to[i]] = work[dense_slot[i] * n];\n",
                          to.size());
    }
    body += fmt::format("  if (!solve_dense_system<{}, {}>(dense, dense + {})) return fail();\n", n, nc, qdd);
    for (int i = 0; i < n; ++i) {
      body += fmt::format("  {}[0] = dense[{}];\n", qdd_series(i), qdd + i);
      body += fmt::format("  qdk[{} + {}] = {}[0];\n", nv_, i, qdd_series(i));
    }
    for (int c = 0; c < nc; ++c)
      body += fmt::format("  {}[0] = dense[{}];\n", mu_series(c), dense::DenseLayout(n, nc).mu + c);
  }

  // One coefficient-k statement.
  void series_statement(std::string& body, const TaylorStep& item) {
    switch (item.kind) {
      case Kind::node: plan_.solve[item.node] ? solve_step(body, item.node) : node_coefficient(body, item.node); break;
      case Kind::rhs: right_hand_side(body, item.index); break;
      case Kind::dense_solve: {
        const int n = sys_.nq, nc = sys_.nc;
        for (int i = 0; i < n + nc; ++i)
          body += fmt::format("  dense[{}] = {};\n", dense_column() + i, read(Local::rhs, i));
        body += fmt::format("  solve_dense_columns<{}, {}>(dense, dense + {}, 1, dense + {});\n", n, nc,
                            dense_column(), dense_column() + n + nc);
        break;
      }
      case Kind::result_qdd: {
        std::string x = "0.0";
        if (sys_.looped)
          x = fmt::format("dense[{}]", dense_column() + sys_.nq + sys_.nc + item.index);
        else if (plan_.solve[sys_.solve_qdd[item.index]])
          x = coefficient(sys_.solve_qdd[item.index]);
        body += fmt::format("  {}[k] = {};\n", qdd_series(item.index), x);
        body += fmt::format("  qdk[(k + 1) * {} + {}] = {}[k] / (k + 1);\n", nv_, item.index,
                            qdd_series(item.index));
        break;
      }
      case Kind::result_mu: {
        std::string x = "0.0";
        if (sys_.looped)
          x = fmt::format("dense[{}]", dense_column() + sys_.nq + item.index);  // solved in place
        else if (plan_.solve[sys_.solve_mu[item.index]])
          x = coefficient(sys_.solve_mu[item.index]);
        body += fmt::format("  {}[k] = {};\n", mu_series(item.index), x);
        break;
      }
    }
  }

  // b_i = f_k − Σ_l tail(M_il, q̈_l) − Σ_c tail(C_ci, μ_c), b_(nq+c) = γ_k + Σ_l tail(C_cl, q̈_l):
  // the terms in the order the evaluator sums them (taylor.cpp).
  void right_hand_side(std::string& body, int i) {
    const int nq = sys_.nq, nc = sys_.nc;
    const bool force = i < nq;
    const NodeId leading = force ? sys_.force[i] : sys_.bias[i - nq];
    std::vector<std::string> terms;  // joined by " -" (force rows) or " +"
    if (plan_.varying[leading]) terms.push_back(coefficient(leading));
    auto add_tail = [&](NodeId entry, const std::string& x) {
      if (!plan_.varying[entry]) return;
      const std::string t = tail(series(entry), x);
      terms.push_back(terms.empty() && force ? fmt::format("-{}", t) : t);
    };
    if (force) {
      for (int l = 0; l < nq; ++l) add_tail(sys_.mass[i + nq * l], qdd_series(l));
      for (int c = 0; c < nc; ++c) add_tail(sys_.jacobian[c + nc * i], mu_series(c));
    } else {
      for (int l = 0; l < nq; ++l) add_tail(sys_.jacobian[(i - nq) + nc * l], qdd_series(l));
    }
    if (terms.empty()) terms.emplace_back("0.0");
    body += define(Local::rhs, i, terms, force ? " -" : " +");
  }

  // A step of the order-0 solve applied to the right-hand side (linear in it: the plan checks).
  void solve_step(std::string& body, NodeId n) {
    const Node& node = g_[n];
    auto operand = [&](int i) {
      return Text{plan_.solve[node.arg[i]] ? coefficient(node.arg[i]) : value(node.arg[i])};
    };
    const Text e = arity(node.op) == 1 ? ops::print(node.op, operand(0))
                                       : ops::print(node.op, operand(0), operand(1));
    body += define(Local::coefficient, n, e.s);
  }

  // The sine or cosine of angle x as the scalar kernels take it: by sincos_n, then trig_at (one
  // of the two computes it, as trig_helper_text is compiled), so that q̈ at order 0 keeps the
  // forward_dynamics kernel's bits.
  static std::string angle_call(Op op, const std::string& x) {
    return fmt::format("{}_of_angle({})", op == Op::Sin ? "sin" : "cos", x);
  }

  // Coefficient k of node n (and of its sin/cos partner and auxiliaries).
  void node_coefficient(std::string& body, NodeId n) {
    Step x{*this, body, n};
    ops::visit(g_[n].op, [&](auto entry) {
      using Entry = decltype(entry);
      if constexpr (Entry::kind == ops::Kind::real)
        Entry::taylor(x);
      else
        throw std::logic_error(fmt::format("eomgen: Taylor mode: a series of {}", Entry::name));
    });
  }

  // The contexts the table's Taylor rules run in (ops/op.hpp): values are C++ text, series names.
  using Text = ops::Text;
  struct Order0 {  // coefficient 0 of node n's auxiliaries
    TaylorWriter& w;
    std::string& body;
    NodeId n;
    Text v(int i) const { return {w.value(w.g_[n].arg[i])}; }
    Text self_v() const { return {w.value(n)}; }
    Text aux0(int j) const { return {w.aux(n, j) + "[0]"}; }
    void set_aux0(int j, const Text& e) const { body += fmt::format("  {}[0] = {};\n", w.aux(n, j), e.s); }
    Text constant(double d) const { return {literal(d)}; }
    template <class... T> Text apply(Op op, const T&... e) const {
      if constexpr (sizeof...(T) == 1)  // an angle's partner (sin's cos, cos's sin)
        if (w.by_sincos_n_ && is_angle(w.g_, n) && (op == Op::Sin || op == Op::Cos))
          return {w.angle_call(op, e.s...)};
      return ops::print(op, e...);
    }
  };
  struct Step {  // coefficient k of node n
    TaylorWriter& w;
    std::string& body;
    NodeId n;
    NodeId arg(int i) const { return w.g_[n].arg[i]; }
    bool varying(int i) const { return w.plan_.varying[arg(i)]; }
    bool same_args() const { return arg(0) == arg(1); }
    bool paired() const { return w.plan_.partner[n] != 0; }
    Text c(int i) const { return {w.coefficient(arg(i))}; }
    Text v(int i) const { return {w.value(arg(i))}; }
    Text self_v() const { return {w.value(n)}; }
    std::string S(int i) const { return w.series(arg(i)); }
    std::string self_S() const { return w.series(n); }
    std::string partner_S() const { return w.series(w.plan_.partner[n]); }
    std::string aux(int j) const { return w.aux(n, j); }
    void self(const Text& e) const {
      if (w.slot_[n] >= 0)
        set(w.series(n), e);
      else
        body += w.define(Local::coefficient, n, e.s);
    }
    void set(const std::string& s, const Text& e) const { body += fmt::format("  {}[k] = {};\n", s, e.s); }
    Text constant(double d) const { return {literal(d)}; }
    template <class... T> Text apply(Op op, const T&... e) const { return ops::print(op, e...); }
    Text product(const std::string& a, const std::string& b) const { return {w.product(a, b)}; }
    Text square(const std::string& a) const { return {w.square(a)}; }
    Text integral(const std::string& a, const std::string& b) const { return {w.integral(a, b)}; }
    Text inverse_integral(const Text& ak, const std::string& b, const std::string& c) const {
      return {w.inverse_integral(ak.s, b, c)};
    }
    Text quotient(const Text& ak, const std::string& b, const std::string& c) const {
      return {w.quotient(ak.s, b, c)};
    }
    Text root(const Text& ak, const std::string& c) const { return {w.root(ak.s, c)}; }
    Text cross(const std::string& y, const std::string& x) const { return {w.cross(y, x)}; }
    Text power(const std::string& a, const std::string& c, const Text& r) const {
      return {fmt::format("taylor_pow({}, {}, {}, k)", a, c, r.s)};
    }
  };

  // ---- functions ----

  void emit_all(Buffer& out) {
    std::vector<std::string> parts0, partsk, history_parts;
    int function = 1;
    if (split_) {
      for (std::size_t p = 0; p * part_size < plan_.order0.size(); ++p) parts0.push_back(order0_part(out, p, function++));
      for (std::size_t p = 0; p * part_size < plan_.coefficient.size(); ++p)
        partsk.push_back(series_part(out, p, function++));
      for (std::size_t p = 0; p * part_size < histories_.size(); ++p)
        history_parts.push_back(history_part(out, p, function++));
    }
    main(out, parts0, partsk, history_parts);
  }

  std::string order0_part(Buffer& out, std::size_t p, int function) {
    function_ = function;
    pointers_.clear();
    std::string body;
    const std::size_t end = std::min(plan_.order0.size(), (p + 1) * part_size);
    for (std::size_t i = p * part_size; i < end; ++i) order0_statement(body, plan_.order0[i].node, "false");
    const std::string name = fmt::format("{}_order0_part{}", signature(k_.id).name, p + 1);
    fmt::format_to(std::back_inserter(out), "// {}: {}, order 0, part {} of {}\n", m_.name,
                   signature(k_.id).name, p + 1, (plan_.order0.size() + part_size - 1) / part_size);
    const std::string text = pointer_declarations() + body;
    out.append(wrap(fmt::format("static bool {}(", name),
                    {parameter("double", "t", text), parameter("const double*", "q", text),
                     parameter("const double*", "qd", text), parameter("const double*", "u", text),
                     parameter("const double*", "p", text), parameter("double*", "qdk", text),
                     parameter("double*", "w", text), parameter("double*", "work", text),
                     parameter("std::ptrdiff_t", "n", text)},
                    ") noexcept {\n"));
    out.append(text);
    out.append(std::string_view("  return true;\n}\n\n"));
    return name;
  }

  std::string series_part(Buffer& out, std::size_t p, int function) {
    function_ = function;
    pointers_.clear();
    std::string body;
    const std::size_t end = std::min(plan_.coefficient.size(), (p + 1) * part_size);
    for (std::size_t i = p * part_size; i < end; ++i) series_statement(body, plan_.coefficient[i]);
    const std::string name = fmt::format("{}_part{}", signature(k_.id).name, p + 1);
    fmt::format_to(std::back_inserter(out), "// {}: {}, coefficient k, part {} of {}\n", m_.name,
                   signature(k_.id).name, p + 1, (plan_.coefficient.size() + part_size - 1) / part_size);
    const std::string text = pointer_declarations() + body;
    std::vector<std::string> ps{parameter("int", "k", text), parameter("const double*", "u", text),
                                parameter("const double*", "p", text), parameter("const double*", "qk", text),
                                parameter("double*", "qdk", text), parameter("const double*", "w", text),
                                parameter("const double*", "h", text),
                                parameter("double*", "x", text), parameter("double*", "work", text),
                                parameter("std::ptrdiff_t", "n", text)};
    if (sys_.looped) ps.push_back(parameter("double*", "dense", text));
    out.append(wrap(fmt::format("static void {}(", name), ps, ") noexcept {\n"));
    out.append(text);
    out.append(std::string_view("}\n\n"));
    return name;
  }

  // Histories [p part_size, (p + 1) part_size) into h[] (split kernels).
  std::string history_part(Buffer& out, std::size_t p, int function) {
    function_ = function;
    pointers_.clear();
    const std::size_t first = p * part_size, last = std::min(histories_.size(), first + part_size);
    const std::string body = history_loop(first, last);
    const std::string name = fmt::format("{}_history{}", signature(k_.id).name, p + 1);
    fmt::format_to(std::back_inserter(out), "// {}: {}, histories of coefficient k, part {} of {}\n", m_.name,
                   signature(k_.id).name, p + 1, (histories_.size() + part_size - 1) / part_size);
    const std::string text = pointer_declarations() + body;
    out.append(wrap(fmt::format("static void {}(", name),
                    {"int k", "double* __restrict h", parameter("double*", "work", text),
                     parameter("std::ptrdiff_t", "n", text)},
                    ") noexcept {\n"));
    out.append(text);
    out.append(std::string_view("}\n\n"));
    return name;
  }

  // With quaternions in q (eom/model/free_joint.hpp; qk: nq rows, qdk: nv): the order-0 copies,
  // and q_coefficient(k), which gives q's coefficient k >= 1 from coefficients 0..k-1 of q and v:
  // q_k = (q̇)_(k-1) / k with q̇ = G(q) v, v's own for a plain coordinate and ½ q ⊗ (0, ω) for a
  // quaternion, bilinear in q and ω, so its coefficient k-1 is the Cauchy product
  // ½ Σ_(j<k) q_j ⊗ (0, ω_(k-1-j)).
  std::string floating_start() const {
    std::string text =
        "  for (int i = 0; i < nq; ++i) qk[i] = q[i];\n"
        "  for (int i = 0; i < nv; ++i) qdk[i] = qd[i];\n"
        "  // q's coefficient k from those below k of q and v: q' = G(q) v, a quaternion's rate\n"
        "  // 0.5 q (x) (0, w) bilinear, so its coefficients are Cauchy products.\n"
        "  const auto q_coefficient = [&](int k) noexcept {\n";
    // Runs of plain coordinates as loops, each quaternion as its product.
    int run_q = -1, run_v = 0, run_n = 0;
    const auto flush = [&] {
      if (run_n == 1)
        text += fmt::format("    qk[k * nq + {}] = qdk[(k - 1) * nv + {}] / k;\n", run_q, run_v);
      else if (run_n > 1)
        text += fmt::format("    for (int i = 0; i < {}; ++i) qk[k * nq + {} + i] = qdk[(k - 1) * nv + {} + i] / k;\n",
                            run_n, run_q, run_v);
      run_n = 0;
    };
    m_.layout().walk(
        [&](int i, int j) {
          if (run_n == 0) run_q = i, run_v = j;
          ++run_n;
        },
        [&](int i, int j) {
          flush();
          text += fmt::format(
              "    {{\n"
              "      double r0 = 0, r1 = 0, r2 = 0, r3 = 0;\n"
              "      for (int j = 0; j < k; ++j) {{\n"
              "        const double* a = qk + j * nq + {0};\n"
              "        const double* w = qdk + (k - 1 - j) * nv + {1};\n"
              "        r0 -= a[1] * w[0] + a[2] * w[1] + a[3] * w[2];\n"
              "        r1 += a[0] * w[0] + a[2] * w[2] - a[3] * w[1];\n"
              "        r2 += a[0] * w[1] + a[3] * w[0] - a[1] * w[2];\n"
              "        r3 += a[0] * w[2] + a[1] * w[1] - a[2] * w[0];\n"
              "      }}\n"
              "      qk[k * nq + {0}] = 0.5 * r0 / k;\n"
              "      qk[k * nq + {2}] = 0.5 * r1 / k;\n"
              "      qk[k * nq + {3}] = 0.5 * r2 / k;\n"
              "      qk[k * nq + {4}] = 0.5 * r3 / k;\n"
              "    }}\n",
              i, j, i + 1, i + 2, i + 3);
        });
    flush();
    return text + "  };\n";
  }

  void main(Buffer& out, const std::vector<std::string>& parts0, const std::vector<std::string>& partsk,
            const std::vector<std::string>& history_parts) {
    function_ = 0;
    pointers_.clear();
    const Signature& sig = signature(k_.id);
    std::vector<NodeId> stored_inputs;  // copied into their series at order 0 and per coefficient
    for (NodeId n : plan_.nodes)
      if (g_[n].op == Op::Input && slot_[n] >= 0) stored_inputs.push_back(n);
    const std::string w = shared_.empty() ? "nullptr" : "w", x = scratch_.empty() ? "nullptr" : "x";

    std::string body = m_.floating() ? floating_start()
                                     : "  for (int i = 0; i < nq; ++i) {\n    qk[i] = q[i];\n    qdk[i] = qd[i];\n  }\n";
    body += "  // Order 0: the forward dynamics (its guards included), the first coefficients.\n";
    for (NodeId n : stored_inputs) body += fmt::format("  {}[0] = {};\n", series(n), value(n));
    if (split_) {
      for (const std::string& part : parts0)
        body += wrap(fmt::format("  if (!{}(", part), {"t", "q", "qd", "u", "p", "qdk", w, "work", "n"},
                     ")) return fail();\n");
    } else {
      for (const TaylorStep& step : plan_.order0) order0_statement(body, step.node, "fail()");
    }
    for (NodeId n : plan_.nodes)  // q̈ or μ that are leaves
      if (arity(g_[n].op) == 0) results0(body, n);
    if (sys_.looped) dense_order0(body);

    body += "  // Coefficient k of every series from those below k.\n";
    body += "  for (int k = 1; k < order; ++k) {\n";
    body += m_.floating() ? "    q_coefficient(k);\n"
                          : "    for (int i = 0; i < nq; ++i) qk[k * nq + i] = qdk[(k - 1) * nq + i] / k;\n";
    std::string loop;
    for (NodeId n : stored_inputs) loop += fmt::format("  {}[k] = {};\n", series(n), input_coefficient(n));
    const std::string h = histories_.empty() ? "nullptr" : "h";
    if (split_) {
      if (!histories_.empty()) loop += "  // The sums over coefficients 1..k-1 of every recurrence.\n";
      for (const std::string& part : history_parts) loop += fmt::format("  {}(k, h, work, n);\n", part);
      std::vector<std::string> args{"k", "u", "p", "qk", "qdk", w, h, x, "work", "n"};
      if (sys_.looped) args.emplace_back("dense");
      for (const std::string& part : partsk) loop += wrap(fmt::format("  {}(", part), args, ");\n");
    } else {
      std::string statements;
      for (const TaylorStep& item : plan_.coefficient) {
        if (item.kind == Kind::rhs && item.index == 0)
          statements += "  // The right-hand side of coefficient k, solved by the order-0 factors.\n";
        series_statement(statements, item);
      }
      if (!histories_.empty()) loop += "  // The sums over coefficients 1..k-1 of every recurrence, in one loop.\n";
      loop += history_loop(0, histories_.size()) + statements;
    }
    for (std::size_t at = 0; at < loop.size();) {  // indented into the loop
      const std::size_t eol = loop.find('\n', at);
      body += "  " + loop.substr(at, eol - at + 1);
      at = eol + 1;
    }
    body += "  }\n";
    body += m_.floating() ? "  q_coefficient(order);\n"
                          : "  for (int i = 0; i < nq; ++i) qk[order * nq + i] = qdk[(order - 1) * nq + i] / order;\n";
    body += "  // High orders of a nearly singular motion may overflow.\n";
    body += fmt::format("  if (!all_finite(qk, nq * (order + 1)) || !all_finite(qdk, {} * (order + 1))) return fail();\n",
                        nv_);
    body += "  return true;\n";

    std::string text(
        "  const auto fail = [&]() noexcept {\n"
        "    if (order >= 0) {\n"
        "      fill_nan(qk, nq * (order + 1));\n"
        "      fill_nan(qdk, " + nv_ + " * (order + 1));\n"
        "    }\n"
        "    return false;\n"
        "  };\n");
    std::vector<std::string> tests{"order < 1", "order > taylor_max_order", "!is_finite(t)",
                                   "!all_finite(q, nq)", fmt::format("!all_finite(qd, {})", nv_)};
    if (m_.nu > 0) tests.emplace_back("!all_finite(u, nu)");
    if (m_.np() > 0) tests.emplace_back("!all_finite(p, np)");
    text += wrap("  if (", tests, ") return fail();\n", " ||");
    const std::string rest = pointer_declarations() + body;
    if (mentions(rest, "n")) text += "  const std::ptrdiff_t n = order + 1;  // coefficients per series\n";
    // The arrays that cross parts live in `scratch` (the caller's, or the plain overload's stack).
    std::size_t at = 0;
    const auto array = [&](std::string_view name, std::size_t size, std::string_view what) {
      if (size == 0) return;
      text += at == 0 ? fmt::format("  double* const {} = scratch;  // {}\n", name, what)
                      : fmt::format("  double* const {} = scratch + {};  // {}\n", name, at, what);
      at += size;
    };
    array("w", shared_.size(), "order-0 values read by other parts");
    array("x", scratch_.empty() ? 0 : static_cast<std::size_t>(scratch_size_),
          "coefficient-k values read by other parts");
    array("h", split_ ? histories_.size() : 0, "histories of coefficient k");
    array("dense", static_cast<std::size_t>(dense_size()),
          "the dense routine's system and factors, q̈_0, coefficient k's right-hand side and q̈_k");
    scratch_doubles_ = at;
    text += rest + "}\n";

    fmt::format_to(std::back_inserter(out),
                   "// {}: {} ({} operations at order 0; per coefficient {} series, {} by recurrence, "
                   "{} convolution tail{}, {}; {} stored series{})\n",
                   m_.name, sig.name, plan_.order0.size(), plan_.series, plan_.recurrences, plan_.tails,
                   plan_.tails == 1 ? "" : "s",
                   sys_.looped ? fmt::format("the looped dense solve of {} + {} unknowns", sys_.nq, sys_.nc)
                               : fmt::format("{} solve step{}", plan_.solve_nodes.size(),
                                             plan_.solve_nodes.size() == 1 ? "" : "s"),
                   slot_count_,
                   split_ ? fmt::format(", in {} + {} parts", parts0.size(), partsk.size()) : "");
    const std::vector<std::string> ps{"int order", "double t", "const double* q", "const double* qd",
                                      parameter("const double*", "u", text),
                                      parameter("const double*", "p", text), "double* qk", "double* qdk",
                                      "double* work"};
    if (scratch_doubles_ == 0) {
      out.append(wrap(fmt::format("bool {}(", sig.name), ps, ") noexcept {\n"));
      out.append(text);
      return;
    }
    std::vector<std::string> with_scratch = ps;
    with_scratch.emplace_back("double* scratch");
    out.append(wrap(fmt::format("bool {}(", sig.name), with_scratch, ") noexcept {\n"));
    out.append(text);
    // The plain signature lends the overload its scratch on the stack.
    out.append(std::string_view("\n"));
    out.append(lending_overload(sig, scratch_doubles_));
  }

  const TracedModel& m_;
  const Graph& g_;
  const Kernel& k_;
  const TaylorPlan plan_;
  const TaylorSystem& sys_;
  const std::string nv_;  // the header's name of qd's and qdk's rows: nq where nv = nq
  std::vector<int> index_;
  std::vector<char> is_guard_;
  std::map<NodeId, std::vector<int>> qdd_of_, mu_of_;  // the q̈ and μ entries a node is
  bool split_ = false;
  bool by_sincos_n_ = false;  // the inputs' sines and cosines by the source's sincos_n
  std::vector<int> slot_, aux_slot_;
  int qdd_slot_ = 0, slot_count_ = 0;
  // Writing: the current function and its series pointers; crossing values (split).
  int function_ = 0;
  std::map<int, std::pair<std::string, std::string>> pointers_;  // slot -> name, comment
  bool recording_ = false;
  std::map<Key, int> defined_in_;
  std::set<Key> crossing_;
  std::vector<Key> definitions_;  // in the order they are written
  std::map<Key, int> last_read_;  // the last function reading a crossing value
  std::map<Key, int> shared_, scratch_;  // w[] and x[] indices
  int scratch_size_ = 0;                 // x[]
  std::size_t scratch_doubles_ = 0;      // w[], x[] and h[] together: the `scratch` overload's size
  // Histories of the coefficient-k pass: a taylor_history_<kind> term over two series.
  struct History {
    std::string text, a, b;
  };
  std::vector<History> histories_;
  std::map<std::string, int> history_index_;                         // text -> index
  std::map<std::string, std::pair<int, std::string>> pointer_slot_;  // series name -> slot, comment
};

}  // namespace

std::size_t write_taylor_kernel(const TracedModel& m, const Kernel& k, Buffer& out,
                                std::size_t& workspace, std::size_t& scratch) {
  TaylorWriter w(m, k);
  return w.write(out, workspace, scratch);
}

}  // namespace eom::gen::detail
