// The 1-dof models of the event tests, in the project's model form (docs/CONTRACT.md §1).
#pragma once

#include <array>
#include <cmath>

#include <eom/model/model.hpp>

namespace eom_events {

// A ball in free fall over the floor y = 0: T = ½ m ẏ², V = m g y. Its impacts are the events.
struct Ball {
  static constexpr std::array coordinates{"y"};
  static constexpr std::array parameters{"m", "g"};
  static constexpr std::array parameter_values{0.5, 9.81};

  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S> p) {
    return 0.5 * p[0] * qd[0] * qd[0];
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) { return p[0] * p[1] * q[0]; }
};

// The plane pendulum, θ from the downward vertical: T = ½ m l² θ̇², V = −m g l cos θ.
struct Pendulum {
  static constexpr std::array coordinates{"theta"};
  static constexpr std::array parameters{"m", "l", "g"};
  static constexpr std::array parameter_values{1.0, 0.7, 9.81};

  template <class S> static S kinetic_energy(eom::In<S>, eom::In<S> qd, eom::In<S> p) {
    return 0.5 * p[0] * p[1] * p[1] * qd[0] * qd[0];
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    using std::cos;
    return -p[0] * p[2] * p[1] * cos(q[0]);
  }
};

}  // namespace eom_events
