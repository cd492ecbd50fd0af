// A valid model (a falling point mass), misused by the CMake calls around it.
#pragma once

#include <array>

#include <eom/model/model.hpp>

struct Good {
  static constexpr std::array coordinates{"y"};
  static constexpr std::array parameters{"m", "g"};
  static constexpr std::array parameter_values{1.0, 9.81};

  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S> p) {
    return 0.5 * p[0] * qd[0] * qd[0];
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    return p[0] * p[1] * q[0];
  }
};
