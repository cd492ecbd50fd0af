// The tree form of a spatial body-form model: the robot as a kinematic tree of links, each hanging
// from its parent by one joint, as URDF describes it. A model that states its tree
//   static constexpr int link_count = N;
//   template <class S> static void tree(eom::In<S> p, eom::Out<eom::TreeLink<S>> links);
// writes its bodies from it (`bodies` = eom::tree_bodies of the tree), so the two never disagree,
// and the generator can then also trace the recursive Newton–Euler algorithm (below) through its
// tape: the inverse dynamics in O(N) operations instead of through M (docs/CONTRACT.md §1).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "eom/model/model.hpp"
#include "eom/multibody/spatial.hpp"

namespace eom {

// One link and the joint that carries it. Its frame in its parent's frame is
// origin · motion(q[coordinate]): a rotation by q about `axis` (revolute), a translation by q
// along it (prismatic), or nothing (a fixed joint, coordinate −1). A ball joint turns it by the
// unit quaternion q[coordinate..coordinate+4) (w x y z; child axes → joint frame) at the
// angular velocity ω of three velocities, in the link's axes. A free link (parent −1, the root of
// a model with `floating_base` at coordinate 0, eom/model/free_joint.hpp) is placed by
// q[coordinate..coordinate+7) itself: its frame is (x, y, z) and quaternion(qw, qx, qy, qz) in
// the world; its origin stays the identity. Its six velocities are the origin's in world axes,
// then ω in the link's axes. A joint's velocity is v[coordinate − the quaternions before it]
// (each free or ball joint's takes one velocity fewer than its coordinates; velocity_offsets).
// A mimic joint (URDF's <mimic>) has no coordinate of its own: it turns (or slides) by
// multiplier · q[coordinate] + offset, its leader's coordinate, at multiplier times its rate; a
// coordinate may then move several links. The articulated-body algorithm (tree_forward_dynamics)
// refuses such a tree; the others take it.
// A joint's armature (MuJoCo's rotor inertia, reflected through its gearing) adds
// armature · multiplier² to M's diagonal entry of its coordinate and nothing else: a rotor turned
// by the joint alone, not by the links above it.
template <class S> struct TreeLink {
  int parent = -1;         // the parent link, listed before this one; −1: a root (world-fixed)
  Transform<S> origin{};   // the joint frame in the parent link's frame (URDF's <joint><origin>)
  int coordinate = -1;     // the generalized coordinate that moves the joint; −1: fixed
  double multiplier = 1.0; // a mimic joint's: joint position = multiplier · q[coordinate] + offset
  double offset = 0.0;
  bool free = false;       // a free joint: parent −1, seven coordinates, six velocities
  bool ball = false;       // a ball joint: four coordinates (a unit quaternion), three velocities
  bool prismatic = false;  // the joint slides along `axis` (else it turns about it)
  std::array<double, 3> axis{0.0, 0.0, 1.0};  // in the joint frame; any non-zero length
  double armature = 0.0;   // rotor inertia on the joint's rate (kg m² or kg); ≥ 0
  S mass{};                     // 0: a massless link
  std::array<S, 6> inertia{};   // about the mass centre, inertial axes: Ixx, Iyy, Izz, Ixy, Ixz, Iyz
  Transform<S> inertial{};      // mass centre and inertial axes in the link frame (<inertial><origin>)
};

// A frame fixed to a link of the tree (docs/CONTRACT.md §1, frames): the link's frame · offset.
// A tree-form model places its frames by
//   static constexpr std::array frame_names{"tool", ...};
//   template <class S> static void link_frames(eom::In<S> p, eom::Out<eom::LinkFrame<S>> f);
// so that the generator reads its Jacobians off the tree (eom/multibody/frames.hpp).
template <class S> struct LinkFrame {
  int link = -1;            // the link it is fixed to; −1: the world
  Transform<S> offset{};    // the frame in the link's frame
};

namespace detail {

template <class S> Vec3<S> cross(const Vec3<S>& a, const Vec3<S>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
template <class S> Vec3<S> plus(const Vec3<S>& a, const Vec3<S>& b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
template <class S> Vec3<S> minus(const Vec3<S>& a, const Vec3<S>& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
template <class S> Vec3<S> scaled(const std::array<double, 3>& a, const S& s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
template <class S> S dot(const std::array<double, 3>& a, const Vec3<S>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
// Rᵀ v: a parent-frame vector in the child's axes, when R turns child into parent axes.
template <class S> Vec3<S> rotate_back(const Rot3<S>& r, const Vec3<S>& v) {
  return {r[0] * v[0] + r[1] * v[1] + r[2] * v[2], r[3] * v[0] + r[4] * v[1] + r[5] * v[2],
          r[6] * v[0] + r[7] * v[1] + r[8] * v[2]};
}
// J w for the symmetric J = (Jxx, Jyy, Jzz, Jxy, Jxz, Jyz).
template <class S> Vec3<S> inertia_times(const std::array<S, 6>& J, const Vec3<S>& w) {
  return {J[0] * w[0] + J[3] * w[1] + J[4] * w[2], J[3] * w[0] + J[1] * w[1] + J[5] * w[2],
          J[4] * w[0] + J[5] * w[1] + J[2] * w[2]};
}
// R J Rᵀ of a symmetric J: e.g. an inertia given in axes R (relative to the link) in the link's.
template <class S> std::array<S, 6> rotated_inertia(const Rot3<S>& r, const std::array<S, 6>& J) {
  const Rot3<S> rj = multiply(r, Rot3<S>{J[0], J[3], J[4], J[3], J[1], J[5], J[4], J[5], J[2]});
  auto entry = [&](int i, int j) {  // (R J Rᵀ)ᵢⱼ = Σₖ (RJ)ᵢₖ Rⱼₖ
    return rj[i] * r[j] + rj[i + 3] * r[j + 3] + rj[i + 6] * r[j + 6];
  };
  return {entry(0, 0), entry(1, 1), entry(2, 2), entry(0, 1), entry(0, 2), entry(1, 2)};
}

// A 6×6 symmetric spatial inertia about a frame's origin, in its axes: the force (moment about
// the origin n, force f) it gives a motion (ω, v of the origin) is n = I ω + H v, f = Hᵀ ω + M v.
// A rigid body's: I = J + m (cᵀc 1 − c cᵀ), H = m [c]×, M = m 1 (J about the mass centre c).
template <class S> struct SpatialInertia {
  std::array<S, 6> I, M;  // symmetric: xx, yy, zz, xy, xz, yz
  Rot3<S> H;              // column-major
};
template <class S> S sym(const std::array<S, 6>& A, int i, int j) {
  static constexpr int at[3][3] = {{0, 3, 4}, {3, 1, 5}, {4, 5, 2}};
  return A[at[i][j]];
}
template <class S> std::array<S, 6> sym_of(auto&& entry) {  // from a symmetric entry(i, j)
  return {entry(0, 0), entry(1, 1), entry(2, 2), entry(0, 1), entry(0, 2), entry(1, 2)};
}
// R A Rᵀ of a general A.
template <class S> Rot3<S> rotated_mat(const Rot3<S>& r, const Rot3<S>& A) {
  return multiply(multiply(r, A), transpose(r));
}
// [x]× as a matrix.
template <class S> Rot3<S> skew(const Vec3<S>& x) {
  return {S(0), x[2], -x[1], -x[2], S(0), x[0], x[1], -x[0], S(0)};
}
// A rigid body's (or a rigid composite's) spatial inertia by what it holds: I about the origin,
// the mass m and its first moment h = m c. The composite-rigid-body algorithm sums these: kept
// so, M = m 1 and H = [h]× stay exact under rotation, where rotating them as general matrices
// recomputes m as m (cos² + sin²) and 0 as m (cos sin − sin cos).
template <class S> struct RigidInertia {
  std::array<S, 6> I;
  S m;
  Vec3<S> h;
};
template <class S> RigidInertia<S> rigid_inertia(const TreeLink<S>& l) {
  const Vec3<S>& c = l.inertial.translation;
  const std::array<S, 6> J = rotated_inertia(l.inertial.rotation, l.inertia);
  const S& m = l.mass;
  const Vec3<S> h{m * c[0], m * c[1], m * c[2]};
  const S hc = h[0] * c[0] + h[1] * c[1] + h[2] * c[2];
  auto I = [&](int i, int j) { return (i == j ? J[i] + hc : sym(J, i, j)) - h[i] * c[j]; };
  return {sym_of<S>(I), m, h};
}
template <class S> SpatialInertia<S> body_inertia(const TreeLink<S>& l) {
  const RigidInertia<S> a = rigid_inertia(l);
  return {a.I, {a.m, a.m, a.m, S(0), S(0), S(0)}, skew(a.h)};
}
// The rigid inertia a (axes R, origin r in the parent's frame) about the parent's origin in its
// axes: h' = R h + m r, I' = R I Rᵀ − [r]×[Rh]× − [Rh]×[r]× − m [r]×² (in_parent's, with M = m 1).
template <class S>
RigidInertia<S> in_parent(const Rot3<S>& r_rot, const Vec3<S>& r, const RigidInertia<S>& a) {
  const std::array<S, 6> I = rotated_inertia(r_rot, a.I);
  const Vec3<S> h = rotate(r_rot, a.h), mr{a.m * r[0], a.m * r[1], a.m * r[2]};
  // [a]×[b]× = b aᵀ − (a·b) 1
  const S rh2 = 2.0 * (r[0] * h[0] + r[1] * h[1] + r[2] * h[2]);
  const S mrr = mr[0] * r[0] + mr[1] * r[1] + mr[2] * r[2];
  auto entry = [&](int i, int j) {
    const S shift = h[i] * r[j] + r[i] * h[j] + mr[i] * r[j];
    return i == j ? sym(I, i, j) + (rh2 + mrr) - shift : sym(I, i, j) - shift;
  };
  return {sym_of<S>(entry), a.m, plus(h, mr)};
}
// The inertia of a link (axes R, origin r in the parent's frame) about the parent's origin in
// its axes: rotated, then shifted by r: I' = I − H[r]× + [r]×Hᵀ − [r]×M[r]×, H' = H + [r]×M.
template <class S>
SpatialInertia<S> in_parent(const Rot3<S>& r_rot, const Vec3<S>& r, const SpatialInertia<S>& a) {
  const std::array<S, 6> I = rotated_inertia(r_rot, a.I), M = rotated_inertia(r_rot, a.M);
  const Rot3<S> H = rotated_mat(r_rot, a.H), X = skew(r);
  const Rot3<S> full_M{sym(M, 0, 0), sym(M, 1, 0), sym(M, 2, 0), sym(M, 0, 1), sym(M, 1, 1),
                       sym(M, 2, 1), sym(M, 0, 2), sym(M, 1, 2), sym(M, 2, 2)};
  const Rot3<S> XM = multiply(X, full_M), XHt = multiply(X, transpose(H)), XMX = multiply(XM, X);
  auto entry = [&](int i, int j) {  // I − H[r]× + [r]×Hᵀ − [r]×M[r]× = I + XHᵀ + (XHᵀ)ᵀ − XMX
    return sym(I, i, j) + XHt[i + 3 * j] + XHt[j + 3 * i] - XMX[i + 3 * j];
  };
  Rot3<S> H2;
  for (int k = 0; k < 9; ++k) H2[k] = H[k] + XM[k];
  return {sym_of<S>(entry), M, H2};
}

// x = A⁻¹ b for a spatial inertia A acting on (linear; angular) motion, b = (force; moment) on
// entry and x on return, by an LDLᵀ factorization whose six pivots go to `pivots`: a free root's
// articulated inertia, solved for its acceleration.
template <class S>
void solve_spatial(const SpatialInertia<S>& I, std::array<S, 6>& b, Out<S> pivots) {
  auto A = [&](int r, int c) -> S {  // [[M Hᵀ] [H I]]
    if (r < 3 && c < 3) return sym(I.M, r, c);
    if (r >= 3 && c >= 3) return sym(I.I, r - 3, c - 3);
    return r >= 3 ? I.H[(r - 3) + 3 * c] : I.H[(c - 3) + 3 * r];
  };
  std::array<S, 36> W, L;  // W = L D, column by column
  std::array<S, 6> D_inv;
  for (int j = 0; j < 6; ++j) {
    for (int i = j; i < 6; ++i) {
      S x = A(i, j);
      for (int k = 0; k < j; ++k) x = x - W[i + 6 * k] * L[j + 6 * k];
      W[i + 6 * j] = x;
    }
    pivots[j] = W[j + 6 * j];
    D_inv[j] = S(1) / pivots[j];
    for (int i = j + 1; i < 6; ++i) L[i + 6 * j] = W[i + 6 * j] * D_inv[j];
  }
  for (int i = 0; i < 6; ++i)
    for (int k = 0; k < i; ++k) b[i] = b[i] - L[i + 6 * k] * b[k];
  for (int i = 0; i < 6; ++i) b[i] = b[i] * D_inv[i];
  for (int i = 5; i >= 0; --i)
    for (int k = i + 1; k < 6; ++k) b[i] = b[i] - L[k + 6 * i] * b[k];
}

// A spatial vector as two 3-vectors in one frame: a motion (ω, v of the origin) or a force
// (moment about the origin, force); the sums, multiples and pairings the recursions below share.
template <class S> struct Pair {
  Vec3<S> a, b;
};
template <class S> Pair<S> sum(const Pair<S>& x, const Pair<S>& y) {
  return {plus(x.a, y.a), plus(x.b, y.b)};
}
template <class S> Pair<S> scale(const Pair<S>& x, const S& k) {
  return {{x.a[0] * k, x.a[1] * k, x.a[2] * k}, {x.b[0] * k, x.b[1] * k, x.b[2] * k}};
}
template <class S> S dot(const Pair<S>& x, const Pair<S>& y) {
  return x.a[0] * y.a[0] + x.a[1] * y.a[1] + x.a[2] * y.a[2] + x.b[0] * y.b[0] +
         x.b[1] * y.b[1] + x.b[2] * y.b[2];
}

// Where link l's quaternion's w is in q: a free joint's at its coordinate + 3, a ball joint's at
// its coordinate; −1: it holds none.
template <class S> int quaternion_of(const TreeLink<S>& l) {
  return l.free ? l.coordinate + 3 : l.ball ? l.coordinate : -1;
}
template <class S, std::size_t N> std::size_t quaternion_count(const std::array<TreeLink<S>, N>& links) {
  std::size_t count = 0;
  for (const TreeLink<S>& l : links) count += quaternion_of(l) >= 0 ? 1 : 0;
  return count;
}

// Where each link's velocities start in v (−1: a fixed joint): its coordinate less one for
// each quaternion before it in q (a free joint's at coordinate + 3, a ball joint's at its
// coordinate), eom/model/free_joint.hpp's Layout.
template <class S, std::size_t N>
std::array<int, N> velocity_offsets(const std::array<TreeLink<S>, N>& links) {
  std::array<int, N> quaternions{};  // where each one's w is: few, so each link counts them
  std::size_t count = 0;
  for (const TreeLink<S>& l : links)
    if (quaternion_of(l) >= 0) quaternions[count++] = quaternion_of(l);
  std::array<int, N> at;
  for (std::size_t i = 0; i < N; ++i) {
    const int c = links[i].coordinate;
    at[i] = c;
    for (std::size_t k = 0; k < count && c >= 0; ++k)
      if (quaternions[k] < c) --at[i];
  }
  return at;
}

// The number of velocities link l's joint has: 6 free, 3 ball, 1 a joint, 0 fixed.
template <class S> int joint_velocities(const TreeLink<S>& l) {
  return l.free ? 6 : l.ball ? 3 : l.coordinate >= 0 ? 1 : 0;
}

// Parents come first and coordinates name existing q: the order the recursions need. The tree's
// free and ball joints hold the model's nq − nv quaternions; a model with a floating base has
// its free joint at link 0.
template <class S, std::size_t N>
void check_tree(const std::array<TreeLink<S>, N>& links, std::size_t nq, std::size_t nv) {
  const std::size_t quaternions = quaternion_count(links);
  if (nq != nv + quaternions)
    throw std::invalid_argument(
        "eom::tree: the tree's free and ball joints hold " + std::to_string(quaternions) +
        " quaternions but the model has " + std::to_string(nq) + " coordinates and " +
        std::to_string(nv) + " velocities (floating_base and `quaternions` must list them)");
  for (std::size_t i = 0; i < N; ++i) {
    const TreeLink<S>& l = links[i];
    const std::string link = "eom::tree: link " + std::to_string(i);
    if (l.free && (l.parent != -1 || l.ball || l.prismatic))
      throw std::invalid_argument(link + " is free: its parent must be -1 (the world), and it "
                                  "cannot be a ball or prismatic joint too");
    if (l.ball && l.prismatic)
      throw std::invalid_argument(link + " is a ball joint: it cannot be prismatic too");
    if ((l.free || l.ball) && l.coordinate < 0)
      throw std::invalid_argument(link + "'s free or ball joint needs a coordinate (its first)");
    if (l.parent < -1 || l.parent >= static_cast<int>(i))
      throw std::invalid_argument(link + "'s parent " + std::to_string(l.parent) +
                                  " is not an earlier link (parents come first; -1 is the root)");
    const int width = l.free ? 7 : l.ball ? 4 : 1;
    if (l.coordinate < -1 || l.coordinate + width > static_cast<int>(nq))
      throw std::invalid_argument(link + "'s coordinate " + std::to_string(l.coordinate) +
                                  (width > 1 ? " (and the " + std::to_string(width - 1) +
                                                   " after it)" : std::string()) +
                                  " is not one of the model's " + std::to_string(nq) +
                                  " (-1: a fixed joint)");
    for (std::size_t k = 0; k < N && l.coordinate >= 0; ++k) {  // free and ball joints own theirs
      const TreeLink<S>& o = links[k];
      const int owned = o.free ? 7 : o.ball ? 4 : 0;
      const bool inside = k != i && owned > 0 && l.coordinate + width > o.coordinate &&
                          l.coordinate < o.coordinate + owned;
      if (inside)
        throw std::invalid_argument(link + "'s coordinate " + std::to_string(l.coordinate) +
                                    " belongs to link " + std::to_string(k) + "'s " +
                                    (o.free ? "free" : "ball") + " joint (q[" +
                                    std::to_string(o.coordinate) + ".." +
                                    std::to_string(o.coordinate + owned) + "))");
    }
    if (l.axis[0] == 0.0 && l.axis[1] == 0.0 && l.axis[2] == 0.0)
      throw std::invalid_argument(link + "'s joint axis is zero");
    if (!std::isfinite(l.multiplier) || !std::isfinite(l.offset) ||
        ((l.multiplier != 1.0 || l.offset != 0.0) && (l.coordinate < 0 || l.free || l.ball)))
      throw std::invalid_argument(link + "'s mimic multiplier and offset must be finite, and only "
                                  "a revolute or prismatic joint with a coordinate may have them");
    if (!(l.armature >= 0.0 && std::isfinite(l.armature)) ||
        (l.armature != 0.0 && (l.coordinate < 0 || l.free)))
      throw std::invalid_argument(link + "'s armature must be finite and >= 0, and only a "
                                  "revolute, prismatic or ball joint may have one");
  }
}

// The joint's motion direction per unit of its coordinate's rate: the unit axis, times a mimic
// joint's multiplier.
template <class S> std::array<double, 3> joint_axis(const TreeLink<S>& l) {
  auto u = unit_axis(l.axis).u;
  if (l.multiplier != 1.0)
    for (double& x : u) x *= l.multiplier;
  return u;
}

// The armature on the coordinate's rate: armature · multiplier² (the rotor turns at multiplier · q̇).
template <class S> double reflected_armature(const TreeLink<S>& l) {
  return l.armature * l.multiplier * l.multiplier;
}

// A free joint's placement of its link in the world, from q[c..c+7).
template <class S> Transform<S> free_placement(In<S> q, int c = 0) {
  return {quaternion(q[c + 3], q[c + 4], q[c + 5], q[c + 6]), {q[c], q[c + 1], q[c + 2]}};
}

// Whether link l is a free joint moved by x (q or v). check_tree refuses a free link without
// its seven coordinates; the size test lets the compiler see that a model without one never
// reads x[3..7) (GCC's -Warray-bounds would see a read past a small model's array otherwise).
template <class S> bool moves_free(const TreeLink<S>& l, In<S> x) {
  return l.free && x.size() >= static_cast<std::size_t>(free_joint_nv);
}
// The same for a ball joint (three velocities, four coordinates).
template <class S> bool moves_ball(const TreeLink<S>& l, In<S> x) {
  return l.ball && x.size() >= 3;
}

// The joint's motion at coordinates q (the identity for a fixed joint).
template <class S> Transform<S> joint_motion(const TreeLink<S>& l, In<S> q) {
  if (l.free)
    return q.size() >= free_joint_nq ? free_placement(q, l.coordinate) : Transform<S>{};
  if (l.coordinate < 0) return {};
  if (l.ball)
    return q.size() >= 4 ? Transform<S>{quaternion(q[l.coordinate], q[l.coordinate + 1],
                                                   q[l.coordinate + 2], q[l.coordinate + 3]),
                                        {S(0), S(0), S(0)}}
                         : Transform<S>{};
  const S& leader = q[l.coordinate];
  const S x = l.multiplier == 1.0 && l.offset == 0.0 ? leader : leader * l.multiplier + l.offset;
  return l.prismatic ? prismatic<S>(l.axis, x) : revolute<S>(l.axis, x);
}

// Each link's frame in its parent's, origin · motion(q), and vectors carried across it in two
// rotations, so that an origin made of quarter turns costs nothing and a coordinate-axis joint
// four products. Both recursions below walk the tree with it.
template <class S, std::size_t N> struct LinkFrames {
  const std::array<TreeLink<S>, N>& links;
  std::array<Transform<S>, N> motion;
  std::array<Vec3<S>, N> r;  // each link's origin in its parent's frame
  std::array<int, N> velocity;  // where each joint's velocities start in v (velocity_offsets)

  LinkFrames(const std::array<TreeLink<S>, N>& l, In<S> q) : links(l), velocity(velocity_offsets(l)) {
    for (std::size_t i = 0; i < N; ++i) {
      motion[i] = joint_motion(l[i], q);
      r[i] = l[i].origin.apply(motion[i].translation);
    }
  }
  Vec3<S> to_link(std::size_t i, const Vec3<S>& v) const {
    return rotate_back(motion[i].rotation, rotate_back(links[i].origin.rotation, v));
  }
  Vec3<S> to_parent(std::size_t i, const Vec3<S>& v) const {
    return rotate(links[i].origin.rotation, rotate(motion[i].rotation, v));
  }
  Rot3<S> to_parent_rotation(std::size_t i) const {
    return multiply(links[i].origin.rotation, motion[i].rotation);
  }
};

// A link's motion in its own axes: angular velocity, the origin's velocity, angular acceleration
// and the origin's classical acceleration d²x/dt².
template <class S> struct LinkMotion {
  Vec3<S> w, v, dw, a;
};

// Link i's motion from its parent's (null: the root, which does not move unless free) and the
// joint's rates v and accelerations v̇: the outward step of the recursive Newton–Euler algorithm.
// With gravity g the world accelerates upwards at g: a fixed root's acceleration is g e_z, a free
// one's v̇ + g e_z (its linear v̇ is in world axes).
template <class S, std::size_t N>
LinkMotion<S> link_motion(const LinkFrames<S, N>& X, std::size_t i, const LinkMotion<S>* parent,
                          In<S> qd, In<S> qdd, const S* gravity = nullptr) {
  const TreeLink<S>& l = X.links[i];
  const int j = X.velocity[i];
  LinkMotion<S> k;
  if (moves_free(l, qd)) {  // ω, ω̇ are v's and v̇'s in link axes; the origin's velocity and
                            // acceleration are in world axes there
    const Rot3<S>& R = X.motion[i].rotation;
    k = {{qd[j + 3], qd[j + 4], qd[j + 5]},
         rotate_back(R, Vec3<S>{qd[j], qd[j + 1], qd[j + 2]}),
         {qdd[j + 3], qdd[j + 4], qdd[j + 5]},
         rotate_back(R, Vec3<S>{qdd[j], qdd[j + 1], gravity ? qdd[j + 2] + *gravity : qdd[j + 2]})};
  } else if (!parent) {  // the root does not move (but accelerates upwards at g: gravity)
    const Vec3<S> zero{S(0), S(0), S(0)};
    k = {zero, zero, zero, gravity ? X.to_link(i, Vec3<S>{S(0), S(0), *gravity}) : zero};
  } else {
    const LinkMotion<S>& p = *parent;
    const Vec3<S>& x = X.r[i];
    k.w = X.to_link(i, p.w);
    k.v = X.to_link(i, plus(p.v, cross(p.w, x)));
    k.dw = X.to_link(i, p.dw);
    k.a = X.to_link(i, plus(p.a, plus(cross(p.dw, x), cross(p.w, cross(p.w, x)))));
  }
  if (moves_ball(l, qd)) {  // ω += ω_b, ω̇ += ω̇_b + ω_parent × ω_b (link axes, as a revolute's)
    const Vec3<S> w{qd[j], qd[j + 1], qd[j + 2]}, dw{qdd[j], qdd[j + 1], qdd[j + 2]};
    k.dw = plus(k.dw, plus(dw, cross(k.w, w)));
    k.w = plus(k.w, w);
  } else if (l.coordinate >= 0 && !l.free && !l.ball) {
    const auto u = joint_axis(l);
    const Vec3<S> s_qd = scaled(u, qd[j]), s_qdd = scaled(u, qdd[j]);
    if (l.prismatic) {  // v += s q̇, a += s q̈ + 2 ω × s q̇ (ω unchanged)
      k.v = plus(k.v, s_qd);
      const Vec3<S> w_v = cross(k.w, s_qd);
      k.a = plus(k.a, plus(s_qdd, plus(w_v, w_v)));
    } else {  // ω += s q̇, ω̇ += s q̈ + ω_parent × s q̇ (= ω × s q̇)
      k.dw = plus(k.dw, plus(s_qdd, cross(k.w, s_qd)));
      k.w = plus(k.w, s_qd);
    }
  }
  return k;
}

template <class M> concept has_link_count = requires { M::link_count; };
template <class M> concept declares_tree = requires { &M::template tree<double>; };

// A model's tree form, validated: false when it has none; each misuse a static_assert naming it.
template <class M> consteval bool tree_form() {
  static_assert(has_link_count<M> == declares_tree<M>,
                "eom model: the tree form needs both `static constexpr int link_count` and "
                "`template <class S> static void tree(eom::In<S> p, eom::Out<eom::TreeLink<S>> l)`");
  if constexpr (has_link_count<M> && declares_tree<M>) {
    static_assert(std::is_convertible_v<decltype(M::link_count), int> && M::link_count >= 1,
                  "eom model: `link_count` must be a positive integer");
    static_assert(requires(In<double> p, Out<TreeLink<double>> l) { M::template tree<double>(p, l); },
                  "eom model: `tree` has the wrong signature; expected `template <class S> static "
                  "void tree(eom::In<S> p, eom::Out<eom::TreeLink<S>> l)`");
    static_assert(bodies_callable_with<M, double, SpatialBody>,
                  "eom model: the tree form is a spatial body form: `bodies` (eom::SpatialBody, "
                  "written as eom::tree_bodies of the tree) must be there too");
    return true;
  }
  return false;
}

}  // namespace detail

// Whether a coordinate moves several links or a joint has a mimic multiplier (TreeLink).
template <class S, std::size_t N> bool tree_has_mimic(const std::array<TreeLink<S>, N>& links) {
  for (std::size_t i = 0; i < N; ++i) {
    if (links[i].free || links[i].ball || links[i].coordinate < 0) continue;
    if (links[i].multiplier != 1.0) return true;
    for (std::size_t k = 0; k < i; ++k)
      if (!links[k].free && !links[k].ball && links[k].coordinate == links[i].coordinate)
        return true;
  }
  return false;
}

// Whether tree_forward_dynamics takes the tree: no mimic joint, no ball joint.
template <class S, std::size_t N> bool articulated_body_applies(const std::array<TreeLink<S>, N>& links) {
  for (const TreeLink<S>& l : links)
    if (l.ball) return false;
  return !tree_has_mimic(links);
}

// The model's links, from its tree form.
template <class M, class S> std::array<TreeLink<S>, M::link_count> tree_of(In<S> p) {
  std::array<TreeLink<S>, M::link_count> links;
  M::template tree<S>(p, links);
  return links;
}

// Link i's frame in the world, from its parent's in `world`.
template <class S, std::size_t N>
Transform<S> link_placement(const std::array<TreeLink<S>, N>& links, const std::array<Transform<S>, N>& world,
                            std::size_t i, In<S> q) {
  const TreeLink<S>& l = links[i];
  // (parent · origin) · motion: the constant origin folds into the parent's frame first
  const Transform<S> joint = l.parent < 0 ? l.origin : world[l.parent] * l.origin;
  return l.coordinate < 0 ? joint : joint * detail::joint_motion(l, q);
}

// Each link's frame in the world.
template <class S, std::size_t N>
std::array<Transform<S>, N> tree_placements(const std::array<TreeLink<S>, N>& links, In<S> q) {
  std::array<Transform<S>, N> world;
  for (std::size_t i = 0; i < N; ++i) world[i] = link_placement(links, world, i, q);
  return world;
}

// The tree's links as bodies (one per link, in order; a massless link is a body of mass 0).
template <class S, std::size_t N>
void tree_bodies(const std::array<TreeLink<S>, N>& links, In<S> q, Out<SpatialBody<S>> b) {
  detail::check_tree(links, q.size(), q.size() - detail::quaternion_count(links));
  const std::array<Transform<S>, N> world = tree_placements(links, q);
  for (std::size_t i = 0; i < N; ++i)
    b[i] = rigid_body<S>(world[i], links[i].mass, links[i].inertia, links[i].inertial);
}

namespace detail {
template <class S, std::size_t N>
void inverse_dynamics(const std::array<TreeLink<S>, N>& links, In<S> q, In<S> qd, In<S> qdd, Out<S> tau,
                      const S* gravity) {
  using detail::cross, detail::plus;
  detail::check_tree(links, q.size(), qd.size());
  const detail::LinkFrames<S, N> X(links, q);
  std::array<detail::LinkMotion<S>, N> m;
  std::array<Vec3<S>, N> f, n;  // force and moment (about the origin) the parent exerts, link axes
  for (std::size_t i = 0; i < N; ++i) {
    const TreeLink<S>& l = links[i];
    const detail::LinkMotion<S>& k = m[i] =
        detail::link_motion(X, i, l.parent < 0 ? nullptr : &m[l.parent], qd, qdd, gravity);
    // The link's force and moment about its origin: m a_c and J ω̇ + ω × J ω + c × m a_c.
    const Vec3<S>& c = l.inertial.translation;
    const std::array<S, 6> J = detail::rotated_inertia(l.inertial.rotation, l.inertia);
    const Vec3<S> a_c = plus(k.a, plus(cross(k.dw, c), cross(k.w, cross(k.w, c))));
    f[i] = {l.mass * a_c[0], l.mass * a_c[1], l.mass * a_c[2]};
    n[i] = plus(plus(detail::inertia_times(J, k.dw), cross(k.w, detail::inertia_times(J, k.w))),
                cross(c, f[i]));
  }
  for (S& t : tau) t = S(0);
  for (std::size_t i = N; i-- > 0;) {
    const TreeLink<S>& l = links[i];
    const int j = X.velocity[i];
    if (detail::moves_free(l, qd)) {
      const Vec3<S> F = rotate(X.motion[i].rotation, f[i]);
      for (int k = 0; k < 3; ++k) {
        tau[j + k] = F[k];
        tau[j + 3 + k] = n[i][k];
      }
    } else if (detail::moves_ball(l, qd)) {  // the moment about its centre, link axes
      for (int k = 0; k < 3; ++k)
        tau[j + k] = n[i][k] + qdd[j + k] * S(l.armature);
    } else if (l.coordinate >= 0) {  // += : a mimic joint adds to its leader's coordinate
      const auto u = detail::joint_axis(l);
      const int k = j;
      S& t = tau[k];
      t = t + detail::dot(u, l.prismatic ? f[i] : n[i]);
      if (l.armature != 0.0) t = t + qdd[k] * S(detail::reflected_armature(l));
    }
    if (l.parent >= 0) {  // the parent carries this link: its force and moment in parent axes
      const Vec3<S> fp = X.to_parent(i, f[i]);
      f[l.parent] = plus(f[l.parent], fp);
      n[l.parent] = plus(n[l.parent], plus(X.to_parent(i, n[i]), cross(X.r[i], fp)));
    }
  }
}
}  // namespace detail

// τ = M(q) v̇ + c(q, v): the joint forces that give the tree the accelerations v̇ without gravity
// or other loads (a model's potential and generalized forces add theirs), by the recursive
// Newton–Euler algorithm in each link's own axes: velocities and accelerations outward from the
// root, then each link's force and moment about its origin inward, τ the moment (revolute) or
// force (prismatic) along the joint axis; a free joint's τ is the force in world axes, then the
// moment in root axes. Velocities no joint moves get τ = 0. (Without a free joint v = q̇.)
template <class S, std::size_t N>
void tree_inverse_dynamics(const std::array<TreeLink<S>, N>& links, In<S> q, In<S> qd, In<S> qdd,
                           Out<S> tau) {
  detail::inverse_dynamics(links, q, qd, qdd, tau, static_cast<const S*>(nullptr));
}
// The same with gravity g along −z on the tree's bodies (the world accelerates upwards at g, a
// free root's linear v̇ with it): τ + ∂V/∂q for V = g Σ m z, as gravity_potential of tree_bodies.
template <class S, std::size_t N>
void tree_inverse_dynamics(const std::array<TreeLink<S>, N>& links, In<S> q, In<S> qd, In<S> qdd,
                           Out<S> tau, const S& gravity) {
  detail::inverse_dynamics(links, q, qd, qdd, tau, &gravity);
}

namespace detail {
template <class S, std::size_t N>
void mass_matrix(const std::array<TreeLink<S>, N>& links, In<S> q, Out<S> M, bool world) {
  using detail::cross, detail::plus;
  std::size_t nv = 0;
  while (nv * nv < M.size()) ++nv;
  detail::check_tree(links, q.size(), nv);
  const detail::LinkFrames<S, N> X(links, q);
  const Vec3<S> zero{S(0), S(0), S(0)};
  std::array<detail::RigidInertia<S>, N> IC;  // each link's and every link's below it
  for (std::size_t i = 0; i < N; ++i) IC[i] = detail::rigid_inertia(links[i]);
  for (std::size_t i = N; i-- > 0;) {
    const TreeLink<S>& l = links[i];
    if (l.parent < 0) continue;
    const detail::RigidInertia<S> add = detail::in_parent(X.to_parent_rotation(i), X.r[i], IC[i]);
    auto& I = IC[l.parent];
    for (int k = 0; k < 6; ++k) I.I[k] = I.I[k] + add.I[k];
    I.m = I.m + add.m;
    I.h = plus(I.h, add.h);
  }
  for (S& x : M) x = S(0);
  struct Force {
    Vec3<S> n, f;  // moment about the link origin, force; link axes
  };
  // The force I (ω, v): n = I ω + h × v, f = ω × h + m v.
  auto times = [](const detail::RigidInertia<S>& I, const Vec3<S>& w, const Vec3<S>& v) {
    return Force{plus(detail::inertia_times(I.I, w), cross(I.h, v)),
                 plus(cross(w, I.h), Vec3<S>{I.m * v[0], I.m * v[1], I.m * v[2]})};
  };
  // Link j's velocities in v: the first, and how many (a free joint's six, a ball joint's three,
  // a joint's one, or none).
  auto velocities = [&](std::size_t j) {
    return std::pair<int, int>{X.velocity[j], detail::joint_velocities(links[j])};
  };
  // Velocity k of link j: its motion (ω, v of the origin, link axes), and the generalized force
  // a force F on the link exerts along it.
  auto motion = [&](std::size_t j, int k) {
    const TreeLink<S>& l = links[j];
    std::pair<Vec3<S>, Vec3<S>> m{zero, zero};
    if (l.free && k < 3) {  // the world velocity e_k of the link origin: Rᵀ e_k in link axes
      const Rot3<S>& R = X.motion[j].rotation;
      m.second = {R[k], R[k + 3], R[k + 6]};
    } else if (l.free) {
      m.first[k - 3] = S(1);
    } else if (l.ball) {
      m.first[k] = S(1);
    } else {
      const auto u = detail::joint_axis(l);
      (l.prismatic ? m.second : m.first) = Vec3<S>{S(u[0]), S(u[1]), S(u[2])};
    }
    return m;
  };
  auto along = [&](std::size_t j, int k, const Force& F) -> S {
    const TreeLink<S>& l = links[j];
    if (l.free) return k < 3 ? rotate(X.motion[j].rotation, F.f)[k] : F.n[k - 3];  // world force
    if (l.ball) return F.n[k];
    return detail::dot(detail::joint_axis(l), l.prismatic ? F.f : F.n);
  };
  // world: each link's placement, and each joint's motion in world axes about the origin.
  std::vector<Transform<S>> placed;
  std::vector<Force> axis;  // n: ω, f: the origin's velocity (p × ω, or R u if prismatic)
  if (world) {
    const auto at = tree_placements(links, q);
    placed.assign(at.begin(), at.end());
    for (std::size_t j = 0; j < N; ++j) {
      const auto [w, v] = motion(j, 0);
      const Vec3<S> W = rotate(placed[j].rotation, w), V = rotate(placed[j].rotation, v);
      axis.push_back({W, plus(V, cross(placed[j].translation, W))});
    }
  }
  auto dot3 = [](const Vec3<S>& x, const Vec3<S>& y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
  for (std::size_t i = 0; i < N; ++i) {
    const auto [first, count] = velocities(i);
    for (int c = 0; c < count; ++c) {
      const int a = first + c;
      const auto [w, v] = motion(i, c);
      Force F = times(IC[i], w, v);
      Force FW = F;  // world: F in world axes about the origin
      if (world) {
        FW.f = rotate(placed[i].rotation, F.f);
        FW.n = plus(rotate(placed[i].rotation, F.n), cross(placed[i].translation, FW.f));
      }
      for (std::size_t j = i;;) {  // M[b][a] for the velocities b of i and the links above it
        const auto [jf, jc] = velocities(j);
        for (int d = 0; d < jc; ++d) {  // sums: links that share a coordinate (mimic joints)
          const int b = jf + d;          // add up, M = Gᵀ M_joints G
          if (j == i && b > a) continue;
          // A free link's world-velocity block is its subtree's mass times the identity:
          // R (m I) Rᵀ with R orthonormal, written so, not as the polynomial R m Rᵀ of q that
          // no pivot test can fold.
          const S x = links[j].free && j == i && c < 3 && d < 3 ? (c == d ? IC[j].m : S(0))
                      : world && j != i ? dot3(axis[j].n, FW.n) + dot3(axis[j].f, FW.f)
                                        : along(j, d, F);
          M[a + nv * b] = M[a + nv * b] + x;
          if (j != i || b != a) M[b + nv * a] = M[b + nv * a] + x;
        }
        if (links[j].parent < 0) break;
        if (!world) {
          const Vec3<S> fp = X.to_parent(j, F.f);
          F = {plus(X.to_parent(j, F.n), cross(X.r[j], fp)), fp};
        }
        j = static_cast<std::size_t>(links[j].parent);
      }
    }
  }
  for (std::size_t i = 0; i < N; ++i)  // the rotors: on the diagonal only
    if (links[i].armature != 0.0)
      for (int k = 0; k < detail::joint_velocities(links[i]); ++k) {
        const int a = X.velocity[i] + k;
        M[a + nv * a] = M[a + nv * a] + S(detail::reflected_armature(links[i]));
      }
}
}  // namespace detail

// M(q), the tree's mass matrix, by the composite-rigid-body algorithm in each link's own axes: the
// composite inertias inward, then for each joint its force I^c s carried towards the root, one
// entry of M per joint on the way (Featherstone, RBDA Table 6.2). A free link's six columns are
// (world force, link-axes moment) against (world velocity, link-axes angular velocity), a ball
// joint's three its link-axes moment against ω, as the RNEA's. M is nv × nv, column-major (nv =
// M's size ^ ½); velocities no joint moves get 0 rows.
template <class S, std::size_t N>
void tree_mass_matrix(const std::array<TreeLink<S>, N>& links, In<S> q, Out<S> M) {
  detail::mass_matrix(links, q, M, false);
}

// M(q) as tree_mass_matrix computes it, but each joint's force I^c s taken once into world axes
// about the world origin and dotted there with each ancestor joint's motion (ω, p × ω), where
// tree_mass_matrix carries it into every parent's axes in turn: 4 operations per entry of a
// planar chain against 8. The same composite inertias and diagonal; off the diagonal a moment
// about the origin rounds with |p| |f|, so for a fixed base near the origin (no free or ball
// joints, else std::invalid_argument). The generator's mass_matrix kernel keeps it if cheaper.
template <class S, std::size_t N>
void tree_mass_matrix_world(const std::array<TreeLink<S>, N>& links, In<S> q, Out<S> M) {
  for (const TreeLink<S>& l : links)
    if (l.free || l.ball)
      throw std::invalid_argument("eom::tree_mass_matrix_world: a free or ball joint; call "
                                  "tree_mass_matrix");
  detail::mass_matrix(links, q, M, true);
}


// How the ABA's outward pass reaches a joint's v̇ = (u − U·a) / D from its parent's acceleration:
// `carried`, the parent's acceleration carried into the link's axes first (fewer operations), or
// `from_parent`, U / D carried into the parent's axes on the way in, so that one dot product with
// the parent's acceleration gives v̇ (more operations, fewer dependent steps from link to link: a
// long chain's ABA is bound by that dependency chain, not by its operations).
enum class AbaOutward { carried, from_parent };

namespace detail {
template <class S, std::size_t N>
void forward_dynamics(const std::array<TreeLink<S>, N>& links, In<S> q, In<S> qd, In<S> tau, Out<S> qdd,
                      Out<S> pivots, const S* gravity, AbaOutward outward) {
  using detail::cross, detail::plus, detail::rotate_back;
  detail::check_tree(links, q.size(), qd.size());
  if (!articulated_body_applies(links))
    throw std::invalid_argument("eom::tree_forward_dynamics: the tree has mimic joints (a "
                                "coordinate that moves several links, or a multiplier) or ball "
                                "joints: the articulated-body algorithm here needs one joint per "
                                "coordinate and one velocity per joint (but free ones); solve "
                                "M(q) v̇ = τ − c with tree_mass_matrix and tree_inverse_dynamics");
  const Vec3<S> zero{S(0), S(0), S(0)};
  const detail::LinkFrames<S, N> X(links, q);
  using Pair = detail::Pair<S>;  // link axes
  using detail::sum, detail::scale, detail::dot;
  auto times = [](const detail::SpatialInertia<S>& I, const Pair& m) {  // the force I m
    return Pair{plus(detail::inertia_times(I.I, m.a), rotate(I.H, m.b)),
                plus(rotate_back(I.H, m.a), detail::inertia_times(I.M, m.b))};
  };
  auto motion_in_link = [&](std::size_t i, const Pair& m) {  // a parent motion at the link origin
    return Pair{X.to_link(i, m.a), X.to_link(i, plus(m.b, cross(m.a, X.r[i])))};
  };

  std::array<Pair, N> s, v, c, p, U, a, G;  // s: the joint axis, (a, 0) revolute, (0, a) prismatic
  std::array<detail::SpatialInertia<S>, N> IA;
  std::array<S, N> D, D_inv, u, x0;  // from_parent: v̇ = x0 − G·(the parent's acceleration)
  for (std::size_t i = 0; i < N; ++i) {  // velocities, velocity-product accelerations, bias forces
    const TreeLink<S>& l = links[i];
    v[i] = l.parent < 0 ? Pair{zero, zero} : motion_in_link(i, v[l.parent]);
    c[i] = {zero, zero};
    const int j = X.velocity[i];
    if (detail::moves_free(l, qd)) {  // (ω, the origin's velocity) in link axes
      v[i] = {{qd[j + 3], qd[j + 4], qd[j + 5]},
              rotate_back(X.motion[i].rotation, Vec3<S>{qd[j], qd[j + 1], qd[j + 2]})};
    } else if (l.coordinate >= 0) {  // v += s q̇; c = v × s q̇ (the motion cross product)
      const auto unit = detail::unit_axis(l.axis).u;
      const Vec3<S> axis{S(unit[0]), S(unit[1]), S(unit[2])};
      s[i] = l.prismatic ? Pair{zero, axis} : Pair{axis, zero};
      const Pair s_qd = scale(s[i], qd[j]);
      v[i] = sum(v[i], s_qd);
      c[i] = {cross(v[i].a, s_qd.a), plus(cross(v[i].a, s_qd.b), cross(v[i].b, s_qd.a))};
    }
    IA[i] = detail::body_inertia(l);
    const Pair h = times(IA[i], v[i]);  // v ×* I v
    p[i] = {plus(cross(v[i].a, h.a), cross(v[i].b, h.b)), cross(v[i].a, h.b)};
  }
  for (std::size_t i = N; i-- > 0;) {  // articulated inertias and bias forces, inward
    const TreeLink<S>& l = links[i];
    if (l.free) continue;  // a root: its articulated inertia is complete, solved below
    detail::SpatialInertia<S> Ia = IA[i];
    Pair pa = p[i];
    if (l.coordinate >= 0) {
      const int k = X.velocity[i];
      U[i] = times(IA[i], s[i]);
      D[i] = dot(s[i], U[i]);
      if (l.armature != 0.0) D[i] = D[i] + S(l.armature);  // the rotor: on the joint's own pivot
      pivots[k] = D[i];
      u[i] = tau[k] - dot(s[i], p[i]);
      const Pair& W = U[i];
      D_inv[i] = S(1) / D[i];  // once: every later division by D is a product
      const Pair V = scale(W, D_inv[i]);  // U / D
      if (outward == AbaOutward::from_parent) {  // G = Xᵀ (U / D), x0 = (u − U·c) / D
        x0[i] = (u[i] - dot(W, c[i])) * D_inv[i];
        const Vec3<S> b = l.parent < 0 ? V.b : X.to_parent(i, V.b);
        G[i] = l.parent < 0 ? V : Pair{plus(X.to_parent(i, V.a), cross(X.r[i], b)), b};
      }
      // Iᵃ = Iᴬ − (U / D) Uᵀ, blockwise. Where s = ±e_k, U = ±Iᴬe_k and D = Iᴬ_kk + a (a the
      // rotor's armature), so Iᵃ's row and column k are ±U a / D: zero without a rotor, and
      // never the cancellation Iᴬ_k − U (U_k / D).
      const detail::UnitAxis along = detail::unit_axis(l.axis);
      const int ka = l.prismatic ? -1 : along.coordinate, kb = l.prismatic ? along.coordinate : -1;
      const S r = l.armature == 0.0 ? S(0) : S(along.sign * l.armature) * D_inv[i];
      auto I = [&](int x, int y) {
        if (x == ka || y == ka) return r * W.a[x == ka ? y : x];
        return detail::sym(Ia.I, x, y) - V.a[x] * W.a[y];
      };
      auto M = [&](int x, int y) {
        if (x == kb || y == kb) return r * W.b[x == kb ? y : x];
        return detail::sym(Ia.M, x, y) - V.b[x] * W.b[y];
      };
      Ia.I = detail::sym_of<S>(I);
      Ia.M = detail::sym_of<S>(M);
      for (int x = 0; x < 3; ++x)
        for (int y = 0; y < 3; ++y)
          Ia.H[x + 3 * y] = x == ka   ? r * W.b[y]
                            : y == kb ? r * W.a[x]
                                      : Ia.H[x + 3 * y] - V.a[x] * W.b[y];
      pa = sum(sum(pa, times(Ia, c[i])), scale(V, u[i]));  // pᵃ = p + Iᵃc + (U / D) u
    } else {
      pa = sum(pa, times(Ia, c[i]));
    }
    if (l.parent >= 0) {
      const std::size_t j = static_cast<std::size_t>(l.parent);
      const detail::SpatialInertia<S> add = detail::in_parent(X.to_parent_rotation(i), X.r[i], Ia);
      for (int k = 0; k < 6; ++k) {
        IA[j].I[k] = IA[j].I[k] + add.I[k];
        IA[j].M[k] = IA[j].M[k] + add.M[k];
      }
      for (int k = 0; k < 9; ++k) IA[j].H[k] = IA[j].H[k] + add.H[k];
      const Vec3<S> fp = X.to_parent(i, pa.b);
      p[j] = sum(p[j], Pair{plus(X.to_parent(i, pa.a), cross(X.r[i], fp)), fp});
    }
  }
  for (S& x : qdd) x = S(0);
  for (std::size_t i = 0; i < N; ++i) {  // accelerations, outward
    const TreeLink<S>& l = links[i];
    if (detail::moves_free(l, qd)) {  // Iᴬ a = f − pᴬ, f = (moment, Rᵀ force) from τ; then a
                                      // to (world v̇, ω̇)
      const int j = X.velocity[i];
      const Rot3<S>& R = X.motion[i].rotation;
      const Vec3<S> force = rotate_back(R, Vec3<S>{tau[j], tau[j + 1], tau[j + 2]});
      std::array<S, 6> b;
      for (int k = 0; k < 3; ++k) {
        b[k] = force[k] - p[i].b[k];
        b[3 + k] = tau[j + 3 + k] - p[i].a[k];
      }
      detail::solve_spatial(IA[i], b, pivots.subspan(j, 6));
      a[i] = {{b[3], b[4], b[5]}, {b[0], b[1], b[2]}};
      const Vec3<S> classical = plus(a[i].b, cross(v[i].a, v[i].b));  // the origin's, link axes
      Vec3<S> world = rotate(R, classical);
      if (gravity) world[2] = world[2] - *gravity;  // a is relative to the world, which rises at g
      for (int k = 0; k < 3; ++k) {
        qdd[j + k] = world[k];
        qdd[j + 3 + k] = a[i].a[k];
      }
      continue;
    }
    const Pair root{zero, gravity ? X.to_link(i, Vec3<S>{S(0), S(0), *gravity}) : zero};
    if (outward == AbaOutward::from_parent && l.parent >= 0) {  // c first in each sum: the
      const Pair& m = a[l.parent];  // carried terms, the latest to arrive, a multiply-add each
      auto in_link = [&](const Vec3<S>& x, const Vec3<S>& plus_c) {
        const Vec3<S> y = rotate_back(l.origin.rotation, x);
        const Rot3<S>& r = X.motion[i].rotation;
        return Vec3<S>{plus_c[0] + r[0] * y[0] + r[1] * y[1] + r[2] * y[2],
                       plus_c[1] + r[3] * y[0] + r[4] * y[1] + r[5] * y[2],
                       plus_c[2] + r[6] * y[0] + r[7] * y[1] + r[8] * y[2]};
      };
      a[i] = {in_link(m.a, c[i].a), in_link(plus(m.b, cross(m.a, X.r[i])), c[i].b)};
    } else {
      a[i] = sum(l.parent < 0 ? root : motion_in_link(i, a[l.parent]), c[i]);
    }
    if (l.coordinate >= 0) {
      S x;
      if (outward == AbaOutward::from_parent) {  // x0 − G·a_parent, the parent's own joint's
        const Pair& ap = l.parent < 0 ? root : a[l.parent];  // half last: the latest to arrive
        const bool linear_last = l.parent >= 0 && links[l.parent].prismatic;
        x = x0[i];
        for (int half = 0; half < 2; ++half) {
          const bool linear = (half == 1) == linear_last;
          for (int k = 0; k < 3; ++k) x = x - (linear ? G[i].b[k] * ap.b[k] : G[i].a[k] * ap.a[k]);
        }
      } else {
        x = (u[i] - dot(U[i], a[i])) * D_inv[i];
      }
      qdd[X.velocity[i]] = x;
      a[i] = sum(a[i], scale(s[i], x));
    }
  }
}
}  // namespace detail

// v̇ = M(q)⁻¹ (τ − c(q, v)): the accelerations the joint forces τ give the tree without gravity
// (a model's potential and generalized forces go into τ), by the articulated-body algorithm in
// each link's own axes with spatial (Featherstone) accelerations: velocities outward, articulated
// inertias and bias forces inward, accelerations outward. pivots[k] receives the articulated
// inertia about velocity k's axis, D = sᵀIᴬs, by which it divides: positive for a tree whose
// every moving subtree has mass; a free root's six are those of the LDLᵀ factorization of its
// articulated inertia (force rows first). Velocities no joint moves get v̇ = 0. (Without a free
// joint v = q̇.)
template <class S, std::size_t N>
void tree_forward_dynamics(const std::array<TreeLink<S>, N>& links, In<S> q, In<S> qd, In<S> tau,
                           Out<S> qdd, Out<S> pivots, AbaOutward outward = AbaOutward::carried) {
  detail::forward_dynamics(links, q, qd, tau, qdd, pivots, static_cast<const S*>(nullptr), outward);
}
// The same with gravity g along −z on the tree's bodies (the world accelerates upwards at g; a
// free root's linear v̇ is solved with it and g taken off): τ then need not hold −∂V/∂q.
template <class S, std::size_t N>
void tree_forward_dynamics(const std::array<TreeLink<S>, N>& links, In<S> q, In<S> qd, In<S> tau,
                           Out<S> qdd, Out<S> pivots, const S& gravity,
                           AbaOutward outward = AbaOutward::carried) {
  detail::forward_dynamics(links, q, qd, tau, qdd, pivots, &gravity, outward);
}

}  // namespace eom
