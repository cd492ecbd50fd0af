#include "eomgen/taylor.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

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
  if (kind == InputKind::qdd || kind == InputKind::rhs)
    throw std::logic_error("eomgen: Taylor mode on a graph that reads " + std::string(name(kind)));
  return kind == InputKind::t || kind == InputKind::q || kind == InputKind::qd;
}

bool is_rhs(const Node& node) {
  return node.op == Op::Input && static_cast<InputKind>(node.arg[0]) == InputKind::rhs;
}

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
    const int first = node.op == Op::Select ? 1 : 0;
    for (int i = first; i < arity(node.op); ++i) plan.varying[n] |= plan.varying[node.arg[i]];
  }

  // Backward: which series the roots need at k >= 1, and whose history the recurrences read.
  for (NodeId n : roots) plan.needed[n] = plan.varying[n];
  for (auto it = plan.nodes.rbegin(); it != plan.nodes.rend(); ++it) {
    const NodeId n = *it;
    const Node& node = g[n];
    if (!plan.needed[n] || arity(node.op) == 0) continue;
    const NodeId a = node.arg[0], b = node.arg[1];
    const bool va = plan.varying[a], vb = arity(node.op) > 1 && plan.varying[b];
    const int first = node.op == Op::Select ? 1 : 0;
    for (int i = first; i < arity(node.op); ++i)
      if (plan.varying[node.arg[i]]) plan.needed[node.arg[i]] = 1;
    auto history = [&](NodeId x) {
      if (plan.varying[x]) plan.stored[x] = 1;
    };
    bool nonlinear = true, own_history = true;
    switch (node.op) {
      case Op::Neg: case Op::Add: case Op::Sub: case Op::Select:
        nonlinear = own_history = false;
        break;
      case Op::Abs:  // the sign of a_0 decides
        history(a);
        nonlinear = own_history = false;
        break;
      case Op::Mul:
        nonlinear = va && vb;
        if (nonlinear) history(a), history(b);
        own_history = false;
        break;
      case Op::Div:  // the numerator's coefficient k only
        nonlinear = own_history = vb;
        history(b);
        break;
      case Op::Sqrt: break;
      case Op::Exp: case Op::Log: case Op::Tan: case Op::Asin: case Op::Acos: case Op::Atan:
        history(a);
        break;
      case Op::Sin: case Op::Cos: {
        history(a);
        const auto other = g.find(node.op == Op::Sin ? Op::Cos : Op::Sin, a);
        if (other && in_cone[*other]) {
          plan.partner[n] = *other;
          plan.partner[*other] = n;
          plan.needed[*other] = plan.stored[*other] = plan.nonlinear[*other] = 1;
        }
        break;
      }
      case Op::Pow: case Op::Atan2: case Op::Hypot:
        history(a);
        history(b);
        break;
      default:
        throw std::logic_error("eomgen: Taylor mode has no rule for " + std::string(name(node.op)));
    }
    plan.nonlinear[n] = nonlinear;
    if (own_history) plan.stored[n] = 1;
  }

  // Auxiliary series, in id order of their owners.
  for (NodeId n : plan.nodes) {
    if (!plan.needed[n]) continue;
    const Node& node = g[n];
    auto add = [&](TaylorAux kind) {
      if (plan.first_aux[n] < 0) plan.first_aux[n] = static_cast<int>(plan.aux.size());
      plan.aux.push_back({n, kind});
    };
    switch (node.op) {
      case Op::Sin: if (!plan.partner[n]) add(TaylorAux::cos_of_sin); break;
      case Op::Cos: if (!plan.partner[n]) add(TaylorAux::sin_of_cos); break;
      case Op::Tan: add(TaylorAux::tan_square); break;
      case Op::Asin: case Op::Acos: add(TaylorAux::root); break;
      case Op::Atan: add(TaylorAux::one_plus_square); break;
      case Op::Atan2: add(TaylorAux::norm_square); break;
      case Op::Pow:
        if (plan.varying[node.arg[0]] && plan.varying[node.arg[1]]) {
          add(TaylorAux::log_base);
          add(TaylorAux::exponent);
        }
        break;
      default: break;
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

}  // namespace

TaylorPlan make_taylor_plan(const Graph& g, std::span<const NodeId> outputs,
                            std::span<const NodeId> guards) {
  TaylorPlan plan;
  std::vector<NodeId> roots(outputs.begin(), outputs.end());
  roots.insert(roots.end(), guards.begin(), guards.end());
  plan.nodes = cone(g, roots);
  classify(g, plan, outputs);
  plan.solve.assign(g.size(), 0);
  count(g, plan);
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
    }
  }

  double at(NodeId n, int k) const { return s_[n][k]; }
  double qdd(int i, int k) const { return qdd_[i][k]; }

  // Order 0: every node by apply(), as the forward dynamics computes it, and the auxiliaries.
  template <class Input> void order0(Input input) {
    for (NodeId n : plan_.nodes) {
      const Node& node = g_[n];
      if (node.op == Op::Const) s_[n][0] = node.value;
      else if (node.op == Op::Input) s_[n][0] = input(n, 0);
      else s_[n][0] = apply(node.op, v(node.arg[0]), v(node.arg[1]), v(node.arg[2]));
    }
    for (std::size_t i = 0; i < plan_.aux.size(); ++i) {
      const Node& node = g_[plan_.aux[i].owner];
      const double a = v(node.arg[0]), b = v(node.arg[1]), c = v(plan_.aux[i].owner);
      double& x = aux_[i][0];
      switch (plan_.aux[i].kind) {
        case TaylorAux::cos_of_sin: x = std::cos(a); break;
        case TaylorAux::sin_of_cos: x = std::sin(a); break;
        case TaylorAux::tan_square: x = 1.0 + c * c; break;
        case TaylorAux::root: x = std::sqrt((1.0 - a) * (1.0 + a)); break;
        case TaylorAux::one_plus_square: x = 1.0 + a * a; break;
        case TaylorAux::norm_square: x = b * b + a * a; break;
        case TaylorAux::log_base: x = std::log(a); break;
        case TaylorAux::exponent: x = b * aux_[i - 1][0]; break;
      }
    }
    if (plan_.system) {
      for (std::size_t i = 0; i < qdd_.size(); ++i) qdd_[i][0] = v(plan_.system->qdd[i]);
      for (std::size_t i = 0; i < mu_.size(); ++i) mu_[i][0] = v(plan_.system->mu[i]);
    }
  }

  // Coefficient k >= 1 of every needed series (the varying inputs' from `input`).
  template <class Input> void coefficient(int k, Input input) {
    using namespace detail;
    for (NodeId n : plan_.nodes) {
      if (!plan_.needed[n]) continue;
      const Node& node = g_[n];
      if (node.op == Op::Input) {
        s_[n][k] = input(n, k);
        continue;
      }
      const NodeId a = node.arg[0], b = node.arg[1];
      const bool va = plan_.varying[a], vb = arity(node.op) > 1 && plan_.varying[b];
      auto c = [&](NodeId x) { return plan_.varying[x] ? s_[x][k] : 0.0; };
      const double* A = s_[a].data();
      const double* B = arity(node.op) > 1 ? s_[b].data() : nullptr;
      double* C = s_[n].data();
      double* X = plan_.first_aux[n] >= 0 ? aux_[plan_.first_aux[n]].data() : nullptr;
      double& out = C[k];
      switch (node.op) {
        case Op::Neg: out = -c(a); break;
        case Op::Add: out = va && vb ? c(a) + c(b) : va ? c(a) : c(b); break;
        case Op::Sub: out = va && vb ? c(a) - c(b) : va ? c(a) : -c(b); break;
        case Op::Mul:
          out = va && vb ? (a == b ? taylor_square(A, k) : taylor_product(A, B, k))
                : va     ? c(a) * v(b)
                         : v(a) * c(b);
          break;
        case Op::Div: out = vb ? taylor_quotient(c(a), B, C, k) : c(a) / v(b); break;
        case Op::Sqrt: out = taylor_sqrt(c(a), C, k); break;
        case Op::Exp: out = taylor_integral(A, C, k); break;
        case Op::Log: out = taylor_inverse_integral(c(a), A, C, k); break;
        case Op::Sin: case Op::Cos: {
          const NodeId partner = plan_.partner[n];
          if (partner && partner < n) break;  // computed with its partner
          double* other = partner ? s_[partner].data() : X;
          double* sin = node.op == Op::Sin ? C : other;
          double* cos = node.op == Op::Sin ? other : C;
          sin[k] = taylor_integral(A, cos, k);
          cos[k] = -taylor_integral(A, sin, k);
          break;
        }
        case Op::Tan:
          out = taylor_integral(A, X, k);
          X[k] = taylor_square(C, k);
          break;
        case Op::Asin: case Op::Acos:
          X[k] = taylor_sqrt(-taylor_square(A, k), X, k);
          out = taylor_inverse_integral(node.op == Op::Asin ? c(a) : -c(a), X, C, k);
          break;
        case Op::Atan:
          X[k] = taylor_square(A, k);
          out = taylor_inverse_integral(c(a), X, C, k);
          break;
        case Op::Abs: out = A[0] < 0 ? -c(a) : c(a); break;
        case Op::Pow:
          if (!vb) {
            out = taylor_pow(A, C, v(b), k);
          } else if (!va) {
            out = std::log(v(a)) * taylor_integral(B, C, k);
          } else {
            double* L = X;
            double* E = aux_[plan_.first_aux[n] + 1].data();
            L[k] = taylor_inverse_integral(c(a), A, L, k);
            E[k] = taylor_product(B, L, k);
            out = taylor_integral(E, C, k);
          }
          break;
        case Op::Atan2: {  // atan2(y = a, x = b)
          X[k] = va && vb ? taylor_square(B, k) + taylor_square(A, k)
                 : va     ? taylor_square(A, k)
                          : taylor_square(B, k);
          const double m = va && vb ? taylor_cross(A, B, k) : va ? v(b) * c(a) : -(v(a) * c(b));
          out = taylor_inverse_integral(m, X, C, k);
          break;
        }
        case Op::Hypot: {
          const double e = va && vb ? taylor_square(A, k) + taylor_square(B, k)
                           : va     ? taylor_square(A, k)
                                    : taylor_square(B, k);
          out = taylor_sqrt(e, C, k);
          break;
        }
        case Op::Select: out = v(a) != 0 ? c(b) : c(node.arg[2]); break;
        default:
          throw std::logic_error("eomgen: Taylor mode has no rule for " + std::string(name(node.op)));
      }
    }
    if (plan_.system) solve(k);
  }

 private:
  // System mode: q̈_k and μ_k from the right-hand side of coefficient k (eomgen/taylor.hpp),
  //   b_i      = f_k − Σ_l tail(M_il, q̈_l) − Σ_c tail(C_ci, μ_c)     (i < nq)
  //   b_(nq+c) = γ_k + Σ_l tail(C_cl, q̈_l)                            (c < nc)
  // (terms of constant entries vanish), solved by the order-0 factors.
  void solve(int k) {
    using namespace detail;
    const TaylorSystem& sys = *plan_.system;
    const int nq = sys.nq, nc = sys.nc;
    std::vector<double> b(nq + nc);
    auto row = [&](NodeId leading, bool negate, auto&& tails) {
      bool first = !plan_.varying[leading];
      double sum = first ? 0.0 : s_[leading][k];
      tails([&](NodeId entry, const std::vector<double>& x) {
        if (!plan_.varying[entry]) return;
        const double t = taylor_tail(s_[entry].data(), x.data(), k);
        sum = first ? (negate ? -t : t) : negate ? sum - t : sum + t;
        first = false;
      });
      return sum;
    };
    for (int i = 0; i < nq; ++i)
      b[i] = row(sys.force[i], true, [&](auto&& tail) {
        for (int l = 0; l < nq; ++l) tail(sys.mass[i + nq * l], qdd_[l]);
        for (int c = 0; c < nc; ++c) tail(sys.jacobian[c + nc * i], mu_[c]);
      });
    for (int c = 0; c < nc; ++c)
      b[nq + c] = row(sys.bias[c], false, [&](auto&& tail) {
        for (int l = 0; l < nq; ++l) tail(sys.jacobian[c + nc * l], qdd_[l]);
      });
    // The solve's nodes are linear in b, with order-0 factors.
    auto x = [&](NodeId n) { return is_rhs(g_[n]) ? b[g_[n].arg[1]] : solved_[n]; };
    for (NodeId n : plan_.solve_nodes) {
      const Node& node = g_[n];
      const NodeId a = node.arg[0], c = node.arg[1];
      const bool sa = plan_.solve[a], sc = arity(node.op) > 1 && plan_.solve[c];
      const bool linear = node.op == Op::Neg || ((node.op == Op::Add || node.op == Op::Sub) && sa && sc) ||
                          (node.op == Op::Mul && sa != sc) || (node.op == Op::Div && sa && !sc);
      if (!linear) throw std::logic_error("eomgen: Taylor mode: a solve step that is not linear");
      double& out = solved_[n];
      switch (node.op) {
        case Op::Neg: out = -x(a); break;
        case Op::Add: out = x(a) + x(c); break;
        case Op::Sub: out = x(a) - x(c); break;
        case Op::Mul: out = sa ? x(a) * v(c) : v(a) * x(c); break;
        default: out = x(a) / v(c); break;
      }
    }
    for (int i = 0; i < nq; ++i) qdd_[i][k] = plan_.solve[sys.solve_qdd[i]] ? x(sys.solve_qdd[i]) : 0.0;
    for (int c = 0; c < nc; ++c) mu_[c][k] = plan_.solve[sys.solve_mu[c]] ? x(sys.solve_mu[c]) : 0.0;
  }

  // The order-0 value (0 for an unused argument slot, which names node 0 outside the cone).
  double v(NodeId x) const { return s_[x].empty() ? 0.0 : s_[x][0]; }

  const Graph& g_;
  const TaylorPlan& plan_;
  std::vector<std::vector<double>> s_, aux_;
  std::vector<std::vector<double>> qdd_, mu_;  // system mode: the series of q̈ and μ
  std::vector<double> solved_;                 // system mode: the solve's nodes at the current k
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
    case InputKind::qdd: case InputKind::rhs: break;
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
      case InputKind::qdd: case InputKind::rhs: break;
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
