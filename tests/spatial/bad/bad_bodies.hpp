// Spatial-body models that must not generate: each has two bodies, body 0 sound and body 1 broken
// in one way at the default parameters; the tracer must fail naming the model and "body 1".
#pragma once

#include <array>

#include <eom/model/model.hpp>
#include <eom/multibody/spatial.hpp>

template <int Case> struct TwoBodies {
  static constexpr std::array coordinates{"a", "b"};
  static constexpr int body_count = 2;

  template <class S>
  static void bodies(eom::In<S> q, eom::In<S>, eom::Out<eom::SpatialBody<S>> out) {
    const eom::Transform<S> first = eom::revolute<S>({0, 0, 1}, q[0]);
    const eom::Transform<S> second = first * eom::origin<S>({1, 0, 0}, {0, 0, 0}) * eom::revolute<S>({0, 1, 0}, q[1]);
    out[0] = eom::rigid_body<S>(first, S(1), {S(0.1), S(0.1), S(0.1), S(0), S(0), S(0)});
    std::array<S, 6> J{S(0.1), S(0.2), S(0.25), S(0), S(0), S(0)};
    S mass(2);
    if constexpr (Case == 1) mass = S(-2);                 // negative mass
    if constexpr (Case == 2) J[3] = S(0.3);                // Ixy too large: not PSD
    if constexpr (Case == 3) J[2] = S(0.5);                // Izz > Ixx + Iyy
    out[1] = eom::rigid_body<S>(second, mass, J);
    if constexpr (Case == 0)                               // a shear, not a rotation
      out[1].rotation[3] = out[1].rotation[3] + S(0.1);
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S>) { return q[0] * q[0]; }
};

struct NonOrthonormal : TwoBodies<0> {};
struct NegativeMass : TwoBodies<1> {};
struct NotPositiveDefinite : TwoBodies<2> {};
struct TriangleViolation : TwoBodies<3> {};
