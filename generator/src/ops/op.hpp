// What an operation table entry is (ops/table.hpp lists them; arithmetic.hpp, elementary.hpp and
// logic.hpp define them). One entry owns everything the generator knows about its operation:
//
//   op, name, arity, kind        identity; kind: leaf (no arguments), real, or boolean (a condition)
//   commutative, conditions      a·b and b·a are one node; the leading boolean arguments (select's)
//   spelling                     how it prints in C++ (printer.hpp adds parentheses by precedence)
//   partner                      an operation of the same argument computed with it (sin ↔ cos)
//   eval(a, b, c)                its value in double: constant folding, the evaluators
//   derivative(g, n, i, w)       (∂n/∂argᵢ)·w as graph nodes: reverse and forward mode alike
//   taylor_plan(p)               what its Taylor recurrence reads (see PlanStep in taylor.cpp)
//   aux, taylor_aux_count(p)     the auxiliary series its recurrence needs, and how many it uses
//   taylor_order0(x)             coefficient 0 of those auxiliaries
//   taylor(x)                    its coefficient k >= 1 from lower ones
//
// The Taylor rules are templates over a context: the generator's evaluator (taylor.cpp: values
// are doubles, series are arrays) and the emitter (emit_taylor.cpp: values are C++ text, series
// are names) run the same rule, so the evaluator and the generated code agree by construction.
// A context X offers:
//   x.varying(i), x.same_args()    argument i is a series; the two arguments are one node
//   x.c(i), x.v(i), x.self_v()     coefficient k of argument i (only when varying), order-0 values
//   x.S(i), x.self_S(), x.aux(j)   series; x.partner_S() the partner's (when x.paired())
//   x.aux0(j), x.set_aux0(j, e)    an auxiliary's coefficient 0
//   x.self(e), x.set(s, e)         coefficient k of the node, of series s
//   x.apply(op, e...)              any table operation on values; x.constant(d)
//   x.product(a, b), x.square(a), x.integral(a, b), x.inverse_integral(ak, b, c),
//   x.quotient(ak, b, c), x.root(ak, c), x.cross(y, x), x.power(a, c, r)
//                                  coefficient k of the recurrences of src/taylor_recurrences.inc
// Entries inherit defaults from Base and the shape classes below; a real operation that lacks
// eval or derivative fails the RealOperation check in table.hpp, one that lacks taylor fails to
// compile where the Taylor passes visit every real entry.
#pragma once

#include <array>
#include <cmath>
#include <string_view>

#include "eomgen/graph.hpp"

namespace eom::gen::ops {

enum class Kind : unsigned char { leaf, real, boolean };

// C++ spelling. precedence is C++'s (smaller binds tighter; 0 for a name or a call).
enum class Form : unsigned char { leaf, prefix, infix, call, ternary };
struct Spelling {
  Form form;
  std::string_view symbol;  // "-", " + ", "std::sin", ...
  int precedence;
};

// An auxiliary series: its name suffix in generated code, and a comment.
struct AuxSeries {
  std::string_view suffix, comment;
};

inline constexpr Op no_partner = Op::Const;

struct Base {
  static constexpr bool commutative = false;
  static constexpr int conditions = 0;
  static constexpr Op partner = no_partner;
  static constexpr std::array<AuxSeries, 0> aux{};
  // Default Taylor plan: a recurrence that reads its own lower coefficients, no arguments'.
  template <class P> static void taylor_plan(P&) {}
  template <class P> static int taylor_aux_count(const P&) { return 0; }
  template <class X> static void taylor_order0(X&) {}
};

struct Leaf : Base {
  static constexpr int arity = 0;
  static constexpr Kind kind = Kind::leaf;
  static constexpr Spelling spelling{Form::leaf, "", 0};
};

template <int n> struct Real : Base {
  static constexpr int arity = n;
  static constexpr Kind kind = Kind::real;
};

template <int n> struct Condition : Base {
  static constexpr int arity = n;
  static constexpr Kind kind = Kind::boolean;
};

}  // namespace eom::gen::ops
