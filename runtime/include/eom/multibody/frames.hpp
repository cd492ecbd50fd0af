// Task space (docs/CONTRACT.md §1 "Frames", §3 the frame kernels): where a model's frames are,
// their Jacobians and velocity-product accelerations, and the mass centre, templated on the scalar
// so that the generator traces them, eom::Reference differentiates them and tests evaluate them.
//
// Conventions (Pinocchio's LOCAL_WORLD_ALIGNED):
//   - a frame's placement: its origin in the world and its rotation (frame axes → world,
//     column-major);
//   - its Jacobian J (6 × nv, column-major): rows 0-2 the velocity of its origin, rows 3-5 its
//     angular velocity, world axes, as linear maps of v (the free joint's v, eom/model/free_joint.hpp);
//   - its bias a = J̇ v (6): the origin's classical acceleration d²x/dt² and the angular
//     acceleration at v̇ = 0, world axes: the frame accelerates by J v̇ + a;
//   - the mass centre is that of the bodies that move with q: a tree link welded to the world
//     (no joint between it and the world) is not counted; every body of the body form is.
//
// A tree-form model's frames are fixed to its links (eom::LinkFrame); their Jacobians and biases
// are then read off the tree by the geometric recursions below, O(depth) each. Frames given by a
// model's own frames() are differentiated instead (the generator symbolically, eom::Reference by
// AD), which eom::Reference also does for the tree form, as the independent check.
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "eom/model/model.hpp"
#include "eom/multibody/body_check.hpp"
#include "eom/multibody/spatial.hpp"
#include "eom/multibody/tree.hpp"

namespace eom {

namespace detail {

// A tree-form model's link_frames, validated (the model.hpp checks ensure it has frame_names).
template <class M> consteval bool link_frames_form() {
  if constexpr (!declares_link_frames<M>) {
    return false;
  } else {
    static_assert(tree_form<M>(), "eom model: `link_frames` places frames on the links of the "
                                  "tree form; a model without `tree` gives `frames()` instead");
    static_assert(requires(In<double> p, Out<LinkFrame<double>> f) {
                    { M::template link_frames<double>(p, f) } -> std::same_as<void>;
                  }, "eom model: `link_frames` has the wrong signature; expected `template <class "
                     "S> static void link_frames(eom::In<S> p, eom::Out<eom::LinkFrame<S>> f)`");
    return true;
  }
}

template <class S> Frame<S> frame_of(const Transform<S>& x) { return {x.translation, x.rotation}; }

// ω with [ω]× = Ṙ Rᵀ (world axes): ω₁ = (ṘRᵀ)₃₂, ω₂ = (ṘRᵀ)₁₃, ω₃ = (ṘRᵀ)₂₁, column-major R.
template <class S> Vec3<S> world_angular_velocity(const Rot3<S>& R, const Rot3<S>& dR) {
  auto entry = [&](int a, int b) {  // (Ṙ Rᵀ)_ab = Σ_c Ṙ_ac R_bc
    return dR[a] * R[b] + dR[a + 3] * R[b + 3] + dR[a + 6] * R[b + 6];
  };
  return {entry(2, 1), entry(0, 2), entry(1, 0)};
}

// Whether each link moves with q: it, or a link above it, has a joint.
template <class S, std::size_t N> std::array<bool, N> moving_links(const std::array<TreeLink<S>, N>& links) {
  std::array<bool, N> moves{};
  for (std::size_t i = 0; i < N; ++i)
    moves[i] = links[i].coordinate >= 0 || (links[i].parent >= 0 && moves[links[i].parent]);
  return moves;
}

// A body as seen in 3D: a planar body moves in the world's x-y plane and turns about z.
template <class S> Vec3<S> position_3d(const SpatialBody<S>& b) { return b.position; }
template <class S> Vec3<S> position_3d(const PlanarBody<S>& b) { return {b.x, b.y, S(0)}; }

}  // namespace detail

// Every frame of model M (ModelInfo<M>::nframes of them) at q.
template <class M, class S> void frame_placements(In<S> q, In<S> p, Out<Frame<S>> f) {
  if constexpr (detail::declares_frames<M>) {
    M::template frames<S>(q, p, f);
  } else if constexpr (detail::link_frames_form<M>()) {
    const auto links = tree_of<M, S>(p);
    const auto world = tree_placements(links, q);
    std::array<LinkFrame<S>, ModelInfo<M>::nframes> at;
    M::template link_frames<S>(p, at);
    for (std::size_t i = 0; i < at.size(); ++i)
      f[i] = detail::frame_of(at[i].link < 0 ? at[i].offset : world[at[i].link] * at[i].offset);
  } else {
    static_assert(detail::always_false<M>, "eom model: the model declares no frames (frame_names)");
  }
}

// Two frames held together, a loop closed (MuJoCo's connect and weld equalities, docs/CONTRACT.md
// §1 MJCF): φ = a's origin − b's (world axes), then, where φ has 6 rows, the vector part of the
// quaternion of bᵀ a taken with w ≥ 0 (sin(θ/2) times the axis, θ the angle between the frames'
// axes: zero where they agree, smooth while they are less than half a turn apart). With 3 rows the
// origins alone are held together (a ball joint).
template <class S> void frame_coincidence(const Transform<S>& a, const Transform<S>& b, Out<S> phi) {
  using std::sqrt;
  for (int i = 0; i < 3; ++i) phi[i] = a.translation[i] - b.translation[i];
  if (phi.size() == 3) return;
  auto e = [&](int i, int j) {  // (bᵀ a)_ij = Σ_k b_ki a_kj, column-major
    const Rot3<S>& A = a.rotation;
    const Rot3<S>& B = b.rotation;
    return B[3 * i] * A[3 * j] + B[3 * i + 1] * A[3 * j + 1] + B[3 * i + 2] * A[3 * j + 2];
  };
  // w = ½ √(1 + tr E); the vector part is (E₃₂ − E₂₃, E₁₃ − E₃₁, E₂₁ − E₁₂) / (4w)
  const S twice_w = sqrt(S(1) + e(0, 0) + e(1, 1) + e(2, 2));
  phi[3] = (e(2, 1) - e(1, 2)) / (S(2) * twice_w);
  phi[4] = (e(0, 2) - e(2, 0)) / (S(2) * twice_w);
  phi[5] = (e(1, 0) - e(0, 1)) / (S(2) * twice_w);
}

// The frame's placement in the world.
template <class S, std::size_t N>
Transform<S> tree_frame_placement(const std::array<TreeLink<S>, N>& links, const LinkFrame<S>& frame,
                                  In<S> q) {
  if (frame.link < 0) return frame.offset;
  return tree_placements(links, q)[frame.link] * frame.offset;
}

// J (6 × nv, column-major, nv = J.size() / 6) of a frame on the tree, column by column from the
// joints between it and the world: a revolute joint turning about the world axis z through its
// link's origin o moves the frame's origin x by z × (x − o) and turns it by z; a prismatic joint
// moves it by z; a free joint by its world velocity (its first three columns) and its link-axes
// angular velocity (the next three, the link's axes zₖ through its origin); a ball joint by the
// latter alone.
// This one takes the links' placements already made (tree_placements(links, q)), for callers
// that need many frames' Jacobians at one q; x is the frame origin's world position.
template <class S, std::size_t N>
void tree_frame_jacobian(const std::array<TreeLink<S>, N>& links,
                         const std::array<Transform<S>, N>& world, int link, const Vec3<S>& x,
                         In<S> q, Out<S> J) {
  using detail::cross;
  for (S& y : J) y = S(0);
  auto column = [&](std::size_t j, const Vec3<S>& linear, const Vec3<S>& angular) {
    for (int k = 0; k < 3; ++k) {  // sums: mimic joints add to their leader's column
      J[k + 6 * j] = J[k + 6 * j] + linear[k];
      J[3 + k + 6 * j] = J[3 + k + 6 * j] + angular[k];
    }
  };
  const std::array<int, N> velocity = detail::velocity_offsets(links);
  for (int i = link; i >= 0; i = links[i].parent) {
    const TreeLink<S>& l = links[i];
    const Rot3<S>& R = world[i].rotation;
    const Vec3<S>& o = world[i].translation;
    const Vec3<S> r{x[0] - o[0], x[1] - o[1], x[2] - o[2]};
    const std::size_t j = static_cast<std::size_t>(velocity[i]);
    if (detail::moves_free(l, q) || detail::moves_ball(l, q)) {
      const std::size_t turn = l.free ? j + 3 : j;  // the angular velocity's first column
      for (int k = 0; k < 3; ++k) {
        const Vec3<S> e{k == 0 ? S(1) : S(0), k == 1 ? S(1) : S(0), k == 2 ? S(1) : S(0)};
        const Vec3<S> z{R[3 * k], R[3 * k + 1], R[3 * k + 2]};
        if (l.free) column(j + k, e, {S(0), S(0), S(0)});
        column(turn + k, cross(z, r), z);
      }
    } else if (l.coordinate >= 0) {
      const auto u = detail::joint_axis(l);
      const Vec3<S> z = rotate(R, Vec3<S>{S(u[0]), S(u[1]), S(u[2])});
      if (l.prismatic)
        column(j, z, {S(0), S(0), S(0)});
      else
        column(j, cross(z, r), z);
    }
  }
}
template <class S, std::size_t N>
void tree_frame_jacobian(const std::array<TreeLink<S>, N>& links, const LinkFrame<S>& frame, In<S> q,
                         Out<S> J) {
  if (frame.link < 0) {  // fixed to the world
    for (S& y : J) y = S(0);
    return;
  }
  const auto world = tree_placements(links, q);
  tree_frame_jacobian(links, world, frame.link, (world[frame.link] * frame.offset).translation, q, J);
}

// a = J̇ v (6) of a frame on the tree: the outward Newton–Euler step at v̇ = 0 from the root to
// its link (eom/multibody/tree.hpp's link_motion, link axes), then the classical acceleration of the
// frame's origin c on that link, a_c = a + ω̇ × c + ω × (ω × c), and ω̇, turned into world axes.
template <class S, std::size_t N>
void tree_frame_bias(const std::array<TreeLink<S>, N>& links, const LinkFrame<S>& frame, In<S> q,
                     In<S> v, Out<S> a) {
  using detail::cross, detail::plus;
  for (S& x : a) x = S(0);
  if (frame.link < 0) return;
  const detail::LinkFrames<S, N> X(links, q);
  std::array<int, N> chain;  // root first
  std::size_t depth = 0;
  for (int i = frame.link; i >= 0; i = links[i].parent) chain[depth++] = i;
  std::array<S, 6 * N> at_rest;  // v̇ = 0 (at most six velocities a link)
  if (v.size() > at_rest.size())
    throw std::invalid_argument("eom::tree_frame_bias: more velocities than the tree's joints move");
  at_rest.fill(S(0));
  detail::LinkMotion<S> m;
  for (std::size_t k = depth; k-- > 0;)
    m = detail::link_motion(X, chain[k], k + 1 < depth ? &m : nullptr, v, In<S>(at_rest.data(), v.size()));
  const Vec3<S>& c = frame.offset.translation;
  const Vec3<S> a_c = plus(m.a, plus(cross(m.dw, c), cross(m.w, cross(m.w, c))));
  const Rot3<S> R = tree_placements(links, q)[frame.link].rotation;
  const Vec3<S> linear = rotate(R, a_c), angular = rotate(R, m.dw);
  for (int k = 0; k < 3; ++k) {
    a[k] = linear[k];
    a[3 + k] = angular[k];
  }
}

// The mass centre (world) of the bodies that move with q: Σ mᵢ xᵢ / Σ mᵢ.
template <class M, class S> Vec3<S> center_of_mass(In<S> q, In<S> p) {
  static_assert(detail::declares_bodies<M>,
                "eom: the mass centre needs the body form (bodies) or the tree form; a model that "
                "states T itself has no bodies to weigh");
  std::array<BodyOf<M, S>, M::body_count> b;
  M::template bodies<S>(q, p, b);
  std::array<bool, M::body_count> moves;
  moves.fill(true);
  if constexpr (detail::tree_form<M>()) {  // bodies past the tree's (an MJCF model's massless
                                           // armature rotors) weigh nothing either way
    const auto links = detail::moving_links(tree_of<M, S>(p));
    for (std::size_t i = 0; i < links.size(); ++i) moves[i] = links[i];
  }
  S mass(0);
  Vec3<S> moment{S(0), S(0), S(0)};
  for (std::size_t i = 0; i < b.size(); ++i) {
    if (!moves[i]) continue;
    const Vec3<S> x = detail::position_3d(b[i]);
    mass = mass + b[i].mass;
    for (int k = 0; k < 3; ++k) moment[k] = moment[k] + b[i].mass * x[k];
  }
  return {moment[0] / mass, moment[1] / mass, moment[2] / mass};
}

// The centroidal momentum (6): the bodies' linear momentum Σ mᵢ ẋᵢ, then their angular momentum
// about the mass centre G, Σ (xᵢ − G) × mᵢ ẋᵢ + Rᵢ Jᵢ ωᵢ, world axes; linear in v, so that
// centroidal_momentum_matrix is its derivative over v. (A welded body is at rest: it adds 0.)
template <class M, class S> std::array<S, 6> centroidal_momentum(In<S> q, In<S> v, In<S> p) {
  using detail::cross;
  const Vec3<S> G = center_of_mass<M, S>(q, p);
  const auto b = bodies_along<M, S>(q, v, p);
  std::array<S, 6> h;
  h.fill(S(0));
  for (const auto& body : b) {
    Vec3<S> x, xd, spin;  // position, velocity, R J ω
    const S& m = body.mass.v;
    if constexpr (std::is_same_v<std::remove_cvref_t<decltype(body)>, SpatialBody<Embedded<1, S, 1>>>) {
      Rot3<S> R;
      for (int k = 0; k < 9; ++k) R[k] = body.rotation[k].v;
      for (int k = 0; k < 3; ++k) {
        x[k] = body.position[k].v;
        xd[k] = body.position[k].g[0];
      }
      const Vec3<S> w = detail::angular_velocity<S>(body.rotation);
      std::array<S, 6> J;
      for (int k = 0; k < 6; ++k) J[k] = body.inertia[k].v;
      spin = rotate(R, detail::inertia_times(J, w));
    } else {
      x = {body.x.v, body.y.v, S(0)};
      xd = {body.x.g[0], body.y.g[0], S(0)};
      spin = {S(0), S(0), body.inertia.v * body.angle.g[0]};
    }
    const Vec3<S> r{x[0] - G[0], x[1] - G[1], x[2] - G[2]};
    const Vec3<S> P{m * xd[0], m * xd[1], m * xd[2]};
    const Vec3<S> L = cross(r, P);
    for (int k = 0; k < 3; ++k) {
      h[k] = h[k] + P[k];
      h[3 + k] = h[3 + k] + L[k] + spin[k];
    }
  }
  return h;
}

// The first problem with a model's frames at (q, p): "frame '<name>': <problem>", or "".
template <class M> std::string frame_problem(std::span<const double> q, std::span<const double> p) {
  constexpr int n = ModelInfo<M>::nframes;
  if constexpr (n > 0) {
    std::vector<Frame<double>> f(n);
    frame_placements<M, double>(q, p, f);
    for (int i = 0; i < n; ++i) {
      const auto& x = f[i].position;
      std::string problem;
      if (!detail::all_finite({x[0], x[1], x[2]})) problem = "its position is not finite (NaN or Inf)";
      else if (!detail::all_finite({f[i].rotation[0], f[i].rotation[1], f[i].rotation[2],
                                    f[i].rotation[3], f[i].rotation[4], f[i].rotation[5],
                                    f[i].rotation[6], f[i].rotation[7], f[i].rotation[8]}))
        problem = "its rotation is not finite (NaN or Inf)";
      else
        problem = rotation_problem(f[i].rotation, "frame-to-world");
      if (!problem.empty())
        return "frame '" + std::string(ModelInfo<M>::frame_names[i]) + "': " + problem;
    }
  }
  return "";
}

}  // namespace eom
