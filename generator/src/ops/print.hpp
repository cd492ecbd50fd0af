// The printer: an operation applied to operand texts, as C++ (emit.cpp's statements and the Taylor
// kernel's rules). Parentheses come from C++ precedence: an operand binding more loosely than the
// operation is parenthesized, and so is an infix operation's right operand of equal precedence,
// which keeps the evaluation order as the graph has it (a + (b + c) is not (a + b) + c in floating
// point).
#pragma once

#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

#include "ops/table.hpp"

namespace eom::gen::ops {

struct Text {
  std::string s;
  int precedence = 0;  // 0: a name, a literal or a call
};

// math: the namespace of the standard math functions as printed ("std::"; the batch kernel's
// lanewise functions are "batch_": batch_sin, batch_cos).
inline Text print(Op op, std::span<const Text> args, std::string_view math = "std::") {
  const Spelling& sp = info(op).spelling;
  if (args.size() != static_cast<std::size_t>(info(op).arity))
    throw std::logic_error("eomgen: print() of " + std::string(info(op).name) + " with " +
                           std::to_string(args.size()) + " operands");
  auto in = [&](const Text& t, bool parenthesize) { return parenthesize ? "(" + t.s + ")" : t.s; };
  switch (sp.form) {
    case Form::prefix:
      return {std::string(sp.symbol) + in(args[0], args[0].precedence >= sp.precedence), sp.precedence};
    case Form::infix:
      return {in(args[0], args[0].precedence > sp.precedence) + std::string(sp.symbol) +
                  in(args[1], args[1].precedence >= sp.precedence),
              sp.precedence};
    case Form::call: {
      std::string_view f = sp.symbol;
      std::string s = f.starts_with("std::") ? std::string(math) + std::string(f.substr(5)) + "("
                                             : std::string(f) + "(";
      for (std::size_t i = 0; i < args.size(); ++i) s += (i ? ", " : "") + args[i].s;
      return {s + ")", 0};
    }
    case Form::ternary:
      return {in(args[0], args[0].precedence >= sp.precedence) + " ? " +
                  in(args[1], args[1].precedence >= sp.precedence) + " : " +
                  in(args[2], args[2].precedence >= sp.precedence),
              sp.precedence};
    case Form::leaf: break;
  }
  throw std::logic_error("eomgen: print() of a leaf");
}

template <class... T> Text print(Op op, const T&... operand) {
  const Text args[] = {operand...};
  return print(op, std::span<const Text>(args));
}

}  // namespace eom::gen::ops
