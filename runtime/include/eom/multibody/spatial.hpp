// Rotations and rigid transforms for the spatial body form, templated on the scalar so that a
// model's kinematics run with double, the AD numbers and the recording scalar alike.
//
// Conventions (the same as eom::SpatialBody and URDF):
//   - a rotation R maps body (child) coordinates to world (parent) coordinates, v_world = R v_body;
//   - Rot3 stores it column-major: R(i, j) = r[i + 3 j];
//   - rot_x/rot_y/rot_z(a) turn by a about the fixed axis, counter-clockwise seen from its tip;
//   - rpy(roll, pitch, yaw) = Rz(yaw)·Ry(pitch)·Rx(roll): URDF's roll-pitch-yaw about fixed axes;
//   - quaternion(w, x, y, z) expects a unit quaternion, scalar part first;
//   - Transform{R, t} maps x to R x + t; a · b applies b first, so a chain of joints reads
//       frame_k = frame_{k-1} * origin(xyz, rpy) * revolute(axis, q[k]);
//   - rigid_body(frame, mass, inertia[, inertial]) places a body whose mass centre and inertia
//     axes are given by `inertial` in `frame` (URDF's <inertial><origin>).
// Axes given as numbers are normalized in double; an exact coordinate axis (±x, ±y, ±z) takes the
// elementary rotation, so a traced model records no products by 0 or 1.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "eom/model/model.hpp"

namespace eom {

template <class S> using Vec3 = std::array<S, 3>;
template <class S> using Rot3 = std::array<S, 9>;  // column-major

template <class S> Rot3<S> identity_rotation() {
  return {S(1), S(0), S(0), S(0), S(1), S(0), S(0), S(0), S(1)};
}

namespace detail {
// The elementary rotations from the cosine and sine of their angle (one layout each).
template <class S> Rot3<S> rot_x_cs(const S& c, const S& s) {
  return {S(1), S(0), S(0), S(0), c, s, S(0), -s, c};
}
template <class S> Rot3<S> rot_y_cs(const S& c, const S& s) {
  return {c, S(0), -s, S(0), S(1), S(0), s, S(0), c};
}
template <class S> Rot3<S> rot_z_cs(const S& c, const S& s) {
  return {c, s, S(0), -s, c, S(0), S(0), S(0), S(1)};
}
}  // namespace detail

template <class S> Rot3<S> rot_x(const S& a) {
  using std::cos, std::sin;
  const S c = cos(a), s = sin(a);  // in this order: a traced model records cos first
  return detail::rot_x_cs<S>(c, s);
}
template <class S> Rot3<S> rot_y(const S& a) {
  using std::cos, std::sin;
  const S c = cos(a), s = sin(a);  // in this order: a traced model records cos first
  return detail::rot_y_cs<S>(c, s);
}
template <class S> Rot3<S> rot_z(const S& a) {
  using std::cos, std::sin;
  const S c = cos(a), s = sin(a);  // in this order: a traced model records cos first
  return detail::rot_z_cs<S>(c, s);
}

// A·B for column-major 3×3 matrices.
template <class S> Rot3<S> multiply(const Rot3<S>& a, const Rot3<S>& b) {
  Rot3<S> r;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i)
      r[i + 3 * j] = a[i] * b[3 * j] + a[i + 3] * b[3 * j + 1] + a[i + 6] * b[3 * j + 2];
  return r;
}
template <class S> Rot3<S> transpose(const Rot3<S>& a) {
  return {a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8]};
}
// R·v.
template <class S> Vec3<S> rotate(const Rot3<S>& r, const Vec3<S>& v) {
  return {r[0] * v[0] + r[3] * v[1] + r[6] * v[2], r[1] * v[0] + r[4] * v[1] + r[7] * v[2],
          r[2] * v[0] + r[5] * v[1] + r[8] * v[2]};
}

// URDF's roll-pitch-yaw: Rz(yaw)·Ry(pitch)·Rx(roll).
template <class S> Rot3<S> rpy(const S& roll, const S& pitch, const S& yaw) {
  return multiply(rot_z(yaw), multiply(rot_y(pitch), rot_x(roll)));
}

// The unit quaternion w + x i + y j + z k as a rotation matrix.
template <class S> Rot3<S> quaternion(const S& w, const S& x, const S& y, const S& z) {
  const S xx = x * x, yy = y * y, zz = z * z, xy = x * y, xz = x * z, yz = y * z;
  const S wx = w * x, wy = w * y, wz = w * z;
  return {1.0 - 2.0 * (yy + zz), 2.0 * (xy + wz),       2.0 * (xz - wy),
          2.0 * (xy - wz),       1.0 - 2.0 * (xx + zz), 2.0 * (yz + wx),
          2.0 * (xz + wy),       2.0 * (yz - wx),       1.0 - 2.0 * (xx + yy)};
}

namespace detail {
// The unit vector along `axis` (not zero), and k with axis = ±e_k when it is a coordinate axis.
struct UnitAxis {
  std::array<double, 3> u{};
  int coordinate = -1;  // 0, 1, 2 for ±x, ±y, ±z; −1 otherwise
  double sign = 1.0;
};
inline UnitAxis unit_axis(const std::array<double, 3>& axis) {
  const double n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  UnitAxis a;
  for (int i = 0; i < 3; ++i) a.u[i] = axis[i] / n;
  for (int k = 0; k < 3; ++k)
    if (axis[(k + 1) % 3] == 0.0 && axis[(k + 2) % 3] == 0.0 && axis[k] != 0.0) {
      a.coordinate = k;
      a.sign = axis[k] > 0 ? 1.0 : -1.0;
      a.u = {0.0, 0.0, 0.0};
      a.u[k] = a.sign;
    }
  return a;
}
}  // namespace detail

// Rotation by `angle` about `axis` (any non-zero length; normalized here), Rodrigues' formula
// R = c·1 + s·[a]× + (1 − c)·a aᵀ.
template <class S> Rot3<S> axis_angle(const std::array<double, 3>& axis, const S& angle) {
  using std::cos, std::sin;
  const detail::UnitAxis a = detail::unit_axis(axis);
  switch (a.coordinate) {
    case 0: return rot_x<S>(a.sign * angle);
    case 1: return rot_y<S>(a.sign * angle);
    case 2: return rot_z<S>(a.sign * angle);
    default: break;
  }
  const S c = cos(angle), s = sin(angle), v = 1.0 - c;
  const auto& u = a.u;
  return {c + v * (u[0] * u[0]),     v * (u[0] * u[1]) + s * u[2], v * (u[0] * u[2]) - s * u[1],
          v * (u[0] * u[1]) - s * u[2], c + v * (u[1] * u[1]),     v * (u[1] * u[2]) + s * u[0],
          v * (u[0] * u[2]) + s * u[1], v * (u[1] * u[2]) - s * u[0], c + v * (u[2] * u[2])};
}

// A rigid transform x ↦ R x + t (a frame's pose in its parent).
template <class S> struct Transform {
  Rot3<S> rotation = identity_rotation<S>();
  Vec3<S> translation{S(0), S(0), S(0)};

  // The point x of this frame in the parent frame.
  Vec3<S> apply(const Vec3<S>& x) const {
    const Vec3<S> r = rotate(rotation, x);
    return {r[0] + translation[0], r[1] + translation[1], r[2] + translation[2]};
  }
  // a * b: first b, then a.
  friend Transform operator*(const Transform& a, const Transform& b) {
    return {multiply(a.rotation, b.rotation), a.apply(b.translation)};
  }
};

namespace detail {
// cos and sin of a constant angle, exact at the multiples of a quarter turn: a file's
// 1.570796326794897 is a quarter turn, whose cosine is 0, not the 2e-16 of the rounded number
// (which would also make every product with it an operation in generated code).
inline std::array<double, 2> cos_sin(double a) {
  const double quarter = std::numbers::pi / 2;
  const double k = std::nearbyint(a / quarter);
  if (std::abs(a - k * quarter) <= 1e-15 * std::max(1.0, std::abs(a))) {
    static constexpr double c[4] = {1, 0, -1, 0}, s[4] = {0, 1, 0, -1};
    const int i = static_cast<int>(std::fmod(std::fmod(k, 4.0) + 4.0, 4.0));
    return {c[i], s[i]};
  }
  return {std::cos(a), std::sin(a)};
}
}  // namespace detail

// rpy(roll, pitch, yaw) of constant angles, computed once in double with the quarter turns exact
// (detail::cos_sin): the rotations a robot description states.
template <class S> Rot3<S> constant_rpy(const std::array<double, 3>& roll_pitch_yaw) {
  const auto& a = roll_pitch_yaw;
  if (a[0] == 0.0 && a[1] == 0.0 && a[2] == 0.0) return identity_rotation<S>();
  const auto [cr, sr] = detail::cos_sin(a[0]);
  const auto [cp, sp] = detail::cos_sin(a[1]);
  const auto [cy, sy] = detail::cos_sin(a[2]);
  const Rot3<double> r = multiply(detail::rot_z_cs(cy, sy),
                                  multiply(detail::rot_y_cs(cp, sp), detail::rot_x_cs(cr, sr)));
  Rot3<S> out;
  for (int i = 0; i < 9; ++i) out[i] = S(r[i]);
  return out;
}

// URDF's <origin xyz rpy>: translation xyz, rotation constant_rpy(rpy).
template <class S>
Transform<S> origin(const std::array<double, 3>& xyz, const std::array<double, 3>& roll_pitch_yaw) {
  return {constant_rpy<S>(roll_pitch_yaw), {S(xyz[0]), S(xyz[1]), S(xyz[2])}};
}
// A translation by xyz (values or traced expressions).
template <class S> Transform<S> translation(const Vec3<S>& xyz) {
  Transform<S> t;
  t.translation = xyz;
  return t;
}
// A pure rotation.
template <class S> Transform<S> rotation(const Rot3<S>& r) { return {r, {S(0), S(0), S(0)}}; }
// A revolute joint's motion: rotation by q about `axis`.
template <class S> Transform<S> revolute(const std::array<double, 3>& axis, const S& q) {
  return rotation(axis_angle<S>(axis, q));
}
// A prismatic joint's motion: translation by q along the unit `axis`.
template <class S> Transform<S> prismatic(const std::array<double, 3>& axis, const S& q) {
  const auto u = detail::unit_axis(axis).u;
  return translation<S>({u[0] * q, u[1] * q, u[2] * q});
}

// The body whose mass centre and inertia axes sit at `inertial` in `frame`; inertia about the mass
// centre in those axes (Ixx, Iyy, Izz, Ixy, Ixz, Iyz, tensor entries).
template <class S>
SpatialBody<S> rigid_body(const Transform<S>& frame, const S& mass, const std::array<S, 6>& inertia,
                          const Transform<S>& inertial = {}) {
  const Transform<S> com = frame * inertial;
  return {mass, inertia, com.translation, com.rotation};
}

// V = Σ mᵢ g zᵢ: uniform gravity g along −z of the world frame.
template <class S> S gravity_potential(In<SpatialBody<S>> bodies, const S& g) {
  S v(0);
  for (const auto& b : bodies) v = v + b.mass * b.position[2];
  return g * v;
}

}  // namespace eom
