// Momentum of a spatial body-form model (eom::SpatialBody), from the same forward pass as
// eom::kinetic_energy_of: the bodies are evaluated once over V = Embedded<1, S, 1> with q̇ as the
// direction, so each pose carries its rate (r, ṙ) and (R, Ṙ), and ω = (RᵀṘ)^∨ in body axes.
//
//   eom::body_motions_of<Model>(q, qd, p)      per body: mass, inertia, r, v, R, ω (body axes)
//   eom::angular_momentum_of<Model>(q, qd, p)  H = Σᵢ (mᵢ rᵢ × vᵢ + Rᵢ Jᵢ ωᵢ) about the world
//                                              origin, in world axes
//
// H is conserved when no external force or torque has a moment about the origin (internal springs
// and dampers, reaction forces at a point fixed at the origin); dH/dt equals that moment otherwise.
#pragma once

#include <array>
#include <cstddef>
#include <type_traits>

#include "eom/model/model.hpp"
#include "eom/numeric/ad.hpp"

namespace eom {

// One body's state of motion, in world axes unless said otherwise.
template <class S> struct BodyMotion {
  S mass{};
  std::array<S, 6> inertia{};   // about the mass centre, body axes (Ixx Iyy Izz Ixy Ixz Iyz)
  std::array<S, 3> position{};  // mass centre
  std::array<S, 3> velocity{};  // mass-centre velocity
  std::array<S, 9> rotation{};  // body to world, column-major
  std::array<S, 3> angular_velocity{};  // ω in body axes, (RᵀṘ)^∨

  // ω in world axes, R ω.
  std::array<S, 3> world_angular_velocity() const {
    const auto& R = rotation;
    const auto& w = angular_velocity;
    return {R[0] * w[0] + R[3] * w[1] + R[6] * w[2], R[1] * w[0] + R[4] * w[1] + R[7] * w[2],
            R[2] * w[0] + R[5] * w[1] + R[8] * w[2]};
  }
  // The angular momentum about the mass centre in world axes, R J ω.
  std::array<S, 3> spin_momentum() const {
    const auto& J = inertia;  // Ixx, Iyy, Izz, Ixy, Ixz, Iyz
    const auto& w = angular_velocity;
    const std::array<S, 3> Jw{J[0] * w[0] + J[3] * w[1] + J[4] * w[2],
                              J[3] * w[0] + J[1] * w[1] + J[5] * w[2],
                              J[4] * w[0] + J[5] * w[1] + J[2] * w[2]};
    const auto& R = rotation;
    return {R[0] * Jw[0] + R[3] * Jw[1] + R[6] * Jw[2], R[1] * Jw[0] + R[4] * Jw[1] + R[7] * Jw[2],
            R[2] * Jw[0] + R[5] * Jw[1] + R[8] * Jw[2]};
  }
  // The angular momentum about the world origin, m r × v + R J ω.
  std::array<S, 3> angular_momentum() const {
    const auto& r = position;
    const auto& v = velocity;
    const auto spin = spin_momentum();
    return {mass * (r[1] * v[2] - r[2] * v[1]) + spin[0],
            mass * (r[2] * v[0] - r[0] * v[2]) + spin[1],
            mass * (r[0] * v[1] - r[1] * v[0]) + spin[2]};
  }
};

// Every body's motion at (q, q̇) (std::type_identity_t: S is given or double, not deduced, so
// std::array and std::vector arguments convert).
template <class M, class S = double>
std::array<BodyMotion<S>, M::body_count> body_motions_of(std::type_identity_t<In<S>> q,
                                                         std::type_identity_t<In<S>> qd,
                                                         std::type_identity_t<In<S>> p) {
  static_assert(detail::bodies_callable_with<M, double, SpatialBody>,
                "eom::body_motions_of: the model must write eom::SpatialBody bodies");
  const auto b = bodies_along<M, S>(q, qd, p);
  std::array<BodyMotion<S>, M::body_count> out;
  for (int k = 0; k < M::body_count; ++k) {
    const auto& body = b[k];
    BodyMotion<S>& m = out[k];
    m.mass = body.mass.v;
    for (int i = 0; i < 6; ++i) m.inertia[i] = body.inertia[i].v;
    for (int i = 0; i < 3; ++i) {
      m.position[i] = body.position[i].v;
      m.velocity[i] = body.position[i].g[0];
    }
    for (int i = 0; i < 9; ++i) m.rotation[i] = body.rotation[i].v;
    m.angular_velocity = detail::angular_velocity<S>(body.rotation);
  }
  return out;
}

// H = Σᵢ (mᵢ rᵢ × vᵢ + Rᵢ Jᵢ ωᵢ) of bodies from body_motions_of, about the world origin.
template <class S, std::size_t N>
std::array<S, 3> angular_momentum(const std::array<BodyMotion<S>, N>& bodies) {
  std::array<S, 3> H{S(0), S(0), S(0)};
  for (const auto& body : bodies) {
    const auto h = body.angular_momentum();
    for (int i = 0; i < 3; ++i) H[i] = H[i] + h[i];
  }
  return H;
}

// The same from the state: H = Σᵢ (mᵢ rᵢ × vᵢ + Rᵢ Jᵢ ωᵢ) about the world origin, world axes.
template <class M, class S = double>
std::array<S, 3> angular_momentum_of(std::type_identity_t<In<S>> q, std::type_identity_t<In<S>> qd,
                                     std::type_identity_t<In<S>> p) {
  return angular_momentum(body_motions_of<M, S>(q, qd, p));
}

}  // namespace eom
