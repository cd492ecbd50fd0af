// A tree-form model whose bodies are not its tree's: the pendulum's tree carries its mass at
// 0.5 m, the bodies at 0.25 m. The generator must refuse it instead of writing two robots' kernels.
#pragma once

#include <array>

#include <eom/multibody/tree.hpp>

struct TreeMismatch {
  static constexpr std::array coordinates{"theta"};
  static constexpr std::array parameters{"m"};
  static constexpr std::array parameter_values{1.5};
  static constexpr int link_count = 1;
  static constexpr int body_count = 1;

  template <class S> static void tree(eom::In<S> p, eom::Out<eom::TreeLink<S>> l) {
    l[0] = {.coordinate = 0, .axis = {0.0, 1.0, 0.0}, .mass = p[0], .inertia = {0.1, 0.1, 0.1},
            .inertial = eom::translation<S>({S(0), S(0), S(-0.5)})};
  }
  template <class S> static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {
    std::array<eom::TreeLink<S>, 1> l;
    tree<S>(p, l);
    l[0].inertial = eom::translation<S>({S(0), S(0), S(-0.25)});
    eom::tree_bodies<S>(l, q, b);
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    std::array<eom::SpatialBody<S>, 1> b;
    bodies<S>(q, p, b);
    return eom::gravity_potential<S>(b, S(9.81));
  }
};
