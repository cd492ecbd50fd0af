// The planar chain eom::models::UndampedChain<N> (models/chain.hpp: absolute link angles θᵢ from
// the horizontal, links of mass mᵢ, length lᵢ, inertia Iᵢ about the mass centre at the middle,
// gravity along −y) in two more forms:
//
//   SpatialChain<N>  the body form with eom::SpatialBody: link i's frame is {Rz(θᵢ), joint i},
//                    its body a slender rod along its own z axis, inertia (Iᵢ, Iᵢ, 0), whose
//                    inertial frame translation(lᵢ/2 e_x)·origin(0, rpy(π/2, π/2, π/2)) turns the
//                    rod's axis onto the link (rpy(π/2, π/2, π/2) maps body z to x, body y to y);
//   ChainEnergy<N>   T written out by hand: the mass centre of link k moves with
//                      v_k = Σ_{i≤k} a_ki θ̇ᵢ (−sin θᵢ, cos θᵢ),  a_ki = lᵢ (i < k), lₖ/2 (i = k),
//                    T = ½ Σ_k (m_k |v_k|² + I_k θ̇_k²),  V = g Σ_k m_k y_k.
#pragma once

#include <array>
#include <cmath>
#include <numbers>

#include <eom/model/model.hpp>
#include <eom/multibody/spatial.hpp>
#include <models/chain.hpp>

namespace spatial_test {

template <int N> struct SpatialChain {
  using Planar = eom::models::UndampedChain<N>;
  static constexpr auto coordinates = Planar::coordinates;
  static constexpr auto parameters = Planar::parameters;
  static constexpr auto parameter_values = Planar::parameter_values;
  static constexpr int body_count = N;

  template <class S>
  static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {
    constexpr double quarter = std::numbers::pi / 2;
    eom::Vec3<S> joint{S(0), S(0), S(0)};
    for (int i = 0; i < N; ++i) {
      const S& l = p[N + i];
      const eom::Transform<S> frame{eom::rot_z(q[i]), joint};
      const eom::Transform<S> inertial =
          eom::translation<S>({0.5 * l, S(0), S(0)}) * eom::origin<S>({0, 0, 0}, {quarter, quarter, quarter});
      b[i] = eom::rigid_body<S>(frame, p[i], {p[2 * N + i], p[2 * N + i], S(0), S(0), S(0), S(0)},
                                inertial);
      joint = frame.apply({l, S(0), S(0)});
    }
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    return Planar::template potential_energy<S>(q, p);
  }
};

template <int N> struct ChainEnergy {
  using Planar = eom::models::UndampedChain<N>;
  static constexpr auto coordinates = Planar::coordinates;
  static constexpr auto parameters = Planar::parameters;
  static constexpr auto parameter_values = Planar::parameter_values;

  template <class S> static S kinetic_energy(eom::In<S> q, eom::In<S> qd, eom::In<S> p) {
    using std::cos, std::sin;
    S twice_T(0), vx(0), vy(0);  // vx, vy: velocity of the current joint
    for (int k = 0; k < N; ++k) {
      const S &m = p[k], &l = p[N + k], &I = p[2 * N + k];
      const S wx = -sin(q[k]) * qd[k], wy = cos(q[k]) * qd[k];
      const S cx = vx + 0.5 * l * wx, cy = vy + 0.5 * l * wy;  // mass centre
      twice_T = twice_T + m * (cx * cx + cy * cy) + I * qd[k] * qd[k];
      vx = vx + l * wx;
      vy = vy + l * wy;
    }
    return 0.5 * twice_T;
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    using std::sin;
    S V(0), y(0);
    for (int k = 0; k < N; ++k) {
      const S &m = p[k], &l = p[N + k];
      V = V + m * p[4 * N] * (y + 0.5 * l * sin(q[k]));
      y = y + l * sin(q[k]);
    }
    return V;
  }
};

}  // namespace spatial_test
