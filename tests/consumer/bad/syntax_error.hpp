// A model header that does not compile (a missing semicolon).
#pragma once

#include <array>

#include <eom/model/model.hpp>

struct SyntaxError {
  static constexpr std::array coordinates{"x"}
  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S>) {
    return 0.5 * qd[0] * qd[0];
  }
  template <class S> static S potential_energy(eom::In<S>, eom::In<S>) { return S(0); }
};
