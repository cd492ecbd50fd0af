// The operation table: every Op's entry, in enum order. To add an operation, define its entry
// (ops/op.hpp lists the members; elementary.hpp's Atan is a complete example, Tanh one that
// shares its rules with Tan), add an enumerator
// to Op (eomgen/graph.hpp) and the entry to All below, and a tape function if models call it
// (eomgen/tape.hpp). The checks below fail the build when an entry is missing, out of place or
// incomplete; everything else (folding, derivation, Taylor mode, printing) reads the entry.
#pragma once

#include <concepts>
#include <cstddef>
#include <span>
#include <tuple>
#include <type_traits>
#include <utility>

#include "ops/arithmetic.hpp"
#include "ops/elementary.hpp"
#include "ops/logic.hpp"

namespace eom::gen::ops {

using All = std::tuple<Const, Input, Neg, Add, Sub, Mul, Div, Sin, Cos, Tan, Tanh, Asin, Acos, Atan,
                       Exp, Log, Sqrt, Abs, Pow, Atan2, Hypot, Select, Less, LessEqual, Equal,
                       NotEqual, Not, And, Or, IsFinite, PivotOk>;
inline constexpr std::size_t count = std::tuple_size_v<All>;
template <std::size_t i> using At = std::tuple_element_t<i, All>;

// What every entry has, and what a real (differentiable, Taylor-expandable) one has besides.
template <class O>
concept Operation = requires {
  { O::op } -> std::convertible_to<Op>;
  { O::name } -> std::convertible_to<std::string_view>;
  { O::arity } -> std::convertible_to<int>;
  { O::kind } -> std::convertible_to<Kind>;
  { O::spelling } -> std::convertible_to<Spelling>;
};
template <class O>
concept RealOperation = Operation<O> && requires(Graph& g, NodeId n, double a) {
  { O::eval(a, a, a) } -> std::same_as<double>;
  { O::derivative(g, n, 0, n) } -> std::same_as<NodeId>;
};

namespace detail {
template <std::size_t... i> constexpr bool complete(std::index_sequence<i...>) {
  return ((Operation<At<i>> && At<i>::op == static_cast<Op>(i) &&
           (At<i>::kind != Kind::real || RealOperation<At<i>>) &&
           (At<i>::kind == Kind::leaf) == (At<i>::arity == 0)) && ...);
}
}  // namespace detail
static_assert(count == static_cast<std::size_t>(Op::count), "an Op without a table entry");
static_assert(detail::complete(std::make_index_sequence<count>{}),
              "a table entry out of enum order, or missing a member its kind needs");

// f(Entry{}) for op's entry.
template <class F> decltype(auto) visit(Op op, F&& f) {
  return [&]<std::size_t... i>(std::index_sequence<i...>) -> decltype(auto) {
    using R = decltype(f(At<0>{}));
    if constexpr (std::is_void_v<R>) {
      (void)((op == static_cast<Op>(i) ? (f(At<i>{}), true) : false) || ...);
    } else {
      R r{};
      (void)((op == static_cast<Op>(i) ? (r = f(At<i>{}), true) : false) || ...);
      return r;
    }
  }(std::make_index_sequence<count>{});
}

// The plain facts of an entry, for O(1) lookup.
struct Info {
  std::string_view name;
  int arity;
  Kind kind;
  bool commutative;
  int conditions;
  Spelling spelling;
  Op partner;
  std::span<const AuxSeries> aux;
  double (*eval)(double, double, double);                  // null for leaves
  NodeId (*derivative)(Graph&, NodeId, int, NodeId);       // null unless real
};

template <class O> constexpr Info info_of() {
  Info i{O::name, O::arity, O::kind, O::commutative, O::conditions, O::spelling, O::partner,
         std::span<const AuxSeries>(O::aux), nullptr, nullptr};
  if constexpr (O::kind != Kind::leaf) i.eval = &O::eval;
  if constexpr (O::kind == Kind::real) i.derivative = &O::derivative;
  return i;
}
inline constexpr auto table = []<std::size_t... i>(std::index_sequence<i...>) {
  return std::array<Info, count>{info_of<At<i>>()...};
}(std::make_index_sequence<count>{});

inline const Info& info(Op op) { return table[static_cast<std::size_t>(op)]; }

}  // namespace eom::gen::ops
