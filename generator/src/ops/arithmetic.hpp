// The arithmetic operations (entries of the operation table, ops/op.hpp says what each member is).
// Derivative forms follow runtime/include/eom/numeric/ad.hpp, so derived kernels agree with the reference
// to round-off.
#pragma once

#include "ops/op.hpp"

namespace eom::gen::ops {

struct Neg : Real<1> {
  static constexpr Op op = Op::Neg;
  static constexpr std::string_view name = "neg";
  static constexpr Spelling spelling{Form::prefix, "-", 3};
  static double eval(double a, double, double) { return -a; }
  static NodeId derivative(Graph& g, NodeId, int, NodeId w) { return g.neg(w); }
  template <class P> static void taylor_plan(P& p) { p.linear(); }
  template <class X> static void taylor(X& x) { x.self(x.apply(op, x.c(0))); }
};

struct Add : Real<2> {
  static constexpr Op op = Op::Add;
  static constexpr std::string_view name = "add";
  static constexpr bool commutative = true;
  static constexpr Spelling spelling{Form::infix, " + ", 6};
  static double eval(double a, double b, double) { return a + b; }
  static NodeId derivative(Graph&, NodeId, int, NodeId w) { return w; }
  template <class P> static void taylor_plan(P& p) { p.linear(); }
  template <class X> static void taylor(X& x) {
    x.self(x.varying(0) && x.varying(1) ? x.apply(op, x.c(0), x.c(1))
           : x.varying(0)               ? x.c(0)
                                        : x.c(1));
  }
};

struct Sub : Real<2> {
  static constexpr Op op = Op::Sub;
  static constexpr std::string_view name = "sub";
  static constexpr Spelling spelling{Form::infix, " - ", 6};
  static double eval(double a, double b, double) { return a - b; }
  static NodeId derivative(Graph& g, NodeId, int i, NodeId w) { return i == 0 ? w : g.neg(w); }
  template <class P> static void taylor_plan(P& p) { p.linear(); }
  template <class X> static void taylor(X& x) {
    x.self(x.varying(0) && x.varying(1) ? x.apply(op, x.c(0), x.c(1))
           : x.varying(0)               ? x.c(0)
                                        : x.apply(Op::Neg, x.c(1)));
  }
};

struct Mul : Real<2> {
  static constexpr Op op = Op::Mul;
  static constexpr std::string_view name = "mul";
  static constexpr bool commutative = true;
  static constexpr Spelling spelling{Form::infix, " * ", 5};
  static double eval(double a, double b, double) { return a * b; }
  static NodeId derivative(Graph& g, NodeId n, int i, NodeId w) {
    return g.mul(w, g[n].arg[1 - i]);
  }
  // A product of two series convolves them; a constant factor scales.
  template <class P> static void taylor_plan(P& p) {
    if (p.varying(0) && p.varying(1)) {
      p.history(0);
      p.history(1);
      p.no_own_history();
    } else {
      p.linear();
    }
  }
  template <class X> static void taylor(X& x) {
    if (x.varying(0) && x.varying(1))
      x.self(x.same_args() ? x.square(x.S(0)) : x.product(x.S(0), x.S(1)));
    else
      x.self(x.varying(0) ? x.apply(op, x.c(0), x.v(1)) : x.apply(op, x.v(0), x.c(1)));
  }
};

struct Div : Real<2> {
  static constexpr Op op = Op::Div;
  static constexpr std::string_view name = "div";
  static constexpr Spelling spelling{Form::infix, " / ", 5};
  static double eval(double a, double b, double) { return a / b; }
  static NodeId derivative(Graph& g, NodeId n, int i, NodeId w) {  // da/b − (a/b)·db/b
    const NodeId b = g[n].arg[1];
    return i == 0 ? g.div(w, b) : g.neg(g.div(g.mul(w, n), b));
  }
  // A series denominator: the quotient recurrence reads the denominator's and its own history;
  // the numerator's coefficient k only.
  template <class P> static void taylor_plan(P& p) {
    p.history(1);
    if (!p.varying(1)) p.linear();
  }
  template <class X> static void taylor(X& x) {
    if (x.varying(1))
      x.self(x.quotient(x.varying(0) ? x.c(0) : x.constant(0.0), x.S(1), x.self_S()));
    else
      x.self(x.apply(op, x.c(0), x.v(1)));
  }
};

}  // namespace eom::gen::ops
