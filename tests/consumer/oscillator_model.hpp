// A linear oscillator: T = ½ m q̇², V = ½ k q²; the template argument is the default stiffness.
#pragma once

#include <array>

#include <eom/model/model.hpp>

namespace consumer {

template <int K> struct Oscillator {
  static constexpr std::array coordinates{"q"};
  static constexpr std::array parameters{"m", "k"};
  static constexpr std::array parameter_values{1.0, double(K)};

  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S> p) {
    return 0.5 * p[0] * qd[0] * qd[0];
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    return 0.5 * p[1] * q[0] * q[0];
  }
};

}  // namespace consumer
