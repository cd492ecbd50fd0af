// A model whose potential throws when it is evaluated.
#pragma once

#include <array>
#include <stdexcept>

#include <eom/model/model.hpp>

struct Throws {
  static constexpr std::array coordinates{"x"};

  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S>) {
    return 0.5 * qd[0] * qd[0];
  }
  template <class S> static S potential_energy(eom::In<S>, eom::In<S>) {
    throw std::runtime_error("potential not implemented");
  }
};
