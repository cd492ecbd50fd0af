// The spacecraft of models/spacecraft_boom.hpp flying free: the same hub and 6-link boom, the same
// hinge springs and dampers, but the hub is a free body (a free joint, eom/model/free_joint.hpp) instead
// of one whose mass centre is pinned at the origin. Its attitude is a unit quaternion, so no
// Euler-angle singularity exists anywhere, and its mass centre drifts as the boom's 6 kg unfold:
// the system's mass centre is what stays put (no external force), and the linear and angular
// momenta are conserved exactly.
//
// Written in the tree form (eom/multibody/tree.hpp): link 0 the free hub, links 1..6 the boom, hinge k on
// link k−1's +x end turning about z, y, z, y, z, y. The generator then traces the recursive
// algorithms with the free root (RNEA, ABA) and keeps them where they are cheaper.
//
// Coordinates (13) and velocities (12):
//   x, y, z, qw, qx, qy, qz   the hub's frame (origin at its mass centre, principal axes) in the
//                             world; v: its velocity in world axes, its angular velocity in its axes
//   hinge1 .. hinge6          the relative angles of the links, 0 when straight
// Parameters and defaults: those of SpacecraftBoom (m_hub now enters: it sets how far the hub
// drifts).
#pragma once

#include <array>
#include <numbers>

#include <eom/model/model.hpp>
#include <eom/multibody/spatial.hpp>
#include <eom/multibody/tree.hpp>

namespace eom::models {

struct SpacecraftFree {
  static constexpr int links = 6;
  static constexpr std::array coordinates{"x",      "y",      "z",      "qw",     "qx",
                                          "qy",     "qz",     "hinge1", "hinge2", "hinge3",
                                          "hinge4", "hinge5", "hinge6"};
  static constexpr bool floating_base = true;
  static constexpr std::array parameters{"m_hub",  "Ixx_hub", "Iyy_hub", "Izz_hub",
                                         "r_root", "m_link",  "l_link",  "r_link",
                                         "k_hinge", "c_hinge"};
  static constexpr std::array parameter_values{500.0, 300.0, 350.0, 400.0, 0.8,
                                               1.0,   1.0,   0.05,  2.0,   8.0};
  static constexpr int link_count = 1 + links;
  static constexpr int body_count = link_count;

  // The stowed start: the hub at the origin, unturned; the boom folded as in SpacecraftBoom.
  static constexpr std::array<double, 13> initial_q = [] {
    constexpr double deg = std::numbers::pi / 180.0;
    std::array<double, 13> q{};
    q[3] = 1.0;
    q[7] = 5.0 * deg;
    for (int k = 1; k < links; ++k) q[7 + k] = (k % 2 == 1 ? 175.0 : -175.0) * deg;
    return q;
  }();

  template <class S> static void tree(In<S> p, Out<TreeLink<S>> l) {
    const S &m_hub = p[0], &r_root = p[4], &m = p[5], &len = p[6], &r = p[7];
    const S zero(0);
    const S axial = m * r * r, transverse = m * len * len / 12.0 + 0.5 * m * r * r;
    l[0] = {.parent = -1, .coordinate = 0, .free = true, .mass = m_hub,
            .inertia = {p[1], p[2], p[3], zero, zero, zero}};
    for (int k = 0; k < links; ++k)
      l[1 + k] = {.parent = k,
                  .origin = translation<S>({k == 0 ? r_root : len, zero, zero}),
                  .coordinate = 7 + k,
                  .axis = k % 2 == 0 ? std::array<double, 3>{0, 0, 1} : std::array<double, 3>{0, 1, 0},
                  .mass = m,
                  .inertia = {axial, transverse, transverse, zero, zero, zero},
                  .inertial = translation<S>({0.5 * len, zero, zero})};
  }
  template <class S> static void bodies(In<S> q, In<S> p, Out<SpatialBody<S>> b) {
    std::array<TreeLink<S>, link_count> l;
    tree<S>(p, l);
    tree_bodies<S>(l, q, b);
  }

  // The hinge springs (no gravity in orbit).
  template <class S> static S potential_energy(In<S> q, In<S> p) {
    S sum(0);
    for (int k = 0; k < links; ++k) sum = sum + q[7 + k] * q[7 + k];
    return 0.5 * p[8] * sum;
  }

  // The hinge dampers on the relative rates; nothing acts on the hub from outside.
  template <class S>
  static void generalized_forces(const S&, In<S>, In<S> v, In<S>, In<S> p, Out<S> Q) {
    for (int i = 0; i < 6; ++i) Q[i] = S(0);
    for (int k = 0; k < links; ++k) Q[6 + k] = -p[9] * v[6 + k];
  }
};

}  // namespace eom::models
