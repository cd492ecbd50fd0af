// The cart-pole: a cart on a horizontal rail, pushed by a force u, carrying a uniform pole on a
// frictionless pin. This is a user's model: it lives with the example, not in eomgen.
//
// q = (x, theta): the cart's position and the pole's angle from the upward vertical (positive
// towards +x), so the upright equilibrium is q = 0. The pole (mass mp, length 2l, inertia
// mp l²/3 about its middle) has its mass centre at (x + l sin θ, l cos θ); gravity acts along −y.
#pragma once

#include <array>
#include <cmath>
#include <numbers>

#include <eom/model/model.hpp>

namespace examples {

struct CartPole {
  static constexpr std::array coordinates{"x", "theta"};
  static constexpr std::array parameters{"mc", "mp", "l", "g"};
  static constexpr std::array parameter_values{1.0, 0.3, 0.4, 9.81};
  static constexpr std::array inputs{"force"};

  static constexpr int body_count = 2;  // the cart and the pole
  template <class S>
  static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::PlanarBody<S>> b) {
    using std::cos, std::sin;
    const S &mc = p[0], &mp = p[1], &l = p[2];
    b[0].mass = mc;  // the cart translates only: its inertia does not matter
    b[0].inertia = S(0);
    b[0].x = q[0];
    b[0].y = S(0);
    b[0].angle = S(0);
    b[1].mass = mp;
    b[1].inertia = mp * l * l / 3.0;
    b[1].x = q[0] + l * sin(q[1]);
    b[1].y = l * cos(q[1]);
    b[1].angle = std::numbers::pi / 2 - q[1];  // from the horizontal
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    using std::cos;
    return p[1] * p[3] * p[2] * cos(q[1]);
  }
  template <class S> static void generalized_forces(const S &, eom::In<S>, eom::In<S>, eom::In<S> u,
                                                    eom::In<S>, eom::Out<S> Q) {
    Q[0] = u[0];
    Q[1] = S(0);
  }
};

}  // namespace examples
