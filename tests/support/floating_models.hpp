// Models with a free joint (eom/model/free_joint.hpp), shared by the tests:
//
//   FreeBody    one asymmetric rigid body, body form: its mass centre off the root frame's
//               origin, a full inertia tensor in rotated inertial axes, gravity g (0 by default:
//               torque-free motion)
//   FreeBodyTree  the same body in the tree form (one free link): the generator can take the
//               articulated-body algorithm for it
//   FreeTree    a free base carrying a revolute-revolute arm and a prismatic branch, tree form
//               (eom/multibody/tree.hpp), written as eomgen-urdf writes robots
#pragma once

#include <array>

#include <eom/model/model.hpp>
#include <eom/multibody/spatial.hpp>
#include <eom/multibody/tree.hpp>

namespace floating_test {

struct FreeBody {
  static constexpr std::array coordinates{"x", "y", "z", "qw", "qx", "qy", "qz"};
  static constexpr bool floating_base = true;
  static constexpr std::array parameters{"m", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz",
                                         "cx", "cy", "cz", "g"};
  static constexpr std::array parameter_values{2.0, 0.3, 0.5, 0.7, 0.02, -0.01, 0.03,
                                               0.1, -0.05, 0.2, 0.0};
  static constexpr int body_count = 1;

  template <class S> static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {
    const eom::Transform<S> frame{eom::quaternion(q[3], q[4], q[5], q[6]), {q[0], q[1], q[2]}};
    const eom::Transform<S> inertial{eom::constant_rpy<S>({0.3, -0.2, 0.5}), {p[7], p[8], p[9]}};
    b[0] = eom::rigid_body<S>(frame, p[0], {p[1], p[2], p[3], p[4], p[5], p[6]}, inertial);
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    std::array<eom::SpatialBody<S>, body_count> b;
    bodies<S>(q, p, b);
    return eom::gravity_potential<S>(b, p[10]);
  }
};

struct FreeBodyTree {
  static constexpr std::array coordinates = FreeBody::coordinates;
  static constexpr bool floating_base = true;
  static constexpr std::array parameters = FreeBody::parameters;
  static constexpr std::array parameter_values = FreeBody::parameter_values;
  static constexpr int link_count = 1;
  static constexpr int body_count = 1;

  template <class S> static void tree(eom::In<S> p, eom::Out<eom::TreeLink<S>> l) {
    l[0] = {.parent = -1, .coordinate = 0, .free = true, .mass = p[0],
            .inertia = {p[1], p[2], p[3], p[4], p[5], p[6]},
            .inertial = {eom::constant_rpy<S>({0.3, -0.2, 0.5}), {p[7], p[8], p[9]}}};
  }
  template <class S> static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {
    std::array<eom::TreeLink<S>, link_count> l;
    tree<S>(p, l);
    eom::tree_bodies<S>(l, q, b);
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    return FreeBody::potential_energy<S>(q, p);
  }
};

struct FreeTree {
  static constexpr std::array coordinates{"x", "y", "z", "qw", "qx", "qy", "qz",
                                          "shoulder", "elbow", "slide"};
  static constexpr bool floating_base = true;
  static constexpr std::array inputs{"u_shoulder", "u_elbow", "u_slide"};
  static constexpr std::array parameters{"g", "base_mass", "arm_mass", "forearm_mass",
                                         "slider_mass", "elbow_damping"};
  static constexpr std::array parameter_values{9.81, 4.0, 1.2, 0.8, 0.5, 0.1};
  static constexpr int link_count = 4;
  static constexpr int body_count = link_count;

  template <class S> static void tree(eom::In<S> p, eom::Out<eom::TreeLink<S>> l) {
    using eom::origin;
    l[0] = {.parent = -1, .coordinate = 0, .free = true, .mass = p[1],
            .inertia = {S(0.10), S(0.15), S(0.12), S(0.01), S(-0.005), S(0.002)},
            .inertial = {eom::constant_rpy<S>({0.1, 0.2, -0.1}), {S(0.02), S(-0.01), S(0.03)}}};
    l[1] = {.parent = 0, .origin = origin<S>({0.1, 0.0, 0.2}, {0.0, 0.3, 0.0}), .coordinate = 7,
            .axis = {0.0, 1.0, 0.0}, .mass = p[2],
            .inertia = {S(0.02), S(0.03), S(0.01), S(0.0), S(0.001), S(0.0)},
            .inertial = eom::translation<S>({S(0.0), S(0.0), S(0.15)})};
    l[2] = {.parent = 1, .origin = origin<S>({0.0, 0.0, 0.3}, {0.2, 0.0, 0.1}), .coordinate = 8,
            .axis = {0.3, 1.0, 0.2}, .mass = p[3],
            .inertia = {S(0.01), S(0.012), S(0.008), S(0.001), S(0.0), S(-0.001)},
            .inertial = eom::translation<S>({S(0.05), S(0.0), S(0.1)})};
    l[3] = {.parent = 0, .origin = origin<S>({-0.1, 0.05, 0.0}, {0.0, 0.0, 0.4}), .coordinate = 9,
            .prismatic = true, .axis = {1.0, 0.0, 0.0}, .mass = p[4],
            .inertia = {S(0.004), S(0.005), S(0.006), S(0.0), S(0.0), S(0.0)},
            .inertial = eom::translation<S>({S(0.02), S(0.01), S(0.0)})};
  }
  template <class S> static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {
    std::array<eom::TreeLink<S>, link_count> l;
    tree<S>(p, l);
    eom::tree_bodies<S>(l, q, b);
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    std::array<eom::SpatialBody<S>, body_count> b;
    bodies<S>(q, p, b);
    return eom::gravity_potential<S>(b, p[0]);
  }
  template <class S>
  static void generalized_forces(const S&, eom::In<S>, eom::In<S> v, eom::In<S> u, eom::In<S> p,
                                 eom::Out<S> Q) {
    for (int i = 0; i < 6; ++i) Q[i] = S(0);
    Q[6] = u[0];
    Q[7] = u[1] - p[5] * v[7];
    Q[8] = u[2];
  }
};

// A top on a ball joint: one rigid body turning about a fixed pivot, hung from a world link by a
// ball joint whose quaternion sits after a slide (q = [lift, qw, qx, qy, qz]: a quaternion that
// is not the first coordinate), with a hinged flap below it so that the tree has a joint after
// the quaternion too. Euler's equations about the pivot give its motion in closed form when the
// slide is held and the flap weighs nothing.
struct BallTop {
  static constexpr std::array coordinates{"lift", "qw", "qx", "qy", "qz", "flap"};
  static constexpr std::array quaternions{1};
  static constexpr std::array parameters{"g", "flap_mass"};
  static constexpr std::array parameter_values{9.81, 0.3};
  static constexpr int link_count = 3;
  static constexpr int body_count = link_count;
  static constexpr double mass = 2.0;
  static constexpr std::array<double, 6> inertia{0.04, 0.05, 0.03, 0.004, -0.002, 0.003};
  static constexpr std::array<double, 3> centre{0.05, -0.02, 0.3};  // from the pivot, body axes

  template <class S> static void tree(eom::In<S> p, eom::Out<eom::TreeLink<S>> l) {
    using eom::origin;
    l[0] = {.parent = -1, .origin = origin<S>({0.1, 0.2, 1.0}, {0.1, 0.0, 0.0}), .coordinate = 0,
            .prismatic = true, .axis = {0.0, 0.0, 1.0}, .mass = S(1.0),
            .inertia = {S(0.01), S(0.01), S(0.01), S(0.0), S(0.0), S(0.0)}};
    l[1] = {.parent = 0, .origin = origin<S>({0.0, 0.0, 0.1}, {0.0, 0.2, 0.0}), .coordinate = 1,
            .ball = true, .mass = S(mass),
            .inertia = {S(inertia[0]), S(inertia[1]), S(inertia[2]), S(inertia[3]), S(inertia[4]),
                        S(inertia[5])},
            .inertial = eom::translation<S>({S(centre[0]), S(centre[1]), S(centre[2])})};
    l[2] = {.parent = 1, .origin = origin<S>({0.0, 0.1, 0.4}, {0.0, 0.0, 0.3}), .coordinate = 5,
            .axis = {1.0, 0.0, 0.2}, .mass = p[1],  // and its inertia scales with it
            .inertia = {p[1] * 0.007, p[1] * 0.01, p[1] * 0.003, S(0.0), S(0.0), S(0.0)},
            .inertial = eom::translation<S>({S(0.0), S(0.05), S(0.0)})};
  }
  template <class S> static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {
    std::array<eom::TreeLink<S>, link_count> l;
    tree<S>(p, l);
    eom::tree_bodies<S>(l, q, b);
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    std::array<eom::SpatialBody<S>, body_count> b;
    bodies<S>(q, p, b);
    return eom::gravity_potential<S>(b, p[0]);
  }
};

}  // namespace floating_test
