// Models with frames (eom/multibody/frames.hpp), shared by the task-space tests:
//
//   FrameArm         a three-joint spatial arm in the body form whose frames() places a tool and
//                    an elbow marker (the generic path: the generator differentiates placements)
//   FreeBodyFrames   the free asymmetric body (floating_models.hpp) with a marker given by frames():
//                    the generic path on the free joint's tangent space
//   FreeTreeFrames   the floating tree (floating_models.hpp) with frames on its links
//                    (link_frames: the tree's recursions), one on the world
//   SkewedFrame      a frames() whose rotation is not orthonormal (refused at generation)
#pragma once

#include <array>

#include <eom/model/model.hpp>
#include <eom/multibody/spatial.hpp>
#include <eom/multibody/tree.hpp>

#include "floating_models.hpp"

namespace frames_test {

struct FrameArm {
  static constexpr std::array coordinates{"yaw", "shoulder", "elbow"};
  static constexpr std::array parameters{"l1", "l2", "m1", "m2", "g"};
  static constexpr std::array parameter_values{0.6, 0.45, 2.0, 1.3, 9.81};
  static constexpr int body_count = 2;
  static constexpr std::array frame_names{"tool", "elbow_marker"};

  // The upper arm turns about z (yaw) then y (shoulder); the forearm about its own y (elbow).
  template <class S> static eom::Transform<S> upper(eom::In<S> q) {
    return eom::Transform<S>{eom::rot_z(q[0]), {S(0), S(0), S(0.2)}} * eom::rotation<S>(eom::rot_y(q[1]));
  }
  template <class S> static eom::Transform<S> fore(eom::In<S> q, eom::In<S> p) {
    return upper<S>(q) * eom::translation<S>({p[0], S(0), S(0)}) * eom::rotation<S>(eom::rot_y(q[2]));
  }
  template <class S> static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {
    const eom::Transform<S> c1 = eom::translation<S>({0.5 * p[0], S(0.01), S(0)});
    const eom::Transform<S> c2{eom::constant_rpy<S>({0.1, 0.2, 0.3}), {0.5 * p[1], S(0), S(-0.02)}};
    b[0] = eom::rigid_body<S>(upper<S>(q), p[2], {S(0.01), S(0.06), S(0.06), S(0), S(0.001), S(0)}, c1);
    b[1] = eom::rigid_body<S>(fore<S>(q, p), p[3], {S(0.008), S(0.03), S(0.031), S(0.0005), S(0), S(0)}, c2);
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    std::array<eom::SpatialBody<S>, body_count> b;
    bodies<S>(q, p, b);
    return eom::gravity_potential<S>(b, p[4]);
  }
  template <class S> static void frames(eom::In<S> q, eom::In<S> p, eom::Out<eom::Frame<S>> f) {
    const eom::Transform<S> tool = fore<S>(q, p) * eom::origin<S>({0.45, 0.0, 0.03}, {0.0, 1.5707963267948966, 0.2});
    const eom::Transform<S> elbow = upper<S>(q) * eom::translation<S>({p[0], S(0.05), S(0)});
    f[0] = {tool.translation, tool.rotation};
    f[1] = {elbow.translation, elbow.rotation};
  }
};

struct FreeBodyFrames : floating_test::FreeBody {
  static constexpr std::array frame_names{"marker"};
  template <class S> static void frames(eom::In<S> q, eom::In<S>, eom::Out<eom::Frame<S>> f) {
    const eom::Transform<S> body{eom::quaternion(q[3], q[4], q[5], q[6]), {q[0], q[1], q[2]}};
    const eom::Transform<S> marker = body * eom::origin<S>({0.3, -0.1, 0.2}, {0.4, 0.0, -0.3});
    f[0] = {marker.translation, marker.rotation};
  }
};

struct FreeTreeFrames : floating_test::FreeTree {
  static constexpr std::array frame_names{"base", "tool", "slider_tip", "world_mark"};
  template <class S> static void link_frames(eom::In<S>, eom::Out<eom::LinkFrame<S>> f) {
    f[0] = {.link = 0};
    f[1] = {.link = 2, .offset = eom::origin<S>({0.05, -0.02, 0.25}, {0.3, 0.1, -0.2})};
    f[2] = {.link = 3, .offset = eom::translation<S>({S(0.1), S(0), S(0)})};
    f[3] = {.link = -1, .offset = eom::origin<S>({1.0, 2.0, 0.0}, {0.0, 0.0, 0.5})};
  }
};

struct SkewedFrame : FrameArm {
  static constexpr std::array frame_names{"skewed"};
  template <class S> static void frames(eom::In<S> q, eom::In<S> p, eom::Out<eom::Frame<S>> f) {
    const eom::Transform<S> x = fore<S>(q, p);
    f[0] = {x.translation, x.rotation};
    f[0].rotation[0] = 1.01 * f[0].rotation[0];
  }
};

}  // namespace frames_test
