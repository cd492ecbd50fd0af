// Random Lagrangians for the differential test: expression trees over every function the tape
// supports, interpreted by a model whose template functions work for any scalar S (double, the
// reference's AD numbers, the recording scalar). Arguments are kept inside the functions' domains
// by construction (log(1 + x²), sqrt(2 + sin x), asin(0.7 x / sqrt(1 + x²)), ...).
//
//   T = ½ Σₖ (Σⱼ Aₖⱼ(q) q̇ⱼ)² + ½ ε |q̇|²,  Aₖⱼ = δₖⱼ + 0.3·tree (or 0: structural zeros)
//   V = tree(q, p),  φᵢ = qᵢ + 0.3·tree(q, p),  Qᵢ = tree(t, q, q̇, u, p)
//
// so M = AᵀA + εI is symmetric positive definite and C has full rank.
#pragma once

#include <array>
#include <cmath>
#include <random>
#include <span>
#include <string_view>
#include <vector>

#include <eom/model/model.hpp>

namespace eomtest {

enum class Leaf { constant, q, qd, u, p, t };

// A tree in post-order: every node's children precede it, so evaluation is one loop.
struct Tree {
  struct Node {
    int op;      // < 0: leaf; else an index into the operation list of apply()
    int a, b;    // children
    Leaf leaf;
    int index;
    double c;
  };
  std::vector<Node> nodes;
};

inline constexpr int unary_ops = 16, binary_ops = 9;

template <class S> S apply_unary(int op, const S& a) {
  using std::abs, std::acos, std::asin, std::atan, std::cos, std::exp, std::log, std::pow,
      std::sin, std::sqrt, std::tan, std::tanh;
  switch (op) {
    case 0: return sin(a);
    case 1: return cos(a);
    case 2: return tan(a / (2.0 + a * a));
    case 3: return asin(0.7 * a / sqrt(1.0 + a * a));
    case 4: return acos(0.7 * a / sqrt(1.0 + a * a));
    case 5: return atan(a);
    case 6: return exp(0.3 * a);
    case 7: return log(1.0 + a * a);
    case 8: return sqrt(2.0 + sin(a));
    case 9: return pow(a, 3);
    case 10: return pow(1.5 + sin(a), -2);
    case 11: return pow(1.0 + a * a, 0.75);
    case 12: return abs(a) + 2 * a;
    case 13: return -a;
    case 14: return tanh(1.5 * a);
    default: return pow(S(2.0), 0.3 * a);
  }
}

template <class S> S apply_binary(int op, const S& a, const S& b) {
  using std::atan2, std::cos, std::hypot, std::pow, std::sin;
  switch (op) {
    case 0: return a + b;
    case 1: return a - b;
    case 2: return a * b;
    case 3: return a / (2.0 + b * b);
    case 4: return pow(1.5 + sin(a), cos(b));
    case 5: return hypot(a, 0.5 + b * b);
    case 6: return atan2(a, 1.5 + cos(b));
    case 7: return eom::select(a < b, a, b) + 1;  // min(a, b): continuous, both sides taken
    default: return 1 - a * 0.5 + b / 4;
  }
}

// Evaluates a tree for any scalar.
template <class S>
S evaluate(const Tree& t, eom::In<S> q, eom::In<S> qd, eom::In<S> u, eom::In<S> p, const S* time) {
  std::vector<S> v(t.nodes.size());
  for (std::size_t i = 0; i < t.nodes.size(); ++i) {
    const Tree::Node& n = t.nodes[i];
    if (n.op < 0) {
      switch (n.leaf) {
        case Leaf::constant: v[i] = S(n.c); break;
        case Leaf::q: v[i] = q[n.index]; break;
        case Leaf::qd: v[i] = qd[n.index]; break;
        case Leaf::u: v[i] = u[n.index]; break;
        case Leaf::p: v[i] = p[n.index]; break;
        case Leaf::t: v[i] = *time; break;
      }
    } else if (n.b < 0) {
      v[i] = apply_unary<S>(n.op, v[n.a]);
    } else {
      v[i] = apply_binary<S>(n.op, v[n.a], v[n.b]);
    }
  }
  return v.back();
}

// Which leaves a tree may use, and how many of each.
struct Leaves {
  int nq = 0, nqd = 0, nu = 0, np = 0;
  bool t = false;
};

class TreeMaker {
 public:
  explicit TreeMaker(unsigned seed) : rng_(seed) {}

  Tree make(const Leaves& leaves, int depth) {
    Tree t;
    grow(t, leaves, depth);
    return t;
  }
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
  int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }

 private:
  int grow(Tree& t, const Leaves& l, int depth) {
    if (depth == 0 || integer(0, 9) < 2) return leaf(t, l);
    Tree::Node n{};
    if (integer(0, 1) == 0) {
      n.op = integer(0, unary_ops - 1);
      n.a = grow(t, l, depth - 1);
      n.b = -1;
    } else {
      n.op = integer(0, binary_ops - 1);
      n.a = grow(t, l, depth - 1);
      n.b = grow(t, l, depth - 1);
    }
    t.nodes.push_back(n);
    return static_cast<int>(t.nodes.size()) - 1;
  }
  int leaf(Tree& t, const Leaves& l) {
    Tree::Node n{};
    n.op = -1;
    n.a = n.b = -1;
    std::vector<Leaf> kinds{Leaf::constant};
    for (int i = 0; i < 3; ++i) {  // weight the variables over the constants
      if (l.nq) kinds.push_back(Leaf::q);
      if (l.nqd) kinds.push_back(Leaf::qd);
    }
    if (l.nu) kinds.push_back(Leaf::u);
    if (l.np) kinds.push_back(Leaf::p);
    if (l.t) kinds.push_back(Leaf::t);
    n.leaf = kinds[integer(0, static_cast<int>(kinds.size()) - 1)];
    switch (n.leaf) {
      case Leaf::constant: n.c = uniform(-1.5, 1.5); break;
      case Leaf::q: n.index = integer(0, l.nq - 1); break;
      case Leaf::qd: n.index = integer(0, l.nqd - 1); break;
      case Leaf::u: n.index = integer(0, l.nu - 1); break;
      case Leaf::p: n.index = integer(0, l.np - 1); break;
      case Leaf::t: break;
    }
    t.nodes.push_back(n);
    return static_cast<int>(t.nodes.size()) - 1;
  }
  std::mt19937 rng_;
};

// The trees of one random model.
struct Lagrangian {
  std::vector<std::vector<Tree>> A;  // nq×nq, empty tree = structural zero
  Tree V;
  std::vector<Tree> phi, Q;
  double eps = 1.0;
};

inline Lagrangian random_lagrangian(unsigned seed, int nq, int nc, int nu, bool forces) {
  TreeMaker mk(seed);
  Lagrangian L;
  const Leaves over_q{nq, 0, 0, 3, false};
  L.A.assign(nq, std::vector<Tree>(nq));
  for (auto& row : L.A)
    for (auto& a : row)
      if (mk.integer(0, 9) < 6) a = mk.make(over_q, 3);
  L.V = mk.make(over_q, 4);
  for (int i = 0; i < nc; ++i) L.phi.push_back(mk.make(over_q, 3));
  if (forces)
    for (int i = 0; i < nq; ++i) L.Q.push_back(mk.make(Leaves{nq, nq, nu, 3, true}, 3));
  L.eps = mk.uniform(0.5, 1.5);
  return L;
}

inline constexpr std::array<std::string_view, 8> q_names{"q0", "q1", "q2", "q3", "q4", "q5", "q6", "q7"};
inline constexpr std::array<std::string_view, 4> u_names{"u0", "u1", "u2", "u3"};
inline constexpr std::array<std::string_view, 4> phi_names{"c0", "c1", "c2", "c3"};

template <int N, std::size_t M>
constexpr std::array<std::string_view, N> first(const std::array<std::string_view, M>& names) {
  std::array<std::string_view, N> a{};
  for (int i = 0; i < N; ++i) a[i] = names[i];
  return a;
}

template <int NC> struct ConstraintNames {
  static constexpr std::array<std::string_view, NC> constraint_names = first<NC>(phi_names);
};
template <> struct ConstraintNames<0> {};

// The model: static trees, set by the test before each case.
template <int NQ, int NC, int NU, bool Forces>
struct RandomModel : ConstraintNames<NC> {
  static constexpr std::array<std::string_view, NQ> coordinates = first<NQ>(q_names);
  static constexpr std::array<std::string_view, NU> inputs = first<NU>(u_names);
  static constexpr std::array parameters{"a", "b", "c"};
  static constexpr std::array parameter_values{0.8, 1.1, 0.6};
  static inline Lagrangian L;

  template <class S> static S kinetic_energy(eom::In<S> q, eom::In<S> qd, eom::In<S> p) {
    S T = 0.0;
    for (int k = 0; k < NQ; ++k) {
      S v = 0.0;
      for (int j = 0; j < NQ; ++j) {
        if (L.A[k][j].nodes.empty()) {
          if (j == k) v += qd[j];
          continue;
        }
        S a = 0.3 * evaluate<S>(L.A[k][j], q, q, q, p, nullptr);
        if (j == k) a = a + 1.0;
        v += a * qd[j];
      }
      T += 0.5 * v * v;
    }
    for (int j = 0; j < NQ; ++j) T += 0.5 * L.eps * qd[j] * qd[j];
    return T;
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    return evaluate<S>(L.V, q, q, q, p, nullptr);
  }
  template <class S>
    requires(NC > 0)
  static void constraints(eom::In<S> q, eom::In<S> p, eom::Out<S> phi) {
    for (int i = 0; i < NC; ++i) phi[i] = q[i] + 0.3 * evaluate<S>(L.phi[i], q, q, q, p, nullptr);
  }
  template <class S>
    requires Forces
  static void generalized_forces(const S& t, eom::In<S> q, eom::In<S> qd, eom::In<S> u,
                                 eom::In<S> p, eom::Out<S> Q) {
    for (int i = 0; i < NQ; ++i) Q[i] = evaluate<S>(L.Q[i], q, qd, u, p, &t);
  }
};

}  // namespace eomtest
