#include "eomgen/taylor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "dense_solve.hpp"
#include "ops/table.hpp"

namespace eom::gen {

namespace detail {
// The recurrences, compiled here for evaluate_taylor(); the emitter copies the same text into
// every generated source, so both run the same arithmetic.
#include "taylor_recurrences.inc"
}  // namespace detail

namespace {

// t, q, q̇ are series; u, p constants; q̈ is no input of the motion (and rhs only of the solve).
bool varying_input(const Node& node) {
  const auto kind = static_cast<InputKind>(node.arg[0]);
  if (kind == InputKind::qdd || kind == InputKind::rhs || kind == InputKind::mu ||
      kind == InputKind::kd || kind == InputKind::rho || kind == InputKind::restitution)
    throw std::logic_error("eomgen: Taylor mode on a graph that reads " + std::string(name(kind)));
  return kind == InputKind::t || kind == InputKind::q || kind == InputKind::qd;
}

bool is_rhs(const Node& node) {
  return node.op == Op::Input && static_cast<InputKind>(node.arg[0]) == InputKind::rhs;
}

// Node n as its table entry's taylor_plan() and taylor_aux_count() see it (ops/op.hpp).
struct PlanStep {
  TaylorPlan& plan;
  const Graph& g;
  NodeId n;
  bool nonlinear = true, own_history = true;

  bool varying(int i) const { return plan.varying[g[n].arg[i]]; }
  bool paired() const { return plan.partner[n] != 0; }
  // The recurrence reads argument i's lower coefficients.
  void history(int i) {
    if (varying(i)) plan.stored[g[n].arg[i]] = 1;
  }
  // Coefficient k from the arguments' coefficient k alone.
  void linear() { nonlinear = own_history = false; }
  void no_own_history() { own_history = false; }
};

// Which nodes of plan.nodes are series, which of them `roots` need at k >= 1 and whose history
// the recurrences read; the auxiliary series.
void classify(const Graph& g, TaylorPlan& plan, std::span<const NodeId> roots) {
  const std::size_t size = g.size();
  plan.varying.assign(size, 0);
  plan.needed.assign(size, 0);
  plan.stored.assign(size, 0);
  plan.nonlinear.assign(size, 0);
  plan.partner.assign(size, 0);
  plan.first_aux.assign(size, -1);
  std::vector<char> in_cone(size, 0);
  for (NodeId n : plan.nodes) in_cone[n] = 1;

  // Forward: which nodes are series. A select's condition is decided at order 0, so only its
  // branches make it vary; booleans are order-0 values.
  for (NodeId n : plan.nodes) {
    const Node& node = g[n];
    if (node.op == Op::Const || is_boolean(node.op)) continue;
    if (node.op == Op::Input) {
      plan.varying[n] = varying_input(node);
      continue;
    }
    for (int i = ops::info(node.op).conditions; i < arity(node.op); ++i)
      plan.varying[n] |= plan.varying[node.arg[i]];
  }

  // Backward: which series the roots need at k >= 1, and whose history the recurrences read.
  for (NodeId n : roots) plan.needed[n] = plan.varying[n];
  for (auto it = plan.nodes.rbegin(); it != plan.nodes.rend(); ++it) {
    const NodeId n = *it;
    const Node& node = g[n];
    if (!plan.needed[n] || arity(node.op) == 0) continue;
    const ops::Info& op = ops::info(node.op);
    for (int i = op.conditions; i < op.arity; ++i)
      if (plan.varying[node.arg[i]]) plan.needed[node.arg[i]] = 1;
    PlanStep step{plan, g, n};
    ops::visit(node.op, [&](auto entry) { decltype(entry)::taylor_plan(step); });
    if (op.partner != ops::no_partner) {  // computed as one pair (sin, cos)
      const auto other = g.find(op.partner, node.arg[0]);
      if (other && in_cone[*other]) {
        plan.partner[n] = *other;
        plan.partner[*other] = n;
        plan.needed[*other] = plan.stored[*other] = plan.nonlinear[*other] = 1;
      }
    }
    plan.nonlinear[n] = step.nonlinear;
    if (step.own_history) plan.stored[n] = 1;
  }

  // Auxiliary series, in id order of their owners.
  for (NodeId n : plan.nodes) {
    if (!plan.needed[n]) continue;
    const PlanStep step{plan, g, n};
    const int count = ops::visit(g[n].op, [&](auto entry) { return decltype(entry)::taylor_aux_count(step); });
    for (int which = 0; which < count; ++which) {
      if (plan.first_aux[n] < 0) plan.first_aux[n] = static_cast<int>(plan.aux.size());
      plan.aux.push_back({n, which});
    }
  }
}

void count(const Graph& g, TaylorPlan& plan) {
  for (NodeId n : plan.nodes) {
    const bool op = arity(g[n].op) > 0;
    plan.operations += op;
    plan.series += op && plan.needed[n];
    plan.recurrences += op && plan.needed[n] && plan.nonlinear[n];
    plan.slots += plan.stored[n];
  }
  plan.slots += plan.aux.size();
}

// The order-0 values read later. Plain mode: all. System mode: q̈, μ, the guards, what the dense
// routine reads, stored series (their recurrences read coefficient 0), the scalars coefficient k
// reads (factors of the solve, constant operands), and the arguments of all those. A node of the
// system read only at k >= 1 (a force entry the order-0 solve folded away) has no order-0
// statement.
std::vector<char> live_at_order0(const Graph& g, const TaylorPlan& plan,
                                 std::span<const NodeId> guards) {
  std::vector<char> live(g.size(), 0);
  if (!plan.system) {
    for (NodeId n : plan.nodes) live[n] = 1;
    return live;
  }
  const TaylorSystem& sys = *plan.system;
  for (NodeId n : sys.qdd) live[n] = 1;
  for (NodeId n : sys.mu) live[n] = 1;
  for (NodeId n : guards) live[n] = 1;
  if (sys.looped)
    for (auto [n, position] : dense_system_entries(sys)) live[n] = 1;
  for (NodeId n : plan.nodes) {
    if (plan.stored[n] || plan.first_aux[n] >= 0) live[n] = 1;
    if (!plan.needed[n]) continue;
    for (int i = 0; i < arity(g[n].op); ++i)
      if (!plan.varying[g[n].arg[i]]) live[g[n].arg[i]] = 1;
  }
  for (NodeId n : plan.solve_nodes)
    for (int i = 0; i < arity(g[n].op); ++i)
      if (!plan.solve[g[n].arg[i]]) live[g[n].arg[i]] = 1;
  for (auto it = plan.nodes.rbegin(); it != plan.nodes.rend(); ++it)
    if (live[*it])
      for (int i = 0; i < arity(g[*it].op); ++i) live[g[*it].arg[i]] = 1;
  return live;
}

// The two passes (TaylorPlan::order0, coefficient).
void schedule(const Graph& g, TaylorPlan& plan, std::span<const NodeId> guards) {
  using Kind = TaylorStep::Kind;
  const std::vector<char> live = live_at_order0(g, plan, guards);
  std::vector<char> done(g.size(), 0);
  for (NodeId n : plan.nodes) {
    if (done[n] || !live[n] || arity(g[n].op) == 0) continue;
    plan.order0.push_back({Kind::node, n});
    done[n] = 1;
    if (const Op pair = ops::info(g[n].op).partner; pair != ops::no_partner) {
      const auto other = g.find(pair, g[n].arg[0]);
      if (other && live[*other] && !done[*other]) {
        plan.order0.push_back({Kind::node, *other});
        done[*other] = 1;
      }
    }
  }
  for (NodeId n : plan.nodes) {
    if (!plan.needed[n] || arity(g[n].op) == 0) continue;
    if (plan.partner[n] && plan.partner[n] < n) continue;  // computed with its partner
    plan.coefficient.push_back({Kind::node, n});
  }
  if (!plan.system) return;
  const TaylorSystem& sys = *plan.system;
  for (int i = 0; i < sys.nq + sys.nc; ++i) plan.coefficient.push_back({Kind::rhs, 0, i});
  if (sys.looped) plan.coefficient.push_back({Kind::dense_solve});
  for (NodeId n : plan.solve_nodes) plan.coefficient.push_back({Kind::node, n});
  for (int i = 0; i < sys.nq; ++i) plan.coefficient.push_back({Kind::result_qdd, 0, i});
  for (int i = 0; i < sys.nc; ++i) plan.coefficient.push_back({Kind::result_mu, 0, i});
}

}  // namespace

std::vector<std::pair<NodeId, int>> dense_system_entries(const TaylorSystem& s) {
  const int n = s.nq, nc = s.nc;
  std::vector<std::pair<NodeId, int>> out;
  // M's lower triangle row by row, so the stores run over consecutive addresses (written out of
  // order, they cost GCC's SLP vectorizer 2.3 GB and half the compile at N = 100)
  for (int i = 0; i < n; ++i)
    for (int j = 0; j <= i; ++j) out.emplace_back(s.mass[i + n * j], j + n * i);
  for (int i = 0; i < n; ++i) out.emplace_back(s.force[i], n * n + i);
  for (int i = 0; i < nc * n; ++i) out.emplace_back(s.jacobian[i], n * n + n + i);
  for (int i = 0; i < nc; ++i) out.emplace_back(s.bias[i], n * n + n + nc * n + i);
  return out;
}

TaylorPlan make_taylor_plan(const Graph& g, std::span<const NodeId> outputs,
                            std::span<const NodeId> guards) {
  TaylorPlan plan;
  std::vector<NodeId> roots(outputs.begin(), outputs.end());
  roots.insert(roots.end(), guards.begin(), guards.end());
  plan.nodes = cone(g, roots);
  classify(g, plan, outputs);
  plan.solve.assign(g.size(), 0);
  count(g, plan);
  schedule(g, plan, guards);
  return plan;
}

TaylorPlan make_taylor_plan(const Graph& g, const TaylorSystem& system,
                            std::span<const NodeId> guards) {
  TaylorPlan plan;
  plan.system = system;
  const int nq = system.nq, nc = system.nc;
  // The per-coefficient solve: the nodes that depend on the right-hand side, and the order-0
  // factors they read.
  std::vector<NodeId> solution = system.solve_qdd;
  solution.insert(solution.end(), system.solve_mu.begin(), system.solve_mu.end());
  plan.solve.assign(g.size(), 0);
  std::vector<NodeId> factors;
  for (NodeId n : cone(g, solution)) {
    const Node& node = g[n];
    if (is_rhs(node)) plan.solve[n] = 1;
    for (int i = 0; i < arity(node.op); ++i) plan.solve[n] |= plan.solve[node.arg[i]];
    if (!plan.solve[n] || arity(node.op) == 0) continue;
    const bool a = plan.solve[node.arg[0]], b = arity(node.op) > 1 && plan.solve[node.arg[1]];
    const Op op = node.op;
    const bool linear = op == Op::Neg || ((op == Op::Add || op == Op::Sub) && a && b) ||
                        (op == Op::Mul && a != b) || (op == Op::Div && a && !b);
    if (!linear) throw std::logic_error("eomgen: Taylor mode: a solve step that is not linear");
    plan.solve_nodes.push_back(n);
    for (int i = 0; i < arity(node.op); ++i)
      if (!plan.solve[node.arg[i]]) factors.push_back(node.arg[i]);
  }
  // Order 0: the forward dynamics (guards, multipliers), the system, the factors.
  std::vector<NodeId> model = system.mass;
  for (const std::vector<NodeId>* v : {&system.force, &system.jacobian, &system.bias})
    model.insert(model.end(), v->begin(), v->end());
  std::vector<NodeId> roots = system.qdd;
  roots.insert(roots.end(), system.mu.begin(), system.mu.end());
  roots.insert(roots.end(), factors.begin(), factors.end());
  roots.insert(roots.end(), model.begin(), model.end());  // (only varying ones are read)
  roots.insert(roots.end(), guards.begin(), guards.end());
  plan.nodes = cone(g, roots);
  // Coefficients k >= 1: the series of M, f, C, γ; those of M and C are convolved (the tails).
  classify(g, plan, model);
  for (const std::vector<NodeId>* v : {&system.mass, &system.jacobian})
    for (NodeId n : *v)
      if (plan.varying[n]) plan.stored[n] = 1;
  for (int i = 0; i < nq; ++i) {
    for (int l = 0; l < nq; ++l) plan.tails += plan.varying[system.mass[i + nq * l]];
    for (int c = 0; c < nc; ++c) plan.tails += 2 * plan.varying[system.jacobian[c + nc * i]];
  }
  count(g, plan);
  plan.slots += nq + nc;  // the series of q̈ and μ
  schedule(g, plan, guards);
  return plan;
}

namespace {

// The plan run in double on vectors: every node keeps all its coefficients.
class SeriesRun {
 public:
  SeriesRun(const Graph& g, const TaylorPlan& plan, int order)
      : g_(g), plan_(plan), s_(g.size()), aux_(plan.aux.size(), std::vector<double>(order + 1)) {
    if (order < 0) throw std::invalid_argument("eomgen: negative Taylor order");
    for (NodeId n : plan.nodes) s_[n].assign(order + 1, 0.0);
    if (plan.system) {
      qdd_.assign(plan.system->nq, std::vector<double>(order + 1, 0.0));
      mu_.assign(plan.system->nc, std::vector<double>(order + 1, 0.0));
      solved_.assign(g.size(), 0.0);
      b_.assign(plan.system->nq + plan.system->nc, 0.0);
      if (plan.system->looped) {
        const int n = plan.system->nq, nc = plan.system->nc;
        dense_.assign(dense::DenseLayout(n, nc).size, 0.0);
        column_.assign(n + nc, 0.0);
        x_.assign(n, 0.0);
      }
    }
  }

  double at(NodeId n, int k) const { return s_[n][k]; }
  double qdd(int i, int k) const { return qdd_[i][k]; }

  // Order 0: the plan's order-0 pass, each node by apply() as the forward dynamics computes it,
  // then its auxiliaries; q̈_0 and μ_0.
  template <class Input> void order0(Input input) {
    for (NodeId n : plan_.nodes) {
      const Node& node = g_[n];
      if (node.op == Op::Const) s_[n][0] = node.value;
      else if (node.op == Op::Input) s_[n][0] = input(n, 0);
    }
    for (const TaylorStep& step : plan_.order0) {
      const NodeId n = step.node;
      const Node& node = g_[n];
      s_[n][0] = apply(node.op, v(node.arg[0]), v(node.arg[1]), v(node.arg[2]));
      if (plan_.first_aux[n] >= 0) {
        Order0 rule{*this, n};
        ops::visit(node.op, [&](auto entry) { decltype(entry)::taylor_order0(rule); });
      }
    }
    if (plan_.system && plan_.system->looped) {
      dense_order0();
    } else if (plan_.system) {
      for (std::size_t i = 0; i < qdd_.size(); ++i) qdd_[i][0] = v(plan_.system->qdd[i]);
      for (std::size_t i = 0; i < mu_.size(); ++i) mu_[i][0] = v(plan_.system->mu[i]);
    }
  }

  // Coefficient k >= 1: the varying inputs' from `input`, then the plan's coefficient pass.
  template <class Input> void coefficient(int k, Input input) {
    for (NodeId n : plan_.nodes)
      if (plan_.needed[n] && g_[n].op == Op::Input) s_[n][k] = input(n, k);
    for (const TaylorStep& step : plan_.coefficient) run(step, k);
  }

 private:
  // The contexts the table's Taylor rules run in (ops/op.hpp): values are doubles, series arrays.
  struct Order0 {  // coefficient 0 of node n's auxiliaries
    SeriesRun& r;
    NodeId n;
    double v(int i) const { return r.v(r.g_[n].arg[i]); }
    double self_v() const { return r.v(n); }
    double aux0(int j) const { return r.aux_[r.plan_.first_aux[n] + j][0]; }
    void set_aux0(int j, double e) { r.aux_[r.plan_.first_aux[n] + j][0] = e; }
    double constant(double d) const { return d; }
    double apply(Op op, double a, double b = 0, double c = 0) const { return gen::apply(op, a, b, c); }
  };
  struct Step {  // coefficient k of node n
    SeriesRun& r;
    NodeId n;
    int k;
    NodeId arg(int i) const { return r.g_[n].arg[i]; }
    bool varying(int i) const { return r.plan_.varying[arg(i)]; }
    bool same_args() const { return arg(0) == arg(1); }
    bool paired() const { return r.plan_.partner[n] != 0; }
    double c(int i) const { return varying(i) ? r.s_[arg(i)][k] : 0.0; }
    double v(int i) const { return r.v(arg(i)); }
    double self_v() const { return r.v(n); }
    double* S(int i) const { return r.s_[arg(i)].data(); }
    double* self_S() const { return r.s_[n].data(); }
    double* partner_S() const { return r.s_[r.plan_.partner[n]].data(); }
    double* aux(int j) const { return r.aux_[r.plan_.first_aux[n] + j].data(); }
    void self(double e) const { r.s_[n][k] = e; }
    void set(double* s, double e) const { s[k] = e; }
    double constant(double d) const { return d; }
    double apply(Op op, double a, double b = 0, double c = 0) const { return gen::apply(op, a, b, c); }
    double product(const double* a, const double* b) const { return detail::taylor_product(a, b, k); }
    double square(const double* a) const { return detail::taylor_square(a, k); }
    double integral(const double* a, const double* b) const { return detail::taylor_integral(a, b, k); }
    double inverse_integral(double ak, const double* b, const double* c) const {
      return detail::taylor_inverse_integral(ak, b, c, k);
    }
    double quotient(double ak, const double* b, const double* c) const {
      return detail::taylor_quotient(ak, b, c, k);
    }
    double root(double ak, const double* c) const { return detail::taylor_sqrt(ak, c, k); }
    double cross(const double* y, const double* x) const { return detail::taylor_cross(y, x, k); }
    double power(const double* a, const double* c, double r) const { return detail::taylor_pow(a, c, r, k); }
  };

  // One step of coefficient k's pass. System mode: q̈_k and μ_k from the right-hand side
  // (eomgen/taylor.hpp),
  //   b_i      = f_k − Σ_l tail(M_il, q̈_l) − Σ_c tail(C_ci, μ_c)     (i < nq)
  //   b_(nq+c) = γ_k + Σ_l tail(C_cl, q̈_l)                            (c < nc)
  // (terms of constant entries vanish), solved by the order-0 factors: the solve's nodes are
  // linear in b, with order-0 factors.
  void run(const TaylorStep& step, int k) {
    using Kind = TaylorStep::Kind;
    switch (step.kind) {
      case Kind::node: {
        const NodeId n = step.node;
        const Node& node = g_[n];
        if (plan_.solve[n]) {
          auto operand = [&](int i) {
            return plan_.solve[node.arg[i]] ? x(node.arg[i]) : v(node.arg[i]);
          };
          solved_[n] = apply(node.op, operand(0), arity(node.op) > 1 ? operand(1) : 0.0);
          return;
        }
        Step rule{*this, n, k};
        ops::visit(node.op, [&](auto entry) {
          using Entry = decltype(entry);
          if constexpr (Entry::kind == ops::Kind::real)
            Entry::taylor(rule);
          else
            throw std::logic_error("eomgen: Taylor mode: a series of " + std::string(Entry::name));
        });
        return;
      }
      case Kind::rhs: b_[step.index] = right_hand_side(step.index, k); return;
      case Kind::dense_solve:  // on the factors of order 0; μ_k comes back in the column
        column_ = b_;
        dense::dense_columns(plan_.system->nq, plan_.system->nc, dense_.data(), column_.data(), 1, x_.data());
        return;
      case Kind::result_qdd: {
        if (plan_.system->looped) {
          qdd_[step.index][k] = x_[step.index];
          return;
        }
        const NodeId r = plan_.system->solve_qdd[step.index];
        qdd_[step.index][k] = plan_.solve[r] ? x(r) : 0.0;
        return;
      }
      case Kind::result_mu: {
        if (plan_.system->looped) {
          mu_[step.index][k] = column_[plan_.system->nq + step.index];
          return;
        }
        const NodeId r = plan_.system->solve_mu[step.index];
        mu_[step.index][k] = plan_.solve[r] ? x(r) : 0.0;
        return;
      }
    }
  }

  // The looped form's order 0: M, f, C, γ into the dense routine's array, its solve (keeping the
  // factors for every coefficient); q̈_0 and μ_0, NaN where the kernel would fail.
  void dense_order0() {
    const TaylorSystem& sys = *plan_.system;
    const int n = sys.nq, nc = sys.nc;
    for (auto [node, position] : dense_system_entries(sys)) dense_[position] = v(node);
    std::vector<double> qdd(n), w(std::max(n, nc));
    if (!dense::dense_system(n, nc, dense_.data(), qdd.data(), w.data()))
      std::fill(qdd.begin(), qdd.end(), std::numeric_limits<double>::quiet_NaN());
    for (int i = 0; i < n; ++i) qdd_[i][0] = qdd[i];
    for (int c = 0; c < nc; ++c) mu_[c][0] = dense_[dense::DenseLayout(n, nc).mu + c];
  }

  // Row i of the right-hand side, the terms in the order the kernel sums them.
  double right_hand_side(int i, int k) const {
    using namespace detail;
    const TaylorSystem& sys = *plan_.system;
    const int nq = sys.nq, nc = sys.nc;
    const bool force = i < nq;
    const NodeId leading = force ? sys.force[i] : sys.bias[i - nq];
    bool first = !plan_.varying[leading];
    double sum = first ? 0.0 : s_[leading][k];
    auto tail = [&](NodeId entry, const std::vector<double>& series) {
      if (!plan_.varying[entry]) return;
      const double t = taylor_tail(s_[entry].data(), series.data(), k);
      sum = first ? (force ? -t : t) : force ? sum - t : sum + t;
      first = false;
    };
    if (force) {
      for (int l = 0; l < nq; ++l) tail(sys.mass[i + nq * l], qdd_[l]);
      for (int c = 0; c < nc; ++c) tail(sys.jacobian[c + nc * i], mu_[c]);
    } else {
      for (int l = 0; l < nq; ++l) tail(sys.jacobian[(i - nq) + nc * l], qdd_[l]);
    }
    return sum;
  }

  // A node of the solve at the current k: a right-hand side entry, or a step already run.
  double x(NodeId n) const { return is_rhs(g_[n]) ? b_[g_[n].arg[1]] : solved_[n]; }

  // The order-0 value (0 for an unused argument slot, which names node 0 outside the cone).
  double v(NodeId x) const { return s_[x].empty() ? 0.0 : s_[x][0]; }

  const Graph& g_;
  const TaylorPlan& plan_;
  std::vector<std::vector<double>> s_, aux_;
  std::vector<std::vector<double>> qdd_, mu_;  // system mode: the series of q̈ and μ
  std::vector<double> solved_;                 // system mode: the solve's nodes at the current k
  std::vector<double> b_;                      // system mode: the right-hand side at the current k
  // The looped form: the dense routine's array (its factors after order 0), the column it solves
  // at the current k (μ_k after the solve), q̈_k.
  std::vector<double> dense_, column_, x_;
};

double input_value(const Node& node, const Point& x) {
  const std::size_t i = node.arg[1];
  auto at = [&](const std::vector<double>& v) {
    if (i >= v.size()) throw std::out_of_range("eomgen: Taylor mode needs more inputs");
    return v[i];
  };
  switch (static_cast<InputKind>(node.arg[0])) {
    case InputKind::t: return x.t;
    case InputKind::q: return at(x.q);
    case InputKind::qd: return at(x.qd);
    case InputKind::u: return at(x.u);
    case InputKind::p: return at(x.p);
    case InputKind::qdd: case InputKind::rhs: case InputKind::mu:
    case InputKind::kd: case InputKind::rho: case InputKind::restitution: break;
  }
  throw std::logic_error("eomgen: Taylor mode on a graph that reads qdd");
}

}  // namespace

std::vector<std::vector<double>> evaluate_taylor(const Graph& g, std::span<const NodeId> outputs,
                                                 const SeriesPoint& x, int order) {
  const TaylorPlan plan = make_taylor_plan(g, outputs);
  SeriesRun run(g, plan, order);
  auto input = [&](NodeId n, int k) {
    const Node& node = g[n];
    const std::size_t i = node.arg[1];
    auto coefficient = [&](const std::vector<double>& s) { return k < static_cast<int>(s.size()) ? s[k] : 0.0; };
    auto series = [&](const std::vector<std::vector<double>>& v) -> const std::vector<double>& {
      if (i >= v.size()) throw std::out_of_range("eomgen: evaluate_taylor needs more inputs");
      return v[i];
    };
    switch (static_cast<InputKind>(node.arg[0])) {
      case InputKind::t: return coefficient(x.t);
      case InputKind::q: return coefficient(series(x.q));
      case InputKind::qd: return coefficient(series(x.qd));
      case InputKind::u:
        if (i >= x.u.size()) throw std::out_of_range("eomgen: evaluate_taylor needs more inputs");
        return k == 0 ? x.u[i] : 0.0;
      case InputKind::p:
        if (i >= x.p.size()) throw std::out_of_range("eomgen: evaluate_taylor needs more inputs");
        return k == 0 ? x.p[i] : 0.0;
      case InputKind::qdd: case InputKind::rhs: case InputKind::mu:
      case InputKind::kd: case InputKind::rho: case InputKind::restitution: break;
    }
    throw std::logic_error("eomgen: Taylor mode on a graph that reads qdd");
  };
  run.order0(input);
  for (int k = 1; k <= order; ++k) run.coefficient(k, input);
  std::vector<std::vector<double>> out;
  for (NodeId n : outputs) {
    std::vector<double> c(order + 1, 0.0);
    c[0] = run.at(n, 0);
    for (int k = 1; k <= order; ++k) c[k] = plan.varying[n] ? run.at(n, k) : 0.0;
    out.push_back(std::move(c));
  }
  return out;
}

std::array<std::vector<double>, 2> taylor_ode(const Graph& g, const TaylorSystem& system,
                                              const Point& x, int order) {
  if (order < 1) throw std::invalid_argument("eomgen: taylor_ode needs order >= 1");
  const TaylorPlan plan = make_taylor_plan(g, system, {});
  const int nq = system.nq;
  std::vector<double> qk((order + 1) * nq), qdk((order + 1) * nq);
  for (int i = 0; i < nq; ++i) {
    qk[i] = x.q.at(i);
    qdk[i] = x.qd.at(i);
  }
  SeriesRun run(g, plan, order);
  auto input = [&](NodeId n, int k) {
    const Node& node = g[n];
    const int i = static_cast<int>(node.arg[1]);
    if (k == 0) return input_value(node, x);
    switch (static_cast<InputKind>(node.arg[0])) {
      case InputKind::t: return k == 1 ? 1.0 : 0.0;
      case InputKind::q: return qk[k * nq + i];
      case InputKind::qd: return qdk[k * nq + i];
      default: return 0.0;
    }
  };
  run.order0(input);
  for (int i = 0; i < nq; ++i) qdk[nq + i] = run.qdd(i, 0);
  for (int k = 1; k < order; ++k) {
    for (int i = 0; i < nq; ++i) qk[k * nq + i] = qdk[(k - 1) * nq + i] / k;
    run.coefficient(k, input);
    for (int i = 0; i < nq; ++i) qdk[(k + 1) * nq + i] = run.qdd(i, k) / (k + 1);
  }
  for (int i = 0; i < nq; ++i) qk[order * nq + i] = qdk[(order - 1) * nq + i] / order;
  return {qk, qdk};
}

}  // namespace eom::gen
