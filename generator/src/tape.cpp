#include "eomgen/tape.hpp"

namespace eom::gen {
namespace {
thread_local Tape* active_tape = nullptr;
}

Tape::Recording::Recording(Tape& tape, std::string_view function)
    : previous_(active_tape), previous_function_(tape.function_) {
  tape.function_ = function;
  active_tape = &tape;
}

Tape::Recording::~Recording() {
  active_tape->function_ = previous_function_;
  active_tape = previous_;
}

Tape& Tape::active() {
  if (!active_tape)
    throw TraceError("eomgen: an eom::gen::Expr operation outside of a recording (no active tape)");
  return *active_tape;
}

Cond::operator bool() const {
  const Tape& tape = Tape::active();
  throw TraceError(tape.model() + ": " + tape.function() +
                   " branches on a traced value (a comparison used as a bool, e.g. in if, ?:, "
                   "std::max); write eom::select(condition, if_true, if_false) instead");
}

}  // namespace eom::gen
