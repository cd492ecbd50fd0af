// The leaves, select, and the conditions (entries of the operation table, ops/op.hpp says what
// each member is). Conditions are values 1.0 / 0.0 when evaluated; they are decided at order 0 in
// Taylor mode and have no derivative.
#pragma once

#include "ops/op.hpp"

namespace eom::gen::ops {

struct Const : Leaf {
  static constexpr Op op = Op::Const;
  static constexpr std::string_view name = "const";
};

struct Input : Leaf {  // arg[0] = InputKind, arg[1] = index
  static constexpr Op op = Op::Input;
  static constexpr std::string_view name = "input";
};

// c ? a : b. Its derivative and Taylor coefficients are those of the branch taken.
struct Select : Real<3> {
  static constexpr Op op = Op::Select;
  static constexpr std::string_view name = "select";
  static constexpr int conditions = 1;
  static constexpr Spelling spelling{Form::ternary, "", 16};
  static double eval(double c, double a, double b) { return c != 0 ? a : b; }
  static NodeId derivative(Graph& g, NodeId n, int i, NodeId w) {
    const NodeId c = g[n].arg[0];
    return i == 1 ? g.make(Op::Select, c, w, Graph::zero) : g.make(Op::Select, c, Graph::zero, w);
  }
  template <class P> static void taylor_plan(P& p) { p.linear(); }
  template <class X> static void taylor(X& x) {
    x.self(x.apply(op, x.v(0), x.varying(1) ? x.c(1) : x.constant(0.0),
                   x.varying(2) ? x.c(2) : x.constant(0.0)));
  }
};

template <Op o, int n> struct Test : Condition<n> {
  static constexpr Op op = o;
};

struct Less : Test<Op::Less, 2> {
  static constexpr std::string_view name = "less";
  static constexpr Spelling spelling{Form::infix, " < ", 9};
  static double eval(double a, double b, double) { return a < b; }
};
struct LessEqual : Test<Op::LessEqual, 2> {
  static constexpr std::string_view name = "less_equal";
  static constexpr Spelling spelling{Form::infix, " <= ", 9};
  static double eval(double a, double b, double) { return a <= b; }
};
struct Equal : Test<Op::Equal, 2> {
  static constexpr std::string_view name = "equal";
  static constexpr bool commutative = true;
  static constexpr Spelling spelling{Form::infix, " == ", 10};
  static double eval(double a, double b, double) { return a == b; }
};
struct NotEqual : Test<Op::NotEqual, 2> {
  static constexpr std::string_view name = "not_equal";
  static constexpr bool commutative = true;
  static constexpr Spelling spelling{Form::infix, " != ", 10};
  static double eval(double a, double b, double) { return a != b; }
};
struct Not : Test<Op::Not, 1> {
  static constexpr std::string_view name = "not";
  static constexpr Spelling spelling{Form::prefix, "!", 3};
  static double eval(double a, double, double) { return a == 0; }
};
struct And : Test<Op::And, 2> {
  static constexpr std::string_view name = "and";
  static constexpr bool commutative = true;
  static constexpr Spelling spelling{Form::infix, " && ", 14};
  static double eval(double a, double b, double) { return a != 0 && b != 0; }
};
struct Or : Test<Op::Or, 2> {
  static constexpr std::string_view name = "or";
  static constexpr bool commutative = true;
  static constexpr Spelling spelling{Form::infix, " || ", 15};
  static double eval(double a, double b, double) { return a != 0 || b != 0; }
};
// Printed as the generated sources' is_finite (integer operations, like their all_finite).
struct IsFinite : Test<Op::IsFinite, 1> {
  static constexpr std::string_view name = "isfinite";
  static constexpr Spelling spelling{Form::call, "is_finite", 0};
  static double eval(double a, double, double) { return std::isfinite(a); }
};
// A Cholesky pivot (arg 0) clearly positive relative to its diagonal entry (arg 1): the relative
// test of eom::linalg::pivot_ok; generated sources carry a copy of it.
struct PivotOk : Test<Op::PivotOk, 2> {
  static constexpr std::string_view name = "pivot_ok";
  static constexpr Spelling spelling{Form::call, "pivot_ok", 0};
  static double eval(double a, double b, double) { return pivot_ok(a, b); }
};

}  // namespace eom::gen::ops
