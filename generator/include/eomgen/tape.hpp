// The recording scalar. A model's template functions, instantiated with S = eom::gen::Expr, build
// the DAG of their own arithmetic: every operation on an Expr is a Graph::make() on the active
// tape's graph (so it is hash-consed, folded and simplified as it is recorded).
//
// Comparisons of Exprs yield a Cond, which is a node too. A Cond can only feed eom::select(); a
// model that branches on one (`if (x < 0)`, `std::max(a, b)`, `c ? a : b`) would freeze one
// branch into the tape, so converting a Cond to bool throws a TraceError that names the model
// and the function being traced.
#pragma once

#include <concepts>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

#include <eom/model/model.hpp>  // eom::select, which calls eom_select below for a Cond

#include "eomgen/graph.hpp"

namespace eom::gen {

class TraceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A graph being recorded into, with what is being traced (for error messages).
class Tape {
 public:
  // `model` names the model in messages, e.g. "model spring_pendulum (SpringPendulum)".
  Tape(Graph& graph, std::string model) : graph_(graph), model_(std::move(model)) {}
  Tape(const Tape&) = delete;
  Tape& operator=(const Tape&) = delete;

  Graph& graph() { return graph_; }
  const std::string& model() const { return model_; }
  const std::string& function() const { return function_; }

  // While a Recording lives, Expr operations on this thread record into `tape`, attributed to
  // `function` (kinetic_energy, potential_energy, constraints, generalized_forces).
  class Recording {
   public:
    Recording(Tape& tape, std::string_view function);
    ~Recording();
    Recording(const Recording&) = delete;
    Recording& operator=(const Recording&) = delete;

   private:
    Tape* previous_;
    std::string previous_function_;
  };

  static Tape& active();  // throws TraceError when nothing is being recorded

 private:
  Graph& graph_;
  std::string model_;
  std::string function_;
};

// A recorded value: the id of its node in the active tape's graph (4 bytes, trivially copyable).
// Numbers convert implicitly to constant nodes, so `0.5 * m` and `x < 0` read as in any model.
class Expr {
 public:
  Expr() = default;  // 0: node 0 of every graph, so it needs no tape
  template <class C>
    requires(std::is_arithmetic_v<C>)
  Expr(C c) : id_(Tape::active().graph().constant(static_cast<double>(c))) {}  // NOLINT

  static Expr node(NodeId id) {
    Expr e;
    e.id_ = id;
    return e;
  }
  NodeId id() const { return id_; }

  Expr& operator+=(const Expr& b) { return *this = *this + b; }
  Expr& operator-=(const Expr& b) { return *this = *this - b; }
  Expr& operator*=(const Expr& b) { return *this = *this * b; }
  Expr& operator/=(const Expr& b) { return *this = *this / b; }

  friend Expr operator+(const Expr& a) { return a; }
  friend Expr operator-(const Expr& a) { return record(Op::Neg, a); }
  friend Expr operator+(const Expr& a, const Expr& b) { return record(Op::Add, a, b); }
  friend Expr operator-(const Expr& a, const Expr& b) { return record(Op::Sub, a, b); }
  friend Expr operator*(const Expr& a, const Expr& b) { return record(Op::Mul, a, b); }
  friend Expr operator/(const Expr& a, const Expr& b) { return record(Op::Div, a, b); }

  static Expr record(Op op, const Expr& a) { return node(Tape::active().graph().make(op, a.id_)); }
  static Expr record(Op op, const Expr& a, const Expr& b) {
    return node(Tape::active().graph().make(op, a.id_, b.id_));
  }

 private:
  NodeId id_ = Graph::zero;
};

// A recorded condition: usable in eom::select(), never as a bool.
class Cond {
 public:
  static Cond node(NodeId id) {
    Cond c;
    c.id_ = id;
    return c;
  }
  NodeId id() const { return id_; }

  // Branching on a traced value: always an error (see the file comment).
  [[noreturn]] explicit operator bool() const;

  friend Cond operator!(const Cond& a) { return record(Op::Not, a, a); }
  friend Cond operator&&(const Cond& a, const Cond& b) { return record(Op::And, a, b); }
  friend Cond operator||(const Cond& a, const Cond& b) { return record(Op::Or, a, b); }

 private:
  static Cond record(Op op, const Cond& a, const Cond& b) {
    return node(Tape::active().graph().make(op, a.id_, b.id_));
  }
  NodeId id_ = Graph::zero;
};

inline Cond compare(Op op, const Expr& a, const Expr& b) {
  return Cond::node(Tape::active().graph().make(op, a.id(), b.id()));
}
inline Cond operator<(const Expr& a, const Expr& b) { return compare(Op::Less, a, b); }
inline Cond operator>(const Expr& a, const Expr& b) { return compare(Op::Less, b, a); }
inline Cond operator<=(const Expr& a, const Expr& b) { return compare(Op::LessEqual, a, b); }
inline Cond operator>=(const Expr& a, const Expr& b) { return compare(Op::LessEqual, b, a); }
inline Cond operator==(const Expr& a, const Expr& b) { return compare(Op::Equal, a, b); }
inline Cond operator!=(const Expr& a, const Expr& b) { return compare(Op::NotEqual, a, b); }

// eom::select(cond, a, b) lands here (argument-dependent lookup on Cond): a Select node.
inline Expr eom_select(const Cond& c, const Expr& a, const Expr& b) {
  return Expr::node(Tape::active().graph().make(Op::Select, c.id(), a.id(), b.id()));
}

// Elementary functions, found by argument-dependent lookup like their <cmath> namesakes.
inline Expr sin(const Expr& a) { return Expr::record(Op::Sin, a); }
inline Expr cos(const Expr& a) { return Expr::record(Op::Cos, a); }
inline Expr tan(const Expr& a) { return Expr::record(Op::Tan, a); }
inline Expr tanh(const Expr& a) { return Expr::record(Op::Tanh, a); }
inline Expr asin(const Expr& a) { return Expr::record(Op::Asin, a); }
inline Expr acos(const Expr& a) { return Expr::record(Op::Acos, a); }
inline Expr atan(const Expr& a) { return Expr::record(Op::Atan, a); }
inline Expr exp(const Expr& a) { return Expr::record(Op::Exp, a); }
inline Expr log(const Expr& a) { return Expr::record(Op::Log, a); }
inline Expr sqrt(const Expr& a) { return Expr::record(Op::Sqrt, a); }
inline Expr abs(const Expr& a) { return Expr::record(Op::Abs, a); }
inline Expr fabs(const Expr& a) { return Expr::record(Op::Abs, a); }
inline Expr atan2(const Expr& y, const Expr& x) { return Expr::record(Op::Atan2, y, x); }
inline Expr hypot(const Expr& a, const Expr& b) { return Expr::record(Op::Hypot, a, b); }
inline Expr pow(const Expr& a, const Expr& b) { return Expr::record(Op::Pow, a, b); }
// An integer exponent is recorded as products (Graph::make expands a constant integral power).
inline Expr pow(const Expr& a, int n) { return pow(a, Expr(n)); }
inline Expr pow(const Expr& a, double r) { return pow(a, Expr(r)); }
inline Expr pow(double c, const Expr& b) { return pow(Expr(c), b); }

}  // namespace eom::gen
