// Recursive rigid-body dynamics of an eom::urdf::Robot, templated on the scalar: an INDEPENDENT
// check of the kernels generated from a URDF file by the Lagrangian route (M from the kinetic
// energy, c by differentiation, ∂V/∂q from the potential).
//
// Featherstone, "Rigid Body Dynamics Algorithms" (Springer 2008), referred to as RBDA:
//   - RNEA (Table 5.1): inverse dynamics τ = M q̈ + c + ∂V/∂q;
//   - CRBA (Table 6.2): the joint-space inertia matrix M(q);
//   - ABA  (Table 7.1): forward dynamics q̈ for given joint forces;
//   - task space (docs/CONTRACT.md §2, "Frames"): any link's placement, its Jacobian and bias
//     J̇v in Pinocchio's LOCAL_WORLD_ALIGNED convention, from the motion subspaces carried to
//     world coordinates and a velocity/acceleration pass at v̇ = 0; the mass centre, its Jacobian
//     and the centroidal momentum matrix from the CRBA's composite inertias (Orin, Briggs, Lee,
//     "Centroidal dynamics of a humanoid robot", Autonomous Robots 35, 2013).
// Everything here is written from the book, not from the project: its own 6D spatial algebra
// (motion and force vectors, Plücker transforms, spatial inertias), no eom/multibody/spatial.hpp, no
// eom/model/model.hpp, no parser. The numbers of the Robot (doubles) are converted to Scalar once, in
// the constructor; every trigonometric function and square root (rpy angles, axis normalization,
// joint rotations) is evaluated in Scalar, so with Scalar = dd_real the model is accurate to
// ~1e-30 for inputs that are exactly representable (the double inputs are taken as exact).
//
// Conventions (those of generator/include/eomgen/urdf.hpp):
//   - child frame = parent frame · T(origin xyz, rpy) · motion(q), rpy = Rz(yaw)·Ry(pitch)·Rx(roll);
//     motion(q) = rotation by q about the normalized axis (revolute, continuous) or translation by
//     q along it (prismatic); joint limits are not modelled;
//   - a link's inertial: mass centre at the inertial origin xyz in the link frame, inertia tensor
//     (ixx iyy izz ixy ixz iyz) about the mass centre in axes rotated by the inertial rpy; no
//     inertial: massless;
//   - links joined by fixed joints form one rigid body, whose frame is that of the link the moving
//     joint enters (links fixed to the root belong to the world and do not move, unless the robot
//     is floating: then they ride on the root body);
//   - gravity g along −z of the world frame (the root frame when the root is fixed); coordinates:
//     the non-fixed joints in file order (file order need not be topological: the algorithms walk
//     a topological order);
//   - generalized force Q = u − d⊙q̇. inverse_dynamics (RNEA) excludes the damping: it returns
//     τ = M q̈ + c + ∂V/∂q, and damping() exposes d; forward_dynamics applies τ = u − d⊙q̇.
//
// Floating robots (Robot::floating): a free joint between the world and the root link comes first.
// q = (x, y, z, qw, qx, qy, qz, joints…): the root origin in world coordinates and the unit
// quaternion (scalar first) taking root axes to world axes; v = (v_world, ω_root, joint rates…):
// the root origin's velocity in world axes (= d/dt (x, y, z)) and the root's angular velocity in
// root axes; q̇ = G(q) v with the quaternion rate ½ q ⊗ (0, ω) (configuration_rate). The free
// rows of τ (conjugate to v) are a force in world axes and a moment about the root origin in root
// axes. nq = 7 + joints, nv = 6 + joints; M is nv×nv; everything indexed by velocity (τ, q̈ — read
// v̇ —, damping) has nv entries. Written as the root body's velocity in its own frame,
// v_0 = [ω; Rᵀ v_world] = S_0 v_free with S_0 = [0 1; Rᵀ 0]: the free joint is a 6-dof joint
// whose motion subspace is S_0 (RNEA, CRBA) or, in the body's own coordinates, the identity (ABA).
//
// Spatial vectors: 6-vectors [angular; linear] in the coordinates of a body frame; motion
// vectors (ω; v of the point at the frame origin), force vectors (moment about the frame origin;
// force). A body's pose in its parent (R, p): R's columns are the body axes in parent
// coordinates, p its origin; the Plücker transform parent → body is then X = [Rᵀ 0; −Rᵀp× Rᵀ].
//
// Scope: g and every Robot number are taken as the doubles they are (g = 9.81 is the double
// nearest 9.81 in every Scalar, so double and dd_real models describe the same robot). A moving
// body with no mass in its whole subtree (e.g. a massless leaf) makes M singular: the ABA divides
// by D = SᵀIᴬS = 0 there (the generated kernels cannot handle it either); so does a floating
// robot whose mass (or inertia) is zero: the root's 6×6 articulated inertia is singular.
//
// Allocation: the constructor sizes every workspace; the algorithms allocate nothing (they are
// non-const because they use that workspace; one model per thread).
#pragma once

#include <eomgen/urdf.hpp>

#include <array>
#include <cmath>
#include <cstddef>
#include <map>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace eomtest {

// ---- 3D and 6D algebra ----------------------------------------------------------------------
namespace rbd {

template <class S> using Vec3 = std::array<S, 3>;
template <class S> using Mat3 = std::array<S, 9>;   // row-major
template <class S> using Vec6 = std::array<S, 6>;   // [angular; linear]
template <class S> using Mat6 = std::array<S, 36>;  // row-major

template <class S>
Mat3<S> identity3() {
  Mat3<S> m;
  m.fill(S(0.0));
  m[0] = m[4] = m[8] = S(1.0);
  return m;
}

template <class S>
Vec3<S> cross(const Vec3<S>& a, const Vec3<S>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

template <class S>
S dot3(const Vec3<S>& a, const Vec3<S>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

template <class S>
Vec3<S> add(const Vec3<S>& a, const Vec3<S>& b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}

template <class S>
Vec3<S> scale(const S& s, const Vec3<S>& a) {
  return {s * a[0], s * a[1], s * a[2]};
}

template <class S>
Vec3<S> mul(const Mat3<S>& m, const Vec3<S>& v) {  // M v
  return {m[0] * v[0] + m[1] * v[1] + m[2] * v[2], m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
          m[6] * v[0] + m[7] * v[1] + m[8] * v[2]};
}

template <class S>
Vec3<S> mul_t(const Mat3<S>& m, const Vec3<S>& v) {  // Mᵀ v
  return {m[0] * v[0] + m[3] * v[1] + m[6] * v[2], m[1] * v[0] + m[4] * v[1] + m[7] * v[2],
          m[2] * v[0] + m[5] * v[1] + m[8] * v[2]};
}

template <class S>
Mat3<S> mul(const Mat3<S>& a, const Mat3<S>& b) {
  Mat3<S> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      c[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j];
  return c;
}

template <class S>
Mat3<S> transpose(const Mat3<S>& a) {
  return {a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8]};
}

template <class S>
Mat3<S> skew(const Vec3<S>& v) {  // skew(v) w = v × w
  return {S(0.0), -v[2], v[1], v[2], S(0.0), -v[0], -v[1], v[0], S(0.0)};
}

// Elementary rotations (active: columns are the rotated axes), angles converted to S first so
// that cos and sin are evaluated in S.
template <class S>
Mat3<S> rotation_x(const S& a) {
  using std::cos, std::sin;
  const S c = cos(a), s = sin(a);
  return {S(1.0), S(0.0), S(0.0), S(0.0), c, -s, S(0.0), s, c};
}
template <class S>
Mat3<S> rotation_y(const S& a) {
  using std::cos, std::sin;
  const S c = cos(a), s = sin(a);
  return {c, S(0.0), s, S(0.0), S(1.0), S(0.0), -s, S(0.0), c};
}
template <class S>
Mat3<S> rotation_z(const S& a) {
  using std::cos, std::sin;
  const S c = cos(a), s = sin(a);
  return {c, -s, S(0.0), s, c, S(0.0), S(0.0), S(0.0), S(1.0)};
}

// URDF rpy: fixed-axis roll about x, then pitch about y, then yaw about z: R = Rz·Ry·Rx.
template <class S>
Mat3<S> rpy_rotation(const std::array<double, 3>& rpy) {
  return mul(rotation_z(S(rpy[2])), mul(rotation_y(S(rpy[1])), rotation_x(S(rpy[0]))));
}

// Rotation by angle q about the unit axis a (Rodrigues): R = cos q·1 + sin q·a× + (1 − cos q)·aaᵀ.
template <class S>
Mat3<S> axis_angle(const Vec3<S>& a, const S& q) {
  using std::cos, std::sin;
  const S c = cos(q), s = sin(q), t = S(1.0) - c;
  return {c + t * a[0] * a[0],        t * a[0] * a[1] - s * a[2], t * a[0] * a[2] + s * a[1],
          t * a[1] * a[0] + s * a[2], c + t * a[1] * a[1],        t * a[1] * a[2] - s * a[0],
          t * a[2] * a[0] - s * a[1], t * a[2] * a[1] + s * a[0], c + t * a[2] * a[2]};
}

// A frame's pose in another: x_outer = R x_inner + p.
template <class S>
struct Pose {
  Mat3<S> R = identity3<S>();
  Vec3<S> p{S(0.0), S(0.0), S(0.0)};
};

// Pose of c in a, given b in a and c in b.
template <class S>
Pose<S> compose(const Pose<S>& ab, const Pose<S>& bc) {
  return {mul(ab.R, bc.R), add(ab.p, mul(ab.R, bc.p))};
}

template <class S>
Pose<S> pose_of(const eom::urdf::Pose& o) {
  return {rpy_rotation<S>(o.rpy), {S(o.xyz[0]), S(o.xyz[1]), S(o.xyz[2])}};
}

template <class S>
Vec6<S> zero6() {
  Vec6<S> v;
  v.fill(S(0.0));
  return v;
}

template <class S>
Vec3<S> top(const Vec6<S>& v) {
  return {v[0], v[1], v[2]};
}
template <class S>
Vec3<S> bottom(const Vec6<S>& v) {
  return {v[3], v[4], v[5]};
}
template <class S>
Vec6<S> join(const Vec3<S>& a, const Vec3<S>& b) {
  return {a[0], a[1], a[2], b[0], b[1], b[2]};
}

template <class S>
Vec6<S> add6(const Vec6<S>& a, const Vec6<S>& b) {
  Vec6<S> c;
  for (int i = 0; i < 6; ++i) c[i] = a[i] + b[i];
  return c;
}

template <class S>
S dot6(const Vec6<S>& a, const Vec6<S>& b) {
  S s = a[0] * b[0];
  for (int i = 1; i < 6; ++i) s += a[i] * b[i];
  return s;
}

template <class S>
Vec6<S> mul6(const Mat6<S>& m, const Vec6<S>& v) {
  Vec6<S> r;
  for (int i = 0; i < 6; ++i) {
    S s = m[6 * i] * v[0];
    for (int j = 1; j < 6; ++j) s += m[6 * i + j] * v[j];
    r[i] = s;
  }
  return r;
}

// Motion vector of the parent frame expressed in the body frame (body pose (R, p) in parent):
// ω_b = Rᵀω, v_b = Rᵀ(v − p × ω) (the velocity of the point at the body origin).
template <class S>
Vec6<S> motion_to_body(const Pose<S>& x, const Vec6<S>& m) {
  const Vec3<S> w = top(m);
  const Vec3<S> v = bottom(m);
  return join(mul_t(x.R, w), mul_t(x.R, add(v, cross(w, x.p))));  // v − p×ω = v + ω×p
}

// Motion vector of the body frame expressed in the parent frame (X⁻¹ m, the inverse of
// motion_to_body): ω_p = R ω, v_p = R v + p × ω_p.
template <class S>
Vec6<S> motion_to_parent(const Pose<S>& x, const Vec6<S>& m) {
  const Vec3<S> w = mul(x.R, top(m));
  return join(w, add(mul(x.R, bottom(m)), cross(x.p, w)));
}

// Force vector of the body frame expressed in the parent frame (Xᵀ f): f_p = R f,
// n_p = R n + p × f_p (moment shifted from the body origin to the parent origin).
template <class S>
Vec6<S> force_to_parent(const Pose<S>& x, const Vec6<S>& f) {
  const Vec3<S> fp = mul(x.R, bottom(f));
  return join(add(mul(x.R, top(f)), cross(x.p, fp)), fp);
}

// The motion cross product v×m (RBDA 2.31): [ω×m_ω; ω×m_v + v×m_ω].
template <class S>
Vec6<S> cross_motion(const Vec6<S>& v, const Vec6<S>& m) {
  const Vec3<S> w = top(v), vv = bottom(v), mw = top(m), mv = bottom(m);
  return join(cross(w, mw), add(cross(w, mv), cross(vv, mw)));
}

// The force cross product v×*f (RBDA 2.32): [ω×n + v×f; ω×f].
template <class S>
Vec6<S> cross_force(const Vec6<S>& v, const Vec6<S>& f) {
  const Vec3<S> w = top(v), vv = bottom(v), n = top(f), ff = bottom(f);
  return join(add(cross(w, n), cross(vv, ff)), cross(w, ff));
}

// Spatial inertia of a body of mass m, mass centre c and inertia Ic about c (RBDA 2.63):
//   I = [Ic + m c×c×ᵀ   m c×;  m c×ᵀ   m 1].
template <class S>
Mat6<S> spatial_inertia(const S& m, const Vec3<S>& c, const Mat3<S>& Ic) {
  const Mat3<S> cx = skew(c);
  const Mat3<S> cxcxt = mul(cx, transpose(cx));
  Mat6<S> I;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      I[6 * i + j] = Ic[3 * i + j] + m * cxcxt[3 * i + j];
      I[6 * i + j + 3] = m * cx[3 * i + j];
      I[6 * (i + 3) + j] = m * cx[3 * j + i];
      I[6 * (i + 3) + j + 3] = i == j ? m : S(0.0);
    }
  return I;
}

// The Plücker transform parent → body as a 6×6 matrix: X = [Rᵀ 0; −Rᵀp× Rᵀ].
template <class S>
Mat6<S> plucker(const Pose<S>& x) {
  const Mat3<S> E = transpose(x.R);
  const Mat3<S> B = mul(E, skew(x.p));
  Mat6<S> X;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      X[6 * i + j] = E[3 * i + j];
      X[6 * i + j + 3] = S(0.0);
      X[6 * (i + 3) + j] = -B[3 * i + j];
      X[6 * (i + 3) + j + 3] = E[3 * i + j];
    }
  return X;
}

// An inertia (rigid or articulated) of the body expressed in the parent frame: Xᵀ I X. Written
// as plain 6×6 products: slower than the rigid-body formulas but obviously right.
template <class S>
Mat6<S> inertia_to_parent(const Pose<S>& x, const Mat6<S>& I) {
  const Mat6<S> X = plucker(x);
  Mat6<S> IX, R;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      S s = I[6 * i] * X[j];
      for (int k = 1; k < 6; ++k) s += I[6 * i + k] * X[6 * k + j];
      IX[6 * i + j] = s;
    }
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      S s = X[i] * IX[j];
      for (int k = 1; k < 6; ++k) s += X[6 * k + i] * IX[6 * k + j];
      R[6 * i + j] = s;
    }
  return R;
}

// Rotation of the unit quaternion (w, x, y, z), scalar first: columns are the rotated axes. Not
// normalized here (the callers pass unit quaternions; the contract fixes this very formula).
template <class S>
Mat3<S> quaternion_rotation(const S& w, const S& x, const S& y, const S& z) {
  const S one(1.0), two(2.0);
  return {one - two * (y * y + z * z), two * (x * y - w * z),       two * (x * z + w * y),
          two * (x * y + w * z),       one - two * (x * x + z * z), two * (y * z - w * x),
          two * (x * z - w * y),       two * (y * z + w * x),       one - two * (x * x + y * y)};
}

// Solves A x = b for a symmetric positive definite 6×6 A (row-major; its lower triangle is read)
// by LDLᵀ: no square roots, so nothing but + − × ÷ in S.
template <class S>
Vec6<S> solve6(const Mat6<S>& A, const Vec6<S>& b) {
  Mat6<S> L{};
  Vec6<S> D{}, x = b;
  for (int j = 0; j < 6; ++j) {
    S d = A[6 * j + j];
    for (int k = 0; k < j; ++k) d -= L[6 * j + k] * L[6 * j + k] * D[k];
    D[j] = d;
    for (int i = j + 1; i < 6; ++i) {
      S s = A[6 * i + j];
      for (int k = 0; k < j; ++k) s -= L[6 * i + k] * L[6 * j + k] * D[k];
      L[6 * i + j] = s / d;
    }
  }
  for (int i = 0; i < 6; ++i)
    for (int k = 0; k < i; ++k) x[i] -= L[6 * i + k] * x[k];
  for (int i = 0; i < 6; ++i) x[i] /= D[i];
  for (int i = 5; i >= 0; --i)
    for (int k = i + 1; k < 6; ++k) x[i] -= L[6 * k + i] * x[k];
  return x;
}

}  // namespace rbd

// ---- the model --------------------------------------------------------------------------------
template <class Scalar>
class RecursiveDynamics {
 public:
  using S = Scalar;
  using Vec3 = rbd::Vec3<S>;
  using Vec6 = rbd::Vec6<S>;
  using Mat6 = rbd::Mat6<S>;
  using Pose = rbd::Pose<S>;

  // Builds the tree of moving bodies (one per coordinate) from the robot; throws
  // std::invalid_argument when the robot is not a tree rooted at robot.root or has a zero axis.
  explicit RecursiveDynamics(const eom::urdf::Robot& robot, double g = 9.81)
      : g_(S(g)), floating_(robot.floating) {
    using eom::urdf::JointType;
    const std::size_t nl = robot.links.size();
    std::map<std::string, std::size_t> link_index;
    for (std::size_t l = 0; l < nl; ++l)
      if (!link_index.emplace(robot.links[l].name, l).second)
        throw std::invalid_argument("recursive dynamics: duplicate link " + robot.links[l].name);
    const auto find = [&](const std::string& name) {
      const auto it = link_index.find(name);
      if (it == link_index.end())
        throw std::invalid_argument("recursive dynamics: unknown link " + name);
      return it->second;
    };

    // Coordinates: the non-fixed joints in file order. children[l]: joints whose parent is l.
    // The free joint has no damping (its six entries lead damping_).
    if (floating_) damping_.assign(6, S(0.0));
    std::vector<int> coordinate(robot.joints.size(), -1);
    std::vector<std::vector<std::size_t>> children(nl);
    std::vector<int> parent_count(nl, 0);
    for (std::size_t j = 0; j < robot.joints.size(); ++j) {
      const auto& joint = robot.joints[j];
      children[find(joint.parent)].push_back(j);
      ++parent_count[find(joint.child)];
      if (joint.type != JointType::fixed) {
        coordinate[j] = static_cast<int>(names_.size());
        names_.push_back(joint.name);
        damping_.push_back(S(joint.damping));
      }
    }
    const std::size_t root = find(robot.root);
    for (std::size_t l = 0; l < nl; ++l)
      if (parent_count[l] != (l == root ? 0 : 1))
        throw std::invalid_argument("recursive dynamics: link " + robot.links[l].name +
                                    " is not the child of exactly one joint (or the root)");
    const std::size_t n = names_.size();
    bodies_.resize(n);

    // Walk the tree from the root (depth first). body[l]: the moving body link l belongs to
    // (−1: the world); in_body[l]: link l's frame in that body's frame. A fixed joint extends
    // the body of its parent; a moving joint starts a new body, whose frame is its child link's
    // frame, placed in the parent body by the fixed chain composed with the joint origin.
    std::vector<int> body(nl, -1);
    std::vector<Pose> in_body(nl);
    std::vector<bool> seen(nl, false);
    std::vector<std::size_t> stack{root};
    seen[root] = true;
    while (!stack.empty()) {
      const std::size_t l = stack.back();
      stack.pop_back();
      for (const std::size_t j : children[l]) {
        const auto& joint = robot.joints[j];
        const std::size_t c = find(joint.child);
        if (seen[c]) throw std::invalid_argument("recursive dynamics: loop at " + joint.name);
        seen[c] = true;
        const Pose joint_frame = rbd::compose(in_body[l], rbd::pose_of<S>(joint.origin));
        if (joint.type == JointType::fixed) {
          body[c] = body[l];
          in_body[c] = joint_frame;
        } else {
          const int k = coordinate[j];
          Body& b = bodies_[static_cast<std::size_t>(k)];
          b.parent = body[l];
          b.tree = joint_frame;
          b.prismatic = joint.type == JointType::prismatic;
          using std::sqrt;
          const Vec3 a{S(joint.axis[0]), S(joint.axis[1]), S(joint.axis[2])};
          const S norm = sqrt(rbd::dot3(a, a));
          if (!(norm > S(0.0)))
            throw std::invalid_argument("recursive dynamics: zero axis at " + joint.name);
          b.axis = rbd::scale(S(1.0) / norm, a);
          // Motion subspace in the body frame: the axis is fixed by the joint's own motion, so
          // S = [a; 0] (rotation) or [0; a] (translation) in the child frame too.
          b.s = b.prismatic ? rbd::join(Vec3{S(0.0), S(0.0), S(0.0)}, b.axis)
                            : rbd::join(b.axis, Vec3{S(0.0), S(0.0), S(0.0)});
          body[c] = k;
          in_body[c] = Pose{};
          order_.push_back(k);  // depth-first preorder: every body after its parent
        }
        stack.push_back(c);
      }
    }
    for (std::size_t l = 0; l < nl; ++l)
      if (!seen[l])
        throw std::invalid_argument("recursive dynamics: link " + robot.links[l].name +
                                    " is not connected to the root");

    // Inertias: each link's spatial inertia expressed in its body's frame, summed (spatial
    // inertias of rigidly joined parts add). Links on the world body do not move: ignored; on a
    // floating robot that body is the root body (frame: the root link's), and it moves.
    for (auto& b : bodies_) {
      b.inertia.fill(S(0.0));
      b.mass = S(0.0);
      b.first_moment = Vec3{S(0.0), S(0.0), S(0.0)};
    }
    root_.inertia.fill(S(0.0));
    root_.mass = S(0.0);
    root_.first_moment = Vec3{S(0.0), S(0.0), S(0.0)};
    for (std::size_t l = 0; l < nl; ++l) {
      const auto& link = robot.links[l];
      if (!link.has_inertial || (body[l] < 0 && !floating_)) continue;
      const auto& in = link.inertial;
      const Pose com = rbd::compose(in_body[l], rbd::pose_of<S>(in.origin));
      const auto& t = in.inertia;  // ixx iyy izz ixy ixz iyz
      const rbd::Mat3<S> local{S(t[0]), S(t[3]), S(t[4]), S(t[3]), S(t[1]),
                               S(t[5]), S(t[4]), S(t[5]), S(t[2])};
      const rbd::Mat3<S> Ic = rbd::mul(com.R, rbd::mul(local, rbd::transpose(com.R)));
      const S m(in.mass);
      Body& b = body[l] < 0 ? root_ : bodies_[static_cast<std::size_t>(body[l])];
      const Mat6 I = rbd::spatial_inertia(m, com.p, Ic);
      for (int i = 0; i < 36; ++i) b.inertia[i] += I[i];
      b.mass += m;
      b.first_moment = rbd::add(b.first_moment, rbd::scale(m, com.p));
    }

    // Every link's frame stays reachable by name (massless and fixed-joint links included): its
    // body and its pose in that body's frame.
    link_index_ = std::move(link_index);
    link_body_ = std::move(body);
    link_in_body_ = std::move(in_body);

    // Workspace, sized once.
    x_.resize(n);
    world_.resize(n);
    v_.resize(n);
    a_.resize(n);
    f_.resize(n);
    c_.resize(n);
    U_.resize(n);
    D_.resize(n);
    u_.resize(n);
    IA_.resize(n);
  }

  int nq() const { return static_cast<int>(bodies_.size()) + (floating_ ? 7 : 0); }
  int nv() const { return static_cast<int>(bodies_.size()) + (floating_ ? 6 : 0); }
  bool floating() const { return floating_; }
  // d of Q = u − d⊙q̇, indexed like v (nv entries; the free joint's six are zero).
  const std::vector<S>& damping() const { return damping_; }
  // The coordinates' joint names (file order; the free joint is not named).
  const std::vector<std::string>& coordinate_names() const { return names_; }
  // λ(i): the body (coordinate) whose body carries joint i; −1 for the world (the root body when
  // floating). Joints are numbered 0… without the free joint.
  int parent(int i) const { return bodies_[static_cast<std::size_t>(i)].parent; }
  // The bodies in a topological order (each after its parent).
  const std::vector<int>& topological_order() const { return order_; }

  // q̇ = G(q) v: position rate v_world, quaternion rate ½ q ⊗ (0, ω), joint rates; q̇ = v when
  // the root is fixed.
  void configuration_rate(std::span<const S> q, std::span<const S> v, std::span<S> qdot) const {
    check_q(q.size());
    check_v(v.size());
    check_q(qdot.size());
    if (!floating_) {
      for (std::size_t i = 0; i < v.size(); ++i) qdot[i] = v[i];
      return;
    }
    const S h(0.5);
    const S w = q[3], x = q[4], y = q[5], z = q[6], a0 = v[3], a1 = v[4], a2 = v[5];
    for (int i = 0; i < 3; ++i) qdot[i] = v[i];
    qdot[3] = h * (-x * a0 - y * a1 - z * a2);
    qdot[4] = h * (w * a0 + y * a2 - z * a1);
    qdot[5] = h * (w * a1 + z * a0 - x * a2);
    qdot[6] = h * (w * a2 + x * a1 - y * a0);
    for (std::size_t i = 6; i < v.size(); ++i) qdot[i + 1] = v[i];
  }

  // CRBA (RBDA Table 6.2): M(q), nv×nv column-major (symmetric by construction).
  void mass_matrix(std::span<const S> q, std::span<S> M) {
    check_q(q.size());
    check_v(n2(M.size()));
    kinematics(q);
    const std::size_t n = bodies_.size(), N = n2(M.size()), o = N - n;
    // Composite inertias: each body's inertia plus its whole subtree's, in its own frame.
    composite_inertias();
    // M_ij = S_jᵀ (X-transported Ic_i S_i) for every ancestor j of i: the force needed at the
    // subtree of i to give it unit acceleration of joint i, seen by joint j. Entries between
    // bodies on different branches are zero. The free joint is every body's ancestor.
    for (std::size_t k = 0; k < N * N; ++k) M[k] = S(0.0);
    for (std::size_t i = 0; i < n; ++i) {
      Vec6 F = rbd::mul6(IA_[i], bodies_[i].s);
      M[o + i + N * (o + i)] = rbd::dot6(bodies_[i].s, F);
      std::size_t j = i;
      while (bodies_[j].parent >= 0) {
        F = rbd::force_to_parent(x_[j], F);
        j = static_cast<std::size_t>(bodies_[j].parent);
        M[o + i + N * (o + j)] = M[o + j + N * (o + i)] = rbd::dot6(bodies_[j].s, F);
      }
      if (!floating_) continue;
      const Vec6 t = free_force(rbd::force_to_parent(x_[j], F));
      for (std::size_t r = 0; r < 6; ++r) M[r + N * (o + i)] = M[o + i + N * r] = t[r];
    }
    if (!floating_) return;
    // S_0ᵀ Ic_0 S_0, column k from the root body's motion for v_free = e_k; mirrored so that M
    // is exactly symmetric.
    for (std::size_t k = 0; k < 6; ++k) {
      Vec6 e = rbd::zero6<S>();
      e[k] = S(1.0);
      const Vec6 t = free_force(rbd::mul6(root_IA_, free_motion(e.data())));
      for (std::size_t r = k; r < 6; ++r) M[r + N * k] = M[k + N * r] = t[r];
    }
  }

  // RNEA (RBDA Table 5.1): τ = M(q) q̈ + c(q, q̇) + ∂V/∂q, damping excluded. Gravity enters as
  // an upward acceleration g of the world (base) frame: a_0 = −a_g = (0, 0, 0; 0, 0, g).
  // Floating: q̇, q̈, τ read v, v̇, τ (nv entries).
  void inverse_dynamics(std::span<const S> q, std::span<const S> qd, std::span<const S> qdd,
                        std::span<S> tau) {
    check_q(q.size());
    check_v(qd.size(), qdd.size(), tau.size());
    rnea(q, qd.data(), qdd.data(), tau);
  }
  // c + ∂V/∂q = RNEA(q, q̇, 0).
  void bias_forces(std::span<const S> q, std::span<const S> qd, std::span<S> out) {
    check_q(q.size());
    check_v(qd.size(), out.size());
    rnea(q, qd.data(), nullptr, out);
  }
  // ∂V/∂q = RNEA(q, 0, 0) (floating: the generalized force conjugate to v).
  void gravity_forces(std::span<const S> q, std::span<S> out) {
    check_q(q.size());
    check_v(out.size());
    rnea(q, nullptr, nullptr, out);
  }

  // ABA (RBDA Table 7.1): q̈ under the generalized joint forces τ (no damping added).
  void articulated_body(std::span<const S> q, std::span<const S> qd, std::span<const S> tau,
                        std::span<S> qdd) {
    check_q(q.size());
    check_v(qd.size(), tau.size(), qdd.size());
    aba(q, qd, tau.data(), nullptr, qdd);
  }
  // Forward dynamics of the URDF model: q̈ for the inputs u, Q = u − d⊙q̇.
  void forward_dynamics(std::span<const S> q, std::span<const S> qd, std::span<const S> u,
                        std::span<S> qdd) {
    check_q(q.size());
    check_v(qd.size(), u.size(), qdd.size());
    aba(q, qd, u.data(), damping_.data(), qdd);
  }

  // T = ½ Σ v_iᵀ I_i v_i (body velocities from a forward pass).
  S kinetic_energy(std::span<const S> q, std::span<const S> qd) {
    check_q(q.size());
    check_v(qd.size());
    kinematics(q);
    const std::size_t o = offset_v();
    S T(0.0);
    if (floating_) {
      root_v_ = root_velocity(qd.data());
      T += rbd::dot6(root_v_, rbd::mul6(root_.inertia, root_v_));
    }
    for (const int ii : order_) {
      const auto i = static_cast<std::size_t>(ii);
      const Body& b = bodies_[i];
      v_[i] = joint_velocity(b, qd[o + i]);
      if (b.parent >= 0)
        v_[i] = rbd::add6(rbd::motion_to_body(x_[i], v_[static_cast<std::size_t>(b.parent)]), v_[i]);
      else if (floating_)
        v_[i] = rbd::add6(rbd::motion_to_body(x_[i], root_v_), v_[i]);
      T += rbd::dot6(v_[i], rbd::mul6(b.inertia, v_[i]));
    }
    return S(0.5) * T;
  }

  // V = g Σ m_i z_i (z_i: height of body i's mass centre in the world frame; the links fixed to
  // the world are left out, a constant).
  S potential_energy(std::span<const S> q) {
    check_q(q.size());
    kinematics(q);
    S V(0.0);
    if (floating_) {
      const Vec3 h = rbd::mul(root_pose_.R, root_.first_moment);
      V += root_.mass * root_pose_.p[2] + h[2];
    }
    for (const int ii : order_) {
      const auto i = static_cast<std::size_t>(ii);
      const Body& b = bodies_[i];
      world_[i] = b.parent >= 0 ? rbd::compose(world_[static_cast<std::size_t>(b.parent)], x_[i])
                  : floating_   ? rbd::compose(root_pose_, x_[i])
                                : x_[i];
      // m z_com = m p_z + (R · m c)_z
      const Vec3 h = rbd::mul(world_[i].R, b.first_moment);
      V += b.mass * world_[i].p[2] + h[2];
    }
    return g_ * V;
  }

  // ---- task space (docs/CONTRACT.md §2, "Frames") ---------------------------------------------
  // Links are named as in the file; every link has a frame: a link on a moving body sits at
  // body frame · fixed joint origins, the root link of a fixed robot (and any link welded to it)
  // at constant world placements. q (nq) and v (nv) as everywhere else (floating: the free joint's
  // v = (v_world, ω_root)). Arrays are caller-owned and column-major.

  // A link's index by its name; std::invalid_argument for a name the robot lacks.
  std::size_t link_of(const std::string& name) const {
    const auto it = link_index_.find(name);
    if (it == link_index_.end()) throw std::invalid_argument("recursive dynamics: unknown link " + name);
    return it->second;
  }

  // The link frame's origin (3, world) and rotation (3×3, columns = link axes in world axes).
  void frame_placement(const std::string& link, const S* q, S* position, S* rotation) {
    frame_placement(link_of(link), q, position, rotation);
  }
  // The same by the link's index (link_of: the lookup once, outside a timed loop).
  void frame_placement(std::size_t l, const S* q, S* position, S* rotation) {
    placement(q);
    const Pose f = link_world(l);
    for (std::size_t i = 0; i < 3; ++i) {
      position[i] = f.p[i];
      for (std::size_t j = 0; j < 3; ++j) rotation[i + 3 * j] = f.R[3 * i + j];
    }
  }

  // J (6×nv) with J v = (ẋ; ω) of the link frame, world axes (LOCAL_WORLD_ALIGNED). Column of a
  // joint on the path to the root: its motion subspace in world coordinates (^0X_i⁻¹ S_i, a
  // column of the tree's Jacobian, RBDA ch. 4), read at the frame origin x: ω stays, the point's
  // velocity is v_O + ω × x (v_O: the velocity of the body point at the world origin).
  void frame_jacobian(const std::string& link, const S* q, S* J) { frame_jacobian(link_of(link), q, J); }
  void frame_jacobian(std::size_t l, const S* q, S* J) {
    placement(q);
    const Vec3 x = link_world(l).p;
    const auto N = static_cast<std::size_t>(nv());
    for (std::size_t k = 0; k < 6 * N; ++k) J[k] = S(0.0);
    const auto put = [&](std::size_t col, const Vec6& s) {
      const Vec3 w = rbd::top(s), vx = rbd::add(rbd::bottom(s), rbd::cross(w, x));
      for (std::size_t r = 0; r < 3; ++r) {
        J[r + 6 * col] = vx[r];
        J[r + 3 + 6 * col] = w[r];
      }
    };
    const std::size_t o = offset_v();
    for (int b = link_body_[l]; b >= 0; b = bodies_[static_cast<std::size_t>(b)].parent) {
      const auto i = static_cast<std::size_t>(b);
      put(o + i, rbd::motion_to_parent(world_[i], bodies_[i].s));
    }
    if (!floating_) return;
    // The free joint: the root body's motion S_0 e_k (its own frame), carried to the world.
    for (std::size_t k = 0; k < 6; ++k) {
      S e[6] = {S(0.0), S(0.0), S(0.0), S(0.0), S(0.0), S(0.0)};
      e[k] = S(1.0);
      put(k, rbd::motion_to_parent(root_pose_, free_motion(e)));
    }
  }

  // a (6) = J̇ v = (ẍ; ω̇) at v̇ = 0, world axes: the classical acceleration of the frame origin
  // and the angular acceleration. The body's spatial acceleration a_b at v̇ = 0 comes from the
  // RNEA's forward pass without gravity (velocity-product terms only); a spatial acceleration is
  // not the classical acceleration of a point (RBDA ch. 2, spatial acceleration): at the frame
  // origin r (body coordinates) ẍ = (a_O + ω̇ × r) + ω × (v_O + ω × r). ω̇ in world axes is R ω̇_b
  // (the ω × ω of d/dt(R ω_b) vanishes).
  void frame_acceleration_bias(const std::string& link, const S* q, const S* v, S* a) {
    frame_acceleration_bias(link_of(link), q, v, a);
  }
  void frame_acceleration_bias(std::size_t l, const S* q, const S* v, S* a) {
    placement(q);
    velocity_pass(v);
    const int b = link_body_[l];
    const Vec6 vb = b >= 0 ? v_[static_cast<std::size_t>(b)] : floating_ ? root_v_ : rbd::zero6<S>();
    const Vec6 ab = b >= 0 ? a_[static_cast<std::size_t>(b)] : floating_ ? root_a_ : rbd::zero6<S>();
    const Vec3 r = link_in_body_[l].p;
    const Vec3 w = rbd::top(vb), wd = rbd::top(ab);
    const Vec3 vr = rbd::add(rbd::bottom(vb), rbd::cross(w, r));
    const Vec3 ar = rbd::add(rbd::add(rbd::bottom(ab), rbd::cross(wd, r)), rbd::cross(w, vr));
    const rbd::Mat3<S> R = body_world(b).R;
    const Vec3 lin = rbd::mul(R, ar), ang = rbd::mul(R, wd);
    for (std::size_t i = 0; i < 3; ++i) {
      a[i] = lin[i];
      a[i + 3] = ang[i];
    }
  }

  // The mass centre (3, world) of the links that move with q (first moments m·c of the bodies,
  // summed in world coordinates); throws std::invalid_argument when no moving link has mass.
  void center_of_mass(const S* q, S* com) {
    placement(q);
    const Vec3 c = mass_centre();
    for (std::size_t i = 0; i < 3; ++i) com[i] = c[i];
  }

  // ∂com/∂q (3×nv): the linear momentum per unit velocity over the total mass (P = m ċ).
  void center_of_mass_jacobian(const S* q, S* J) {
    placement(q);
    const S m = moving_mass();
    momentum_columns([&](std::size_t col, const Vec6& h) {
      for (std::size_t r = 0; r < 3; ++r) J[r + 3 * col] = h[r + 3] / m;
    });
  }

  // A_G (6×nv): A_G v = (linear momentum; angular momentum about the mass centre G), world axes.
  // From the world-frame momentum columns (n_O; f), n_O about the world origin: about G the
  // moment is n_G = n_O − G × f.
  void centroidal_momentum_matrix(const S* q, S* A) {
    placement(q);
    const Vec3 G = mass_centre();
    momentum_columns([&](std::size_t col, const Vec6& h) {
      const Vec3 f = rbd::bottom(h);
      const Vec3 n = rbd::add(rbd::top(h), rbd::cross(f, G));  // n_O − G × f
      for (std::size_t r = 0; r < 3; ++r) {
        A[r + 6 * col] = f[r];
        A[r + 3 + 6 * col] = n[r];
      }
    });
  }

 private:
  struct Body {
    int parent = -1;   // λ(i); −1: the world
    bool prismatic = false;
    Vec3 axis{};       // unit joint axis (joint frame = body frame at q = 0)
    Vec6 s{};          // motion subspace S in the body frame
    Pose tree;         // joint frame in the parent body's frame (X_T)
    Mat6 inertia{};    // spatial inertia about the body origin, body axes (merged links)
    S mass{};          // total mass and first moment m·c (potential energy)
    Vec3 first_moment{};
  };

  static std::size_t n2(std::size_t size) {  // the side of a square matrix of `size` entries
    std::size_t n = 0;
    while (n * n < size) ++n;
    return n * n == size ? n : std::size_t(-1);
  }
  void check_q(std::size_t size) const {
    if (size != static_cast<std::size_t>(nq()))
      throw std::invalid_argument("recursive dynamics: wrong size");
  }
  template <class... Sizes>
  void check_v(Sizes... sizes) const {
    for (const std::size_t s : {static_cast<std::size_t>(sizes)...})
      if (s != static_cast<std::size_t>(nv()))
        throw std::invalid_argument("recursive dynamics: wrong size");
  }
  // Where the joints start in q and in v.
  std::size_t offset_q() const { return floating_ ? 7 : 0; }
  std::size_t offset_v() const { return floating_ ? 6 : 0; }


  // kinematics, then world_[i]: every body's pose in the world (topological order).
  void placement(const S* q) {
    kinematics(std::span<const S>(q, static_cast<std::size_t>(nq())));
    for (const int ii : order_) {
      const auto i = static_cast<std::size_t>(ii);
      const int p = bodies_[i].parent;
      world_[i] = p >= 0    ? rbd::compose(world_[static_cast<std::size_t>(p)], x_[i])
                  : floating_ ? rbd::compose(root_pose_, x_[i])
                              : x_[i];
    }
  }
  // Body b's pose in the world (b = −1: the root body when floating, else the world itself).
  Pose body_world(int b) const {
    return b >= 0 ? world_[static_cast<std::size_t>(b)] : floating_ ? root_pose_ : Pose{};
  }
  Pose link_world(std::size_t l) const {
    return rbd::compose(body_world(link_body_[l]), link_in_body_[l]);
  }

  // After placement: body velocities v_[i] and accelerations a_[i] at v̇ = 0 without gravity,
  // a_i = X a_λ + v_i × S q̇ (RNEA's forward pass, RBDA Table 5.1). The root body (floating) at
  // v̇ = 0 (a_world = 0, ω̇_b = 0): d/dt [ω; Rᵀ v_world] = [0; −ω × Rᵀ v_world].
  void velocity_pass(const S* v) {
    const std::size_t o = offset_v();
    if (floating_) {
      root_v_ = free_motion(v);
      root_a_ = rbd::join(Vec3{S(0.0), S(0.0), S(0.0)}, rbd::cross(rbd::bottom(root_v_), rbd::top(root_v_)));
    }
    const Vec6 v0 = floating_ ? root_v_ : rbd::zero6<S>();
    const Vec6 a0 = floating_ ? root_a_ : rbd::zero6<S>();
    for (const int ii : order_) {
      const auto i = static_cast<std::size_t>(ii);
      const Body& b = bodies_[i];
      const Vec6 vJ = joint_velocity(b, v[o + i]);
      const Vec6 vp = b.parent < 0 ? v0 : v_[static_cast<std::size_t>(b.parent)];
      const Vec6 ap = b.parent < 0 ? a0 : a_[static_cast<std::size_t>(b.parent)];
      v_[i] = rbd::add6(rbd::motion_to_body(x_[i], vp), vJ);
      a_[i] = rbd::add6(rbd::motion_to_body(x_[i], ap), rbd::cross_motion(v_[i], vJ));
    }
  }

  // After placement: IA_[i] = the composite inertia of body i's subtree in its own frame;
  // root_IA_ = the whole robot's in the root frame (floating). As in mass_matrix (RBDA Table 6.2).
  void composite_inertias() {
    for (std::size_t i = 0; i < bodies_.size(); ++i) IA_[i] = bodies_[i].inertia;
    root_IA_ = root_.inertia;
    for (auto it = order_.rbegin(); it != order_.rend(); ++it) {
      const auto i = static_cast<std::size_t>(*it);
      const int p = bodies_[i].parent;
      if (p < 0 && !floating_) continue;
      const Mat6 Ip = rbd::inertia_to_parent(x_[i], IA_[i]);
      Mat6& Ic = p < 0 ? root_IA_ : IA_[static_cast<std::size_t>(p)];
      for (int k = 0; k < 36; ++k) Ic[k] += Ip[k];
    }
  }

  // After placement: put(k, h) for every velocity k, h = (n_O; f) the momentum (world axes, moment
  // about the world origin) of the moving links per unit v_k. Joint i's unit rate moves its
  // subtree rigidly: h = Ic_i S_i with Ic_i the CRBA's composite inertia (RBDA Table 6.2), carried
  // from body i's frame to the world. The free joint: the whole robot's composite inertia times
  // S_0 e_k, carried from the root frame.
  template <class Put>
  void momentum_columns(Put&& put) {
    composite_inertias();
    const std::size_t o = offset_v();
    for (std::size_t i = 0; i < bodies_.size(); ++i)
      put(o + i, rbd::force_to_parent(world_[i], rbd::mul6(IA_[i], bodies_[i].s)));
    if (!floating_) return;
    for (std::size_t k = 0; k < 6; ++k) {
      S e[6] = {S(0.0), S(0.0), S(0.0), S(0.0), S(0.0), S(0.0)};
      e[k] = S(1.0);
      put(k, rbd::force_to_parent(root_pose_, rbd::mul6(root_IA_, free_motion(e))));
    }
  }

  // The total mass of the moving links (the world body's links are not counted unless floating).
  S moving_mass() const {
    S m = floating_ ? root_.mass : S(0.0);
    for (const Body& b : bodies_) m += b.mass;
    if (!(m > S(0.0))) throw std::invalid_argument("recursive dynamics: no moving link has mass");
    return m;
  }
  // After placement: G = Σ (m p + R·m c) / Σ m over the moving bodies, world coordinates.
  Vec3 mass_centre() const {
    const S m = moving_mass();
    Vec3 h{S(0.0), S(0.0), S(0.0)};
    const auto add_body = [&](const Body& b, const Pose& x) {
      h = rbd::add(h, rbd::add(rbd::scale(b.mass, x.p), rbd::mul(x.R, b.first_moment)));
    };
    if (floating_) add_body(root_, root_pose_);
    for (std::size_t i = 0; i < bodies_.size(); ++i) add_body(bodies_[i], world_[i]);
    return rbd::scale(S(1.0) / m, h);
  }

  // x_[i]: body i's pose in its parent body for the configuration q: X_i = X_J(q_i) X_T.
  // root_pose_: the root body's pose in the world (floating only).
  void kinematics(std::span<const S> q) {
    const std::size_t o = offset_q();
    if (floating_) {
      root_pose_.R = rbd::quaternion_rotation(q[3], q[4], q[5], q[6]);
      root_pose_.p = Vec3{q[0], q[1], q[2]};
    }
    for (std::size_t i = 0; i < bodies_.size(); ++i) {
      const Body& b = bodies_[i];
      Pose joint;
      if (b.prismatic)
        joint.p = rbd::scale(q[o + i], b.axis);
      else
        joint.R = rbd::axis_angle(b.axis, q[o + i]);
      x_[i] = rbd::compose(b.tree, joint);
    }
  }

  static Vec6 joint_velocity(const Body& b, const S& qd) {
    Vec6 v;
    for (int k = 0; k < 6; ++k) v[k] = b.s[k] * qd;
    return v;
  }

  Vec6 base_acceleration() const { return {S(0.0), S(0.0), S(0.0), S(0.0), S(0.0), g_}; }

  // S_0 v_free = [ω; Rᵀ v_world]: the root body's velocity in its own frame (after kinematics).
  Vec6 free_motion(const S* v) const {
    return rbd::join(Vec3{v[3], v[4], v[5]}, rbd::mul_t(root_pose_.R, Vec3{v[0], v[1], v[2]}));
  }
  // S_0ᵀ f = [R f; n]: the free joint's generalized force for the root-frame force f = [n; f]
  // (power: (R f)·v_world + n·ω = f·(Rᵀ v_world) + n·ω).
  Vec6 free_force(const Vec6& f) const {
    return rbd::join(rbd::mul(root_pose_.R, rbd::bottom(f)), rbd::top(f));
  }
  Vec6 root_velocity(const S* v) const { return v ? free_motion(v) : rbd::zero6<S>(); }

  // qd, qdd: nullptr stands for zero.
  void rnea(std::span<const S> q, const S* qd, const S* qdd, std::span<S> tau) {
    kinematics(q);
    const S zero(0.0);
    const std::size_t o = offset_v();
    Vec6 a0 = base_acceleration();
    if (floating_) {
      // The root body's acceleration is d/dt of its velocity in its own frame:
      // [ω̇; Rᵀ a_world + Ṙᵀ v_world] with Ṙᵀ = −ω× Rᵀ; the world's upward g is added as in a0.
      root_v_ = root_velocity(qd);
      const Vec3 w = rbd::top(root_v_), vb = rbd::bottom(root_v_);
      const Vec3 aw = qdd ? Vec3{qdd[0], qdd[1], qdd[2] + g_} : Vec3{zero, zero, g_};
      const Vec3 wd = qdd ? Vec3{qdd[3], qdd[4], qdd[5]} : Vec3{zero, zero, zero};
      root_a_ = rbd::join(wd, rbd::add(rbd::mul_t(root_pose_.R, aw), rbd::cross(vb, w)));
      root_f_ = rbd::add6(rbd::mul6(root_.inertia, root_a_),
                          rbd::cross_force(root_v_, rbd::mul6(root_.inertia, root_v_)));
      a0 = root_a_;
    }
    const Vec6 v0 = floating_ ? root_v_ : rbd::zero6<S>();
    // Forward: velocities and accelerations outward, and the force each body needs.
    for (const int ii : order_) {
      const auto i = static_cast<std::size_t>(ii);
      const Body& b = bodies_[i];
      const Vec6 vJ = joint_velocity(b, qd ? qd[o + i] : zero);
      const Vec6 vp = b.parent < 0 ? v0 : v_[static_cast<std::size_t>(b.parent)];
      const Vec6 ap = b.parent < 0 ? a0 : a_[static_cast<std::size_t>(b.parent)];
      v_[i] = rbd::add6(rbd::motion_to_body(x_[i], vp), vJ);
      // a_i = X a_λ + S q̈ + v_i × S q̇ (S is constant in the body frame: no Ṡ term)
      a_[i] = rbd::add6(rbd::add6(rbd::motion_to_body(x_[i], ap), joint_velocity(b, qdd ? qdd[o + i] : zero)),
                        rbd::cross_motion(v_[i], vJ));
      // f_i = I a_i + v_i ×* I v_i (rate of change of the body's momentum)
      f_[i] = rbd::add6(rbd::mul6(b.inertia, a_[i]),
                        rbd::cross_force(v_[i], rbd::mul6(b.inertia, v_[i])));
    }
    // Backward: each joint transmits its subtree's force; τ_i = S_iᵀ f_i.
    for (auto it = order_.rbegin(); it != order_.rend(); ++it) {
      const auto i = static_cast<std::size_t>(*it);
      const Body& b = bodies_[i];
      tau[o + i] = rbd::dot6(b.s, f_[i]);
      if (b.parent >= 0) {
        const auto p = static_cast<std::size_t>(b.parent);
        f_[p] = rbd::add6(f_[p], rbd::force_to_parent(x_[i], f_[i]));
      } else if (floating_) {
        root_f_ = rbd::add6(root_f_, rbd::force_to_parent(x_[i], f_[i]));
      }
    }
    if (floating_) {
      const Vec6 t = free_force(root_f_);
      for (std::size_t r = 0; r < 6; ++r) tau[r] = t[r];
    }
  }

  // τ_i = u_i − d_i q̇_i (d = nullptr: τ = u).
  void aba(std::span<const S> q, std::span<const S> qd, const S* u, const S* d, std::span<S> qdd) {
    kinematics(q);
    const std::size_t o = offset_v();
    // Pass 1 (outward): velocities, velocity-product accelerations c_i, and the bias forces
    // pA_i = v_i ×* I_i v_i; articulated inertias start as the rigid ones. The root body's
    // velocity is its own (free) joint velocity, in its own frame: no c term there.
    if (floating_) {
      root_v_ = root_velocity(qd.data());
      root_IA_ = root_.inertia;
      root_f_ = rbd::cross_force(root_v_, rbd::mul6(root_.inertia, root_v_));
    }
    const Vec6 v0 = floating_ ? root_v_ : rbd::zero6<S>();
    for (const int ii : order_) {
      const auto i = static_cast<std::size_t>(ii);
      const Body& b = bodies_[i];
      const Vec6 vJ = joint_velocity(b, qd[o + i]);
      const Vec6 vp = b.parent < 0 ? v0 : v_[static_cast<std::size_t>(b.parent)];
      v_[i] = rbd::add6(rbd::motion_to_body(x_[i], vp), vJ);
      c_[i] = rbd::cross_motion(v_[i], vJ);
      IA_[i] = b.inertia;
      f_[i] = rbd::cross_force(v_[i], rbd::mul6(b.inertia, v_[i]));  // pA_i
    }
    // Pass 2 (inward): articulated inertias and bias forces; the joint's free direction is
    // eliminated (U = IA S, D = Sᵀ U, u = τ − Sᵀ pA) before passing them to the parent.
    for (auto it = order_.rbegin(); it != order_.rend(); ++it) {
      const auto i = static_cast<std::size_t>(*it);
      const Body& b = bodies_[i];
      U_[i] = rbd::mul6(IA_[i], b.s);
      D_[i] = rbd::dot6(b.s, U_[i]);
      const S tau = d ? u[o + i] - d[o + i] * qd[o + i] : u[o + i];
      u_[i] = tau - rbd::dot6(b.s, f_[i]);
      if (b.parent < 0 && !floating_) continue;
      Mat6 Ia = IA_[i];
      for (int r = 0; r < 6; ++r)
        for (int s = 0; s < 6; ++s) Ia[6 * r + s] -= U_[i][r] * U_[i][s] / D_[i];
      Vec6 pa = rbd::add6(f_[i], rbd::mul6(Ia, c_[i]));
      for (int r = 0; r < 6; ++r) pa[r] += U_[i][r] * u_[i] / D_[i];
      const Mat6 Ip = rbd::inertia_to_parent(x_[i], Ia);
      if (b.parent < 0) {
        for (int k = 0; k < 36; ++k) root_IA_[k] += Ip[k];
        root_f_ = rbd::add6(root_f_, rbd::force_to_parent(x_[i], pa));
        continue;
      }
      const auto p = static_cast<std::size_t>(b.parent);
      for (int k = 0; k < 36; ++k) IA_[p][k] += Ip[k];
      f_[p] = rbd::add6(f_[p], rbd::force_to_parent(x_[i], pa));
    }
    // The root (floating): its six directions are all free, so IA_0 a_0 = f_0 − pA_0 with
    // f_0 = [n; Rᵀ F_world] the applied free-joint force in the root frame. a_0 comes out with
    // the world's upward g in it (as every a_i); the free v̇ takes it out again and undoes the
    // velocity term of the root's acceleration: a_world = R (a_lin − Rᵀ g e_z + ω × Rᵀ v_world).
    Vec6 a0 = base_acceleration();
    if (floating_) {
      const Vec6 f0 = rbd::join(Vec3{u[3], u[4], u[5]}, rbd::mul_t(root_pose_.R, Vec3{u[0], u[1], u[2]}));
      Vec6 rhs;
      for (int r = 0; r < 6; ++r) rhs[r] = f0[r] - root_f_[r];
      root_a_ = rbd::solve6(root_IA_, rhs);
      const Vec3 w = rbd::top(root_v_), vb = rbd::bottom(root_v_);
      const Vec3 lin = rbd::add(rbd::bottom(root_a_), rbd::cross(w, vb));
      const Vec3 aw = rbd::mul(root_pose_.R, lin);
      qdd[0] = aw[0];
      qdd[1] = aw[1];
      qdd[2] = aw[2] - g_;
      qdd[3] = root_a_[0];
      qdd[4] = root_a_[1];
      qdd[5] = root_a_[2];
      a0 = root_a_;
    }
    // Pass 3 (outward): accelerations, starting from the base's −a_g (or the root's).
    for (const int ii : order_) {
      const auto i = static_cast<std::size_t>(ii);
      const Body& b = bodies_[i];
      const Vec6 ap = b.parent < 0 ? a0 : a_[static_cast<std::size_t>(b.parent)];
      const Vec6 a = rbd::add6(rbd::motion_to_body(x_[i], ap), c_[i]);
      qdd[o + i] = (u_[i] - rbd::dot6(U_[i], a)) / D_[i];
      a_[i] = rbd::add6(a, joint_velocity(b, qdd[o + i]));
    }
  }

  S g_;
  bool floating_;
  std::vector<Body> bodies_;        // coordinate order
  Body root_;                       // floating: the root body (its inertia, mass, first moment)
  std::vector<int> order_;          // topological order
  std::vector<S> damping_;
  std::vector<std::string> names_;
  std::map<std::string, std::size_t> link_index_;  // every link by name
  std::vector<int> link_body_;      // the body each link belongs to (−1: the world / root body)
  std::vector<Pose> link_in_body_;  // each link's frame in its body's frame
  // workspace
  std::vector<Pose> x_, world_;
  std::vector<Vec6> v_, a_, f_, c_, U_;
  std::vector<S> D_, u_;
  std::vector<Mat6> IA_;
  Pose root_pose_;                  // floating: the root body's pose in the world
  Vec6 root_v_{}, root_a_{}, root_f_{};
  Mat6 root_IA_{};
};

}  // namespace eomtest
