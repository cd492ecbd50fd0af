// The elementary functions (entries of the operation table, ops/op.hpp says what each member is).
// Each prints as its <cmath> namesake. Taylor rules (Griewank & Walther, "Evaluating
// Derivatives", ch. 13): most go through the derivative's ODE, c' = a'·b ("integral") or
// b·c' = a' ("inverse integral"), with b an auxiliary series when it is not a node already.
#pragma once

#include "ops/op.hpp"

namespace eom::gen::ops {

template <Op o, int n = 1> struct Call : Real<n> {
  static constexpr Op op = o;
};

// sin and cos of one argument are one pair of series: s' = a'c, c' = −a's. The one with the lower
// id computes both (its partner's series, or an auxiliary when the partner is not in the cone).
template <bool is_sin, class X> void sin_cos(X& x) {
  const auto other = x.paired() ? x.partner_S() : x.aux(0);
  const auto sin = is_sin ? x.self_S() : other;
  const auto cos = is_sin ? other : x.self_S();
  x.set(sin, x.integral(x.S(0), cos));
  x.set(cos, x.apply(Op::Neg, x.integral(x.S(0), sin)));
}

struct Sin : Call<Op::Sin> {
  static constexpr std::string_view name = "sin";
  static constexpr Spelling spelling{Form::call, "std::sin", 0};
  static constexpr Op partner = Op::Cos;
  static constexpr std::array aux{AuxSeries{"cos", "cos of the argument"}};
  static double eval(double a, double, double) { return std::sin(a); }
  static NodeId derivative(Graph& g, NodeId n, int, NodeId w) {
    return g.mul(w, g.make(Op::Cos, g[n].arg[0]));
  }
  template <class P> static void taylor_plan(P& p) { p.history(0); }
  template <class P> static int taylor_aux_count(const P& p) { return p.paired() ? 0 : 1; }
  template <class X> static void taylor_order0(X& x) { x.set_aux0(0, x.apply(Op::Cos, x.v(0))); }
  template <class X> static void taylor(X& x) { sin_cos<true>(x); }
};

struct Cos : Call<Op::Cos> {
  static constexpr std::string_view name = "cos";
  static constexpr Spelling spelling{Form::call, "std::cos", 0};
  static constexpr Op partner = Op::Sin;
  static constexpr std::array aux{AuxSeries{"sin", "sin of the argument"}};
  static double eval(double a, double, double) { return std::cos(a); }
  static NodeId derivative(Graph& g, NodeId n, int, NodeId w) {
    return g.neg(g.mul(w, g.make(Op::Sin, g[n].arg[0])));
  }
  template <class P> static void taylor_plan(P& p) { p.history(0); }
  template <class P> static int taylor_aux_count(const P& p) { return p.paired() ? 0 : 1; }
  template <class X> static void taylor_order0(X& x) { x.set_aux0(0, x.apply(Op::Sin, x.v(0))); }
  template <class X> static void taylor(X& x) { sin_cos<false>(x); }
};

// t = tan a: t' = a'(1 + t²); t = tanh a: t' = a'(1 − t²) (smooth friction and saturation laws
// use it). The auxiliary series is the derivative's factor 1 ± t².
template <Op o> struct Tangent : Call<o> {
  static constexpr Op plus_or_minus = o == Op::Tan ? Op::Add : Op::Sub;
  static NodeId derivative(Graph& g, NodeId n, int, NodeId w) {
    return g.mul(w, g.make(plus_or_minus, Graph::one, g.mul(n, n)));
  }
  template <class P> static void taylor_plan(P& p) { p.history(0); }
  template <class P> static int taylor_aux_count(const P&) { return 1; }
  template <class X> static void taylor_order0(X& x) {
    x.set_aux0(0, x.apply(plus_or_minus, x.constant(1.0), x.apply(Op::Mul, x.self_v(), x.self_v())));
  }
  template <class X> static void taylor(X& x) {
    x.self(x.integral(x.S(0), x.aux(0)));
    const auto square = x.square(x.self_S());  // coefficient k of t²
    x.set(x.aux(0), o == Op::Tan ? square : x.apply(Op::Neg, square));
  }
};
struct Tan : Tangent<Op::Tan> {
  static constexpr std::string_view name = "tan";
  static constexpr Spelling spelling{Form::call, "std::tan", 0};
  static constexpr std::array aux{AuxSeries{"sec2", "1 + tan^2"}};
  static double eval(double a, double, double) { return std::tan(a); }
};
struct Tanh : Tangent<Op::Tanh> {
  static constexpr std::string_view name = "tanh";
  static constexpr Spelling spelling{Form::call, "std::tanh", 0};
  static constexpr std::array aux{AuxSeries{"sech2", "1 - tanh^2"}};
  static double eval(double a, double, double) { return std::tanh(a); }
};

// asin a: c'·√(1 − a²) = a'; acos a: the same with −a'.
template <Op o> struct InverseSine : Call<o> {
  static constexpr std::array aux{AuxSeries{"root", "sqrt(1 - a^2)"}};
  static NodeId derivative(Graph& g, NodeId n, int, NodeId w) {
    const NodeId a = g[n].arg[0];
    const NodeId d = g.div(w, g.make(Op::Sqrt, g.sub(Graph::one, g.mul(a, a))));
    return o == Op::Asin ? d : g.neg(d);
  }
  template <class P> static void taylor_plan(P& p) { p.history(0); }
  template <class P> static int taylor_aux_count(const P&) { return 1; }
  template <class X> static void taylor_order0(X& x) {
    const auto one = x.constant(1.0);
    x.set_aux0(0, x.apply(Op::Sqrt, x.apply(Op::Mul, x.apply(Op::Sub, one, x.v(0)),
                                            x.apply(Op::Add, one, x.v(0)))));
  }
  template <class X> static void taylor(X& x) {
    x.set(x.aux(0), x.root(x.apply(Op::Neg, x.square(x.S(0))), x.aux(0)));
    x.self(x.inverse_integral(o == Op::Asin ? x.c(0) : x.apply(Op::Neg, x.c(0)), x.aux(0),
                              x.self_S()));
  }
};
struct Asin : InverseSine<Op::Asin> {
  static constexpr std::string_view name = "asin";
  static constexpr Spelling spelling{Form::call, "std::asin", 0};
  static double eval(double a, double, double) { return std::asin(a); }
};
struct Acos : InverseSine<Op::Acos> {
  static constexpr std::string_view name = "acos";
  static constexpr Spelling spelling{Form::call, "std::acos", 0};
  static double eval(double a, double, double) { return std::acos(a); }
};

// atan a: c'·(1 + a²) = a'.
struct Atan : Call<Op::Atan> {
  static constexpr std::string_view name = "atan";
  static constexpr Spelling spelling{Form::call, "std::atan", 0};
  static constexpr std::array aux{AuxSeries{"den", "1 + a^2"}};
  static double eval(double a, double, double) { return std::atan(a); }
  static NodeId derivative(Graph& g, NodeId n, int, NodeId w) {
    const NodeId a = g[n].arg[0];
    return g.div(w, g.add(Graph::one, g.mul(a, a)));
  }
  template <class P> static void taylor_plan(P& p) { p.history(0); }
  template <class P> static int taylor_aux_count(const P&) { return 1; }
  template <class X> static void taylor_order0(X& x) {
    x.set_aux0(0, x.apply(Op::Add, x.constant(1.0), x.apply(Op::Mul, x.v(0), x.v(0))));
  }
  template <class X> static void taylor(X& x) {
    x.set(x.aux(0), x.square(x.S(0)));
    x.self(x.inverse_integral(x.c(0), x.aux(0), x.self_S()));
  }
};

// exp a: c' = a'c.
struct Exp : Call<Op::Exp> {
  static constexpr std::string_view name = "exp";
  static constexpr Spelling spelling{Form::call, "std::exp", 0};
  static double eval(double a, double, double) { return std::exp(a); }
  static NodeId derivative(Graph& g, NodeId n, int, NodeId w) { return g.mul(w, n); }
  template <class P> static void taylor_plan(P& p) { p.history(0); }
  template <class X> static void taylor(X& x) { x.self(x.integral(x.S(0), x.self_S())); }
};

// log a: a·c' = a'.
struct Log : Call<Op::Log> {
  static constexpr std::string_view name = "log";
  static constexpr Spelling spelling{Form::call, "std::log", 0};
  static double eval(double a, double, double) { return std::log(a); }
  static NodeId derivative(Graph& g, NodeId n, int, NodeId w) { return g.div(w, g[n].arg[0]); }
  template <class P> static void taylor_plan(P& p) { p.history(0); }
  template <class X> static void taylor(X& x) {
    x.self(x.inverse_integral(x.c(0), x.S(0), x.self_S()));
  }
};

// √a: c·c = a.
struct Sqrt : Call<Op::Sqrt> {
  static constexpr std::string_view name = "sqrt";
  static constexpr Spelling spelling{Form::call, "std::sqrt", 0};
  static double eval(double a, double, double) { return std::sqrt(a); }
  static NodeId derivative(Graph& g, NodeId n, int, NodeId w) {
    return g.div(w, g.mul(g.constant(2), n));
  }
  template <class X> static void taylor(X& x) { x.self(x.root(x.c(0), x.self_S())); }
};

// |a|: ±a by the sign of a₀ (+1 at a = 0, as in the reference).
struct Abs : Call<Op::Abs> {
  static constexpr std::string_view name = "abs";
  static constexpr Spelling spelling{Form::call, "std::abs", 0};
  static double eval(double a, double, double) { return std::abs(a); }
  static NodeId derivative(Graph& g, NodeId n, int, NodeId w) {
    return g.make(Op::Select, g.make(Op::Less, g[n].arg[0], Graph::zero), g.neg(w), w);
  }
  template <class P> static void taylor_plan(P& p) {
    p.history(0);
    p.linear();
  }
  template <class X> static void taylor(X& x) {
    x.self(x.apply(Op::Select, x.apply(Op::Less, x.v(0), x.constant(0.0)), x.apply(Op::Neg, x.c(0)),
                   x.c(0)));
  }
};

// a^b = exp(b log a): a constant exponent has its own recurrence; a constant base is exp of a
// multiple of b; otherwise through the auxiliaries log a and b·log a.
struct Pow : Call<Op::Pow, 2> {
  static constexpr std::string_view name = "pow";
  static constexpr Spelling spelling{Form::call, "std::pow", 0};
  static constexpr std::array aux{AuxSeries{"log", "log of the base"},
                                  AuxSeries{"exp", "exponent * log of the base"}};
  static double eval(double a, double b, double) { return std::pow(a, b); }
  static NodeId derivative(Graph& g, NodeId n, int i, NodeId w) {
    const NodeId a = g[n].arg[0], b = g[n].arg[1];
    if (i == 0) return g.mul(w, g.mul(b, g.make(Op::Pow, a, g.sub(b, Graph::one))));
    return g.mul(w, g.mul(n, g.make(Op::Log, a)));
  }
  template <class P> static void taylor_plan(P& p) {
    p.history(0);
    p.history(1);
  }
  template <class P> static int taylor_aux_count(const P& p) {
    return p.varying(0) && p.varying(1) ? 2 : 0;
  }
  template <class X> static void taylor_order0(X& x) {
    x.set_aux0(0, x.apply(Op::Log, x.v(0)));
    x.set_aux0(1, x.apply(Op::Mul, x.v(1), x.aux0(0)));
  }
  template <class X> static void taylor(X& x) {
    if (!x.varying(1)) {
      x.self(x.power(x.S(0), x.self_S(), x.v(1)));
    } else if (!x.varying(0)) {
      x.self(x.apply(Op::Mul, x.apply(Op::Log, x.v(0)), x.integral(x.S(1), x.self_S())));
    } else {
      x.set(x.aux(0), x.inverse_integral(x.c(0), x.S(0), x.aux(0)));
      x.set(x.aux(1), x.product(x.S(1), x.aux(0)));
      x.self(x.integral(x.aux(1), x.self_S()));
    }
  }
};

// atan2(y, x): c'·(x² + y²) = x y' − y x'.
struct Atan2 : Call<Op::Atan2, 2> {
  static constexpr std::string_view name = "atan2";
  static constexpr Spelling spelling{Form::call, "std::atan2", 0};
  static constexpr std::array aux{AuxSeries{"r2", "sum of the squares of the arguments"}};
  static double eval(double a, double b, double) { return std::atan2(a, b); }
  static NodeId derivative(Graph& g, NodeId n, int i, NodeId w) {
    const NodeId y = g[n].arg[0], x = g[n].arg[1];
    const NodeId r2 = g.add(g.mul(y, y), g.mul(x, x));
    return i == 0 ? g.div(g.mul(w, x), r2) : g.neg(g.div(g.mul(w, y), r2));
  }
  template <class P> static void taylor_plan(P& p) {
    p.history(0);
    p.history(1);
  }
  template <class P> static int taylor_aux_count(const P&) { return 1; }
  template <class X> static void taylor_order0(X& x) {
    x.set_aux0(0, x.apply(Op::Add, x.apply(Op::Mul, x.v(1), x.v(1)), x.apply(Op::Mul, x.v(0), x.v(0))));
  }
  template <class X> static void taylor(X& x) {
    const bool vy = x.varying(0), vx = x.varying(1);
    x.set(x.aux(0), vy && vx ? x.apply(Op::Add, x.square(x.S(1)), x.square(x.S(0)))
                    : vy     ? x.square(x.S(0))
                             : x.square(x.S(1)));
    const auto m = vy && vx ? x.cross(x.S(0), x.S(1))
                   : vy     ? x.apply(Op::Mul, x.v(1), x.c(0))
                            : x.apply(Op::Neg, x.apply(Op::Mul, x.v(0), x.c(1)));
    x.self(x.inverse_integral(m, x.aux(0), x.self_S()));
  }
};

// hypot(a, b) = √(a² + b²).
struct Hypot : Call<Op::Hypot, 2> {
  static constexpr std::string_view name = "hypot";
  static constexpr Spelling spelling{Form::call, "std::hypot", 0};
  static constexpr bool commutative = true;
  static double eval(double a, double b, double) { return std::hypot(a, b); }
  static NodeId derivative(Graph& g, NodeId n, int i, NodeId w) {
    return g.div(g.mul(w, g[n].arg[i]), n);
  }
  template <class P> static void taylor_plan(P& p) {
    p.history(0);
    p.history(1);
  }
  template <class X> static void taylor(X& x) {
    const bool va = x.varying(0), vb = x.varying(1);
    x.self(x.root(va && vb ? x.apply(Op::Add, x.square(x.S(0)), x.square(x.S(1)))
                  : va     ? x.square(x.S(0))
                           : x.square(x.S(1)),
                  x.self_S()));
  }
};

}  // namespace eom::gen::ops
