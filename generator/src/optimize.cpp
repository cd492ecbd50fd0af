#include "eomgen/optimize.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <unordered_map>
#include <unordered_set>
#include <utility>

namespace eom::gen {


namespace {

constexpr NodeId none = std::numeric_limits<NodeId>::max();

// Small blocks recycled by size: a free list per multiple of 8 bytes up to 256, carved from
// 64 KiB chunks; bigger blocks from the heap. A monomial is a few atoms, made and dropped millions
// of times while a big model is collected; std::pmr::unsynchronized_pool_resource spent 20% of
// the 50-link chain's generation in its bookkeeping (with this pool: 18% fewer instructions).
class MonoPool {
 public:
  void* allocate(std::size_t bytes) {
    const std::size_t k = size_class(bytes);
    if (k >= free_.size()) return ::operator new(bytes);
    if (void* p = free_[k]) {
      free_[k] = *static_cast<void**>(p);
      return p;
    }
    if (left_ < 8 * k) {
      chunks_.push_back(std::make_unique<std::byte[]>(chunk_bytes));
      next_ = chunks_.back().get();
      left_ = chunk_bytes;
    }
    void* p = next_;
    next_ += 8 * k;
    left_ -= 8 * k;
    return p;
  }
  void deallocate(void* p, std::size_t bytes) noexcept {
    const std::size_t k = size_class(bytes);
    if (k >= free_.size()) return ::operator delete(p);
    *static_cast<void**>(p) = free_[k];
    free_[k] = p;
  }

 private:
  // Blocks of 8k bytes; at least one unit, so that a free block can hold the list's link.
  static std::size_t size_class(std::size_t bytes) { return bytes == 0 ? 1 : (bytes + 7) / 8; }
  static constexpr std::size_t chunk_bytes = std::size_t{1} << 16;
  std::array<void*, 33> free_{};
  std::vector<std::unique_ptr<std::byte[]>> chunks_;
  std::byte* next_ = nullptr;
  std::size_t left_ = 0;
};

// The pool of the Collector running on this thread (none: the heap).
thread_local MonoPool* current_pool = nullptr;

// Allocates from the pool that was current when it was made (copies share it).
template <class T> struct PoolAllocator {
  static_assert(alignof(T) <= 8);
  using value_type = T;
  MonoPool* pool = current_pool;

  PoolAllocator() = default;
  template <class U> PoolAllocator(const PoolAllocator<U>& other) noexcept : pool(other.pool) {}
  T* allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
    return static_cast<T*>(pool ? pool->allocate(bytes) : ::operator new(bytes));
  }
  void deallocate(T* p, std::size_t n) noexcept {
    if (pool)
      pool->deallocate(p, n * sizeof(T));
    else
      ::operator delete(p);
  }
  friend bool operator==(const PoolAllocator& a, const PoolAllocator& b) { return a.pool == b.pool; }
};

// State atoms in ascending id order, repeated for powers. Millions are made and dropped while a
// big model is collected: they come from a pool (Collector::pool_), not one allocation each.
using Mono = std::vector<NodeId, PoolAllocator<NodeId>>;
struct Term {
  Mono mono;
  NodeId coef;  // a node of p alone: a constant once the parameters are fixed
};
using Poly = std::vector<Term>;  // ascending monomials, no zero coefficient

// A monomial with a constant factor: the terms of the Horner form, and of a coefficient's
// canonical polynomial over parameter atoms.
struct Scaled {
  Mono mono;
  double c;
  friend auto operator<=>(const Scaled&, const Scaled&) = default;
};
using Canonical = std::vector<Scaled>;  // ascending monomials, no zero factor

class Collector {
 public:
  Collector(Graph& g, const CollectOptions& options) : g_(g), options_(options) {}
  Collector(const Collector&) = delete;
  Collector& operator=(const Collector&) = delete;

  // The collected roots, or nothing when the work budget ran out.
  std::optional<std::vector<NodeId>> run(std::span<const NodeId> roots) {
    order_ = cone(g_, roots);
    place_.clear();
    if (order_.size() >= g_.size() / 16) {  // a small cone of a big graph is searched instead
      place_.assign(g_.size(), 0);
      for (std::size_t i = 0; i < order_.size(); ++i) place_[order_[i]] = static_cast<NodeId>(i);
    }
    budget_ = options_.work_per_node * order_.size() + options_.max_terms;
    // Per node of the cone, not of the graph: a derivative's cone is a small part of a big graph.
    poly_.assign(order_.size(), std::nullopt);
    rebuilt_.assign(order_.size(), none);
    std::vector<int> uses(order_.size(), 0);
    for (NodeId n : order_)
      for (int i = 0; i < arity(g_[n].op); ++i) ++uses[at(g_[n].arg[i])];
    for (NodeId r : roots) ++uses[at(r)];
    for (NodeId n : order_) {
      expand(n);
      if (exhausted_) return std::nullopt;
      // A polynomial is needed until its last user has been expanded.
      for (int i = 0; i < arity(g_[n].op); ++i)
        if (const std::size_t a = at(g_[n].arg[i]); --uses[a] == 0) poly_[a].reset();
    }
    std::vector<NodeId> out;
    for (NodeId r : roots) out.push_back(rebuild(r, /*last_use=*/true));
    return out;
  }

 private:
  // A node's place in the cone (ascending ids).
  std::size_t at(NodeId n) const {
    if (!place_.empty()) return place_[n];
    return static_cast<std::size_t>(std::lower_bound(order_.begin(), order_.end(), n) - order_.begin());
  }
  bool is_param(NodeId n) const { return g_.parameter_only(n); }

  Poly constant_term(NodeId c) { return g_.is_const(c, 0) ? Poly{} : Poly{{{}, c}}; }

  // Sorts and merges like terms (coefficients added in order); drops the ones that cancel.
  void normalize(Poly& p) {
    std::stable_sort(p.begin(), p.end(), [](const Term& a, const Term& b) { return a.mono < b.mono; });
    std::size_t out = 0;
    for (std::size_t i = 0; i < p.size();) {
      Term t = std::move(p[i]);
      for (++i; i < p.size() && p[i].mono == t.mono; ++i) t.coef = g_.add(t.coef, p[i].coef);
      if (!g_.is_const(t.coef, 0)) p[out++] = std::move(t);
    }
    p.resize(out);
    spend(p.size());
  }

  void spend(std::size_t work) {
    if (work > budget_) exhausted_ = true;
    budget_ -= std::min(work, budget_);
  }

  // a ± b, both normalized: merged in one pass, like terms added a's first (as normalize would).
  Poly sum(const Poly& a, const Poly& b, bool subtract) {
    Poly r;
    r.reserve(a.size() + b.size());
    std::vector<NodeId> other(b.size());  // b's coefficients, negated first (the graph's node order)
    for (std::size_t j = 0; j < b.size(); ++j) other[j] = subtract ? g_.neg(b[j].coef) : b[j].coef;
    auto keep = [&](Mono mono, NodeId coef) {
      if (!g_.is_const(coef, 0)) r.push_back({std::move(mono), coef});
    };
    std::size_t i = 0, j = 0;
    while (i < a.size() || j < b.size()) {
      if (j == b.size() || (i < a.size() && a[i].mono < b[j].mono)) {
        keep(a[i].mono, a[i].coef);
        ++i;
      } else if (i == a.size() || b[j].mono < a[i].mono) {
        keep(b[j].mono, other[j]);
        ++j;
      } else {
        keep(a[i].mono, g_.add(a[i].coef, other[j]));
        ++i, ++j;
      }
    }
    spend(r.size());
    return r;
  }

  Poly product(const Poly& a, const Poly& b) {
    Poly r;
    r.reserve(a.size() * b.size());
    for (const Term& x : a)
      for (const Term& y : b) {
        Mono m;
        m.reserve(x.mono.size() + y.mono.size());
        std::merge(x.mono.begin(), x.mono.end(), y.mono.begin(), y.mono.end(), std::back_inserter(m));
        r.push_back({std::move(m), g_.mul(x.coef, y.coef)});
      }
    normalize(r);
    return r;
  }

  void expand(NodeId n) {
    const Node node = g_[n];
    const std::size_t here = at(n);
    const auto arg = [&](int i) -> const Poly& { return *poly_[at(node.arg[i])]; };
    if (is_param(n)) {  // a coefficient as it stands (computed once per parameter set)
      poly_[here] = constant_term(n);
      return;
    }
    switch (node.op) {
      case Op::Neg:
        poly_[here] = sum({}, arg(0), true);
        return;
      case Op::Add:
      case Op::Sub:
        if (arg(0).size() + arg(1).size() <= options_.max_terms) {
          poly_[here] = sum(arg(0), arg(1), node.op == Op::Sub);
          return;
        }
        break;
      case Op::Mul:
        if (arg(0).size() * arg(1).size() <= options_.max_terms) {
          poly_[here] = product(arg(0), arg(1));
          return;
        }
        break;
      case Op::Div:
        if (is_param(node.arg[1])) {  // x / b: b goes into the coefficients
          Poly r = arg(0);
          for (Term& t : r) t.coef = g_.div(t.coef, node.arg[1]);
          poly_[here] = std::move(r);
          return;
        }
        break;
      default: break;
    }
    // An atom: the operation applied to the collected arguments.
    NodeId a = n;
    if (node.op != Op::Input) {
      NodeId args[3] = {0, 0, 0};
      for (int i = 0; i < arity(node.op); ++i) args[i] = rebuild(node.arg[i]);
      a = g_.make(node.op, args[0], args[1], args[2]);
    }
    rebuilt_[here] = a;
    poly_[here] = is_param(a) ? constant_term(a) : Poly{{{a}, Graph::one}};
  }

  // The node of n's collected polynomial; last_use: the polynomial is not read again (moved).
  NodeId rebuild(NodeId n, bool last_use = false) {
    const std::size_t i = at(n);
    if (rebuilt_[i] == none) rebuilt_[i] = last_use ? build(std::move(*poly_[i])) : build(*poly_[i]);
    return rebuilt_[i];
  }

  // sin²x·R·c + cos²x·R·c = R·c, until no pair is left.
  void pythagoras(Poly& p) {
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t i = 0; !changed && i < p.size(); ++i) {
        const Mono& m = p[i].mono;
        for (std::size_t k = 0; !changed && k + 1 < m.size(); ++k) {
          if (m[k] != m[k + 1] || g_[m[k]].op != Op::Sin) continue;
          const auto cos = g_.find(Op::Cos, g_[m[k]].arg[0]);
          if (!cos) continue;
          Mono rest = m;
          rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(k),
                     rest.begin() + static_cast<std::ptrdiff_t>(k) + 2);
          Mono partner = rest;
          partner.insert(std::upper_bound(partner.begin(), partner.end(), *cos), 2, *cos);
          const auto j = std::lower_bound(p.begin(), p.end(), partner,
                                          [](const Term& t, const Mono& x) { return t.mono < x; });
          if (j == p.end() || j->mono != partner || j->coef != p[i].coef) continue;
          const NodeId c = p[i].coef;
          p[i].coef = Graph::zero;
          j->coef = Graph::zero;
          p.push_back({std::move(rest), c});
          normalize(p);
          changed = true;
        }
      }
    }
  }

  // A parameter-only coefficient as a polynomial over parameter atoms (inputs p, and the
  // operations other than +, −, ·), memoized; a node whose polynomial would pass max_terms
  // terms is an atom itself.
  const Canonical& expansion(NodeId root) {
    std::vector<NodeId> stack{root};
    while (!stack.empty()) {
      const NodeId n = stack.back();
      if (expansion_.count(n)) {
        stack.pop_back();
        continue;
      }
      const Node node = g_[n];
      const bool polynomial = node.op == Op::Neg || node.op == Op::Add || node.op == Op::Sub ||
                              node.op == Op::Mul;
      bool ready = true;
      if (polynomial)
        for (int i = 0; i < arity(node.op); ++i)
          if (!expansion_.count(node.arg[i])) {
            stack.push_back(node.arg[i]);
            ready = false;
          }
      if (!ready) continue;
      stack.pop_back();
      Canonical e;
      if (node.op == Op::Const) {
        if (node.value != 0) e.push_back({{}, node.value});
      } else if (!polynomial) {
        e.push_back({{n}, 1.0});
      } else {
        const Canonical& a = expansion_.at(node.arg[0]);
        const Canonical* b = arity(node.op) > 1 ? &expansion_.at(node.arg[1]) : nullptr;
        const bool expanded_product = node.op == Op::Mul && a.size() * b->size() <= options_.max_terms;
        const bool expanded_sum = (node.op == Op::Add || node.op == Op::Sub) &&
                                  a.size() + b->size() <= options_.max_terms;
        if (expanded_product) {
          e.reserve(a.size() * b->size());
          for (const Scaled& x : a)
            for (const Scaled& y : *b) {
              Mono m;
              m.reserve(x.mono.size() + y.mono.size());
              std::merge(x.mono.begin(), x.mono.end(), y.mono.begin(), y.mono.end(), std::back_inserter(m));
              e.push_back({std::move(m), x.c * y.c});
            }
        } else if (node.op != Op::Mul && a.size() + (b ? b->size() : 0) <= options_.max_terms) {
          e.reserve(a.size() + (b ? b->size() : 0));
          for (const Scaled& x : a) e.push_back({x.mono, node.op == Op::Neg ? -x.c : x.c});
          if (b)
            for (const Scaled& y : *b) e.push_back({y.mono, node.op == Op::Sub ? -y.c : y.c});
        } else {
          e.push_back({{n}, 1.0});
        }
        const auto by_mono = [](const Scaled& x, const Scaled& y) { return x.mono < y.mono; };
        if (expanded_product)
          std::stable_sort(e.begin(), e.end(), by_mono);
        else if (expanded_sum)  // two ascending runs, a's then b's: merged stably, as a sort would
          std::inplace_merge(e.begin(), e.begin() + static_cast<std::ptrdiff_t>(a.size()), e.end(), by_mono);
        std::size_t out = 0;
        for (std::size_t i = 0; i < e.size();) {
          Scaled t = std::move(e[i]);
          for (++i; i < e.size() && e[i].mono == t.mono; ++i) t.c += e[i].c;
          if (t.c != 0) e[out++] = std::move(t);
        }
        e.resize(out);
      }
      spend(e.size());
      expansion_.emplace(n, std::move(e));
    }
    return expansion_.at(root);
  }

  // One node per coefficient polynomial (up to sign), in Horner form over the parameters: equal
  // coefficients reached by different sums become the same node.
  NodeId canonical(NodeId c) {
    if (g_.is_const(c)) return c;
    if (const auto known = canonical_of_.find(c); known != canonical_of_.end()) return known->second;
    Canonical e = expansion(c);
    NodeId r = Graph::zero;
    if (!e.empty()) {
      const bool negative = e.front().c < 0;
      if (negative)
        for (Scaled& t : e) t.c = -t.c;
      auto [it, inserted] = canonical_.try_emplace(std::move(e), Graph::zero);
      if (inserted) it->second = horner(it->first).value(g_);
      r = negative ? g_.neg(it->second) : it->second;
    }
    canonical_of_.emplace(c, r);
    return r;
  }

  // A product of atoms, reusing a product of two of its factors that an earlier product of this
  // collection made (q0·q̇1 in q0·q̇1² and q0·q̇0·q̇1), else multiplied in ascending order.
  NodeId product_of(const Mono& m) {
    if (m.size() <= 2 || products_.empty()) return fold_product(m.begin(), m.end());
    std::vector<NodeId> f(m.begin(), m.end());
    while (f.size() > 2) {
      bool reused = false;
      for (std::size_t i = 0; !reused && i < f.size(); ++i)
        for (std::size_t j = i + 1; !reused && j < f.size(); ++j) {
          const auto p = g_.find(Op::Mul, std::min(f[i], f[j]), std::max(f[i], f[j]));
          if (!p || !products_.contains(*p)) continue;
          f.erase(f.begin() + static_cast<std::ptrdiff_t>(j));
          f[i] = *p;
          reused = true;
        }
      if (!reused) break;
    }
    return fold_product(f.begin(), f.end());
  }
  template <class It> NodeId fold_product(It first, It last) {
    NodeId r = Graph::one;
    for (; first != last; ++first) {
      r = g_.mul(r, *first);
      if (r != *first) products_.insert(r);
    }
    return r;
  }

  // The node of a polynomial, in collected form: one product per distinct coefficient (up to
  // sign) with the sum of its monomials in Horner form.
  NodeId build(Poly p) {
    for (Term& t : p) t.coef = canonical(t.coef);
    pythagoras(p);
    std::vector<std::pair<NodeId, std::vector<Scaled>>> groups;
    std::map<NodeId, std::size_t> group_of;
    for (Term& t : p) {
      NodeId c = t.coef;
      double sign = 1;
      if (g_[c].op == Op::Neg) {
        c = g_[c].arg[0];
        sign = -1;
      } else if (g_.is_const(c) && g_[c].value < 0) {
        c = g_.constant(-g_[c].value);
        sign = -1;
      }
      auto [it, inserted] = group_of.try_emplace(c, groups.size());
      if (inserted) groups.push_back({c, {}});
      groups[it->second].second.push_back({std::move(t.mono), sign});
    }
    NodeId result = Graph::zero;
    for (auto& [c, terms] : groups) {
      const Signed sum = horner(std::move(terms));
      const NodeId term = g_.mul(c, sum.node);
      result = sum.negative ? g_.sub(result, term) : g_.add(result, term);
    }
    return result;
  }

  // A sum built up to sign, the sign left to the caller: a sum and its negation (sⱼcₖ − cⱼsₖ
  // and cⱼsₖ − sⱼcₖ, in two rows of the Coriolis terms) become one node.
  struct Signed {
    NodeId node;
    bool negative;
    NodeId value(Graph& g) const { return negative ? g.neg(node) : node; }
  };

  // Σ cᵢ·mᵢ, highest monomials first: sums over a tail of the atoms (Σᵢ₌ₖ mᵢ) then share their
  // prefixes. Up to sign: the lowest monomial's factor is made positive.
  Signed flat(std::vector<Scaled> terms) {
    std::sort(terms.begin(), terms.end());
    const bool negative = !terms.empty() && terms.front().c < 0;
    NodeId s = Graph::zero;
    for (auto t = terms.rbegin(); t != terms.rend(); ++t) {
      const NodeId m = product_of(t->mono);
      const double c = negative ? -t->c : t->c;
      if (c == 1 || c == -1)
        s = c < 0 ? g_.sub(s, m) : g_.add(s, m);
      else
        s = g_.add(s, g_.mul(g_.constant(c), m));
    }
    return {s, negative};
  }

  // Greedy multivariate Horner form: with a the atom in most terms (at least two) and e its
  // lowest power among them, Σ = aᵉ·Σ(terms with a, aᵉ removed) + Σ(the others) (aᵉ, say q̇ᵢ²,
  // is then one node wherever it occurs). An explicit stack instead of recursion.
  Signed horner(std::vector<Scaled> all) {
    struct Frame {
      std::vector<Scaled> terms, rest;
      NodeId atom = none;
      Signed left{none, false};
      int stage = 0;
    };
    std::vector<Frame> stack;
    stack.push_back({std::move(all), {}});
    Signed ret{none, false};
    while (!stack.empty()) {
      Frame& f = stack.back();
      if (f.stage == 0) {
        // the atom in most terms (the lowest id among equals)
        std::vector<NodeId> atoms;
        for (const Scaled& t : f.terms)
          for (std::size_t i = 0; i < t.mono.size(); ++i)
            if (i == 0 || t.mono[i] != t.mono[i - 1]) atoms.push_back(t.mono[i]);
        spend(atoms.size());
        std::sort(atoms.begin(), atoms.end());
        NodeId best = none;
        std::size_t most = 1;
        for (std::size_t i = 0, j = 0; i < atoms.size(); i = j) {
          while (j < atoms.size() && atoms[j] == atoms[i]) ++j;
          if (j - i > most) best = atoms[i], most = j - i;
        }
        if (best == none) {
          ret = flat(f.terms);
          stack.pop_back();
          continue;
        }
        std::ptrdiff_t power = std::numeric_limits<std::ptrdiff_t>::max();
        for (const Scaled& t : f.terms) {
          const auto [first, last] = std::equal_range(t.mono.begin(), t.mono.end(), best);
          if (first != last) power = std::min(power, last - first);
        }
        std::vector<Scaled> with;
        for (Scaled& t : f.terms) {
          const auto first = std::lower_bound(t.mono.begin(), t.mono.end(), best);
          if (first != t.mono.end() && *first == best) {
            t.mono.erase(first, first + power);
            with.push_back(std::move(t));
          } else {
            f.rest.push_back(std::move(t));
          }
        }
        f.terms.clear();
        f.atom = product_of(Mono(static_cast<std::size_t>(power), best));
        f.stage = 1;
        stack.push_back({std::move(with), {}});  // f is invalid from here
      } else if (f.stage == 1) {
        f.left = {g_.mul(f.atom, ret.node), ret.negative};
        if (f.rest.empty()) {
          ret = f.left;
          stack.pop_back();
          continue;
        }
        f.stage = 2;
        std::vector<Scaled> rest = std::move(f.rest);
        stack.push_back({std::move(rest), {}});
      } else {  // left ± rest, the sign kept outside when both are negative
        const Signed& l = f.left;
        if (l.negative == ret.negative)
          ret = {g_.add(l.node, ret.node), l.negative};
        else
          ret = {l.negative ? g_.sub(ret.node, l.node) : g_.sub(l.node, ret.node), false};
        stack.pop_back();
      }
    }
    return ret;
  }

  // Every Mono is made while this Collector lives (declared first: destroyed last, after every
  // container that holds one), from its pool: this thread's current pool meanwhile. Per thread,
  // so that two threads may collect at once.
  struct Pool {
    MonoPool pool;
    MonoPool* previous = std::exchange(current_pool, &pool);
    ~Pool() { current_pool = previous; }
  } pool_;
  Graph& g_;
  const CollectOptions& options_;
  std::vector<NodeId> order_;                // the cone of the roots
  std::vector<NodeId> place_;                // per node of the graph, its index in order_ (or empty)
  std::vector<std::optional<Poly>> poly_;   // per node of order_
  std::vector<NodeId> rebuilt_;             // per node of order_
  std::unordered_map<NodeId, Canonical> expansion_;
  std::map<Canonical, NodeId> canonical_;
  std::unordered_map<NodeId, NodeId> canonical_of_;  // canonical(), per coefficient node
  std::unordered_set<NodeId> products_;  // the products product_of made
  std::size_t budget_ = 0;
  bool exhausted_ = false;

};

// The operations a call costs: parameter-only ones are computed once per parameter set
// (the emitter's parameter cache), so they count only to break ties.
std::pair<std::size_t, std::size_t> per_call_cost(const Graph& g, std::span<const NodeId> roots) {
  std::size_t per_call = 0, all = 0;
  for (NodeId n : cone(g, roots))
    if (arity(g[n].op) > 0) {
      ++all;
      per_call += !g.parameter_only(n);
    }
  return {per_call, all};
}

}  // namespace

std::vector<NodeId> collect(Graph& g, std::span<const NodeId> roots, const CollectOptions& options) {
  const std::optional<std::vector<NodeId>> collected = Collector(g, options).run(roots);
  if (collected && per_call_cost(g, *collected) < per_call_cost(g, roots))
    return *collected;
  return {roots.begin(), roots.end()};
}

}  // namespace eom::gen
