// A 3D double pendulum on two universal joints, the whole mechanism tilted by a constant
// rotation R0. Two forms of the same model:
//
//   UniversalPendulum        the body form, built from the helpers of <eom/multibody/spatial.hpp>:
//                            R0 = quaternion(0.4, 0.2, 0.4, 0.8) (120.7° about (1, 2, 4)/√21),
//                            each joint two revolutes about the general (non-coordinate) axes
//                            u = R0 e_x = (−0.6, 0.8, 0) and v = R0 e_y = (−0.48, −0.36, 0.8)
//                            (axis_angle's Rodrigues branch), frames chained with Transform,
//                            the bodies placed with rigid_body and an inertial frame {R0, R0 r};
//   UniversalPendulumEnergy  the energy form, derived by hand without the helpers (below).
//
// Untilted kinematics (R0 = 1): body 1 turns by R1 = Rx(a1)·Ry(b1) about the pivot at the
// origin, its mass centre at R1 r1; joint 2 sits at R1 d1, d1 = (0, 0, −L1); body 2 turns by
// R2 = R1·Q, Q = Rx(a2)·Ry(b2), its mass centre at R1 (d1 + Q r2). r1, r2 are general offsets and
// J1, J2 full (non-diagonal) inertia tensors about the mass centres in body axes.
// Tilting by R0 (u = R0 e_x, v = R0 e_y, so axis_angle(u, a) = R0 Rx(a) R0ᵀ) maps every position
// x to R0 x and every body rotation R to R0 R (the body's inertia axes are R0 in the joint frame),
// which leaves every speed and every body-axes angular velocity unchanged: T is that of the
// untilted mechanism and only V = g Σ mᵢ (R0 xᵢ)_z sees the tilt.
//
// Hand derivation of T (body-axes angular velocities from the joint rates; velocities of body
// points as ω × r, never a derivative of a position):
//   R = Rx(a)·Ry(b) gives RᵀṘ = Ry(b)ᵀ[e_x]× Ry(b) ȧ + [e_y]× ḃ, so ω = ȧ Ry(b)ᵀe_x + ḃ e_y
//     = (ȧ cos b, ḃ, ȧ sin b);
//   ω1 = (ȧ1 cos b1, ḃ1, ȧ1 sin b1),  ω2 = Qᵀ ω1 + (ȧ2 cos b2, ḃ2, ȧ2 sin b2);
//   v1 = R1 (ω1 × r1),  v2 = R1 (ω1 × d1 + Q (ω2 × r2));
//   T = ½ m1 |ω1 × r1|² + ½ ω1ᵀJ1ω1 + ½ m2 |ω1 × d1 + Q(ω2 × r2)|² + ½ ω2ᵀJ2ω2,
// with Q = Rx(a)Ry(b) = [[cb, 0, sb], [sa sb, ca, −sa cb], [−ca sb, sa, ca cb]] written out.
#pragma once

#include <array>
#include <cmath>

#include <eom/model/model.hpp>
#include <eom/multibody/spatial.hpp>

namespace spatial_test {

struct UniversalPendulumNames {
  static constexpr std::array coordinates{"a1", "b1", "a2", "b2"};
  static constexpr std::array parameters{
      "m1",    "m2",    "L1",    "r1x",   "r1y",   "r1z",   "r2x",   "r2y",
      "r2z",   "J1xx",  "J1yy",  "J1zz",  "J1xy",  "J1xz",  "J1yz",  "J2xx",
      "J2yy",  "J2zz",  "J2xy",  "J2xz",  "J2yz",  "g"};
  static constexpr std::array parameter_values{
      1.5,   0.8,  0.6,   0.02,  -0.01, -0.3,   0.01,  0.03,
      -0.25, 0.05, 0.06,  0.03,  0.005, -0.004, 0.003, 0.04,
      0.035, 0.02, -0.003, 0.002, 0.004, 9.81};
  // The tilt R0 as a literal (column-major), the rotation of the unit quaternion
  // (w, x, y, z) = (0.4, 0.2, 0.4, 0.8): its entries are multiples of 0.04.
  static constexpr std::array<double, 9> R0{-0.6, 0.8, 0.0, -0.48, -0.36, 0.8, 0.64, 0.48, 0.6};
};

struct UniversalPendulum : UniversalPendulumNames {
  static constexpr int body_count = 2;

  template <class S>
  static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {
    const eom::Rot3<double> tilt = eom::quaternion<double>(0.4, 0.2, 0.4, 0.8);
    const std::array<double, 3> u{tilt[0], tilt[1], tilt[2]};  // R0 e_x
    const std::array<double, 3> v{tilt[3], tilt[4], tilt[5]};  // R0 e_y
    const eom::Rot3<S> R0 = eom::quaternion<S>(S(0.4), S(0.2), S(0.4), S(0.8));
    const S &m1 = p[0], &m2 = p[1], &L1 = p[2];
    const eom::Vec3<S> r1{p[3], p[4], p[5]}, r2{p[6], p[7], p[8]}, d1{S(0), S(0), -L1};
    const std::array<S, 6> J1{p[9], p[10], p[11], p[12], p[13], p[14]};
    const std::array<S, 6> J2{p[15], p[16], p[17], p[18], p[19], p[20]};

    using T = eom::Transform<S>;
    const T frame1 = eom::revolute<S>(u, q[0]) * eom::revolute<S>(v, q[1]);
    const T frame2 = frame1 * eom::translation<S>(eom::rotate(R0, d1)) * eom::revolute<S>(u, q[2]) *
                     eom::revolute<S>(v, q[3]);
    b[0] = eom::rigid_body<S>(frame1, m1, J1, T{R0, eom::rotate(R0, r1)});
    b[1] = eom::rigid_body<S>(frame2, m2, J2, T{R0, eom::rotate(R0, r2)});
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    std::array<eom::SpatialBody<S>, body_count> b;
    bodies<S>(q, p, b);
    return eom::gravity_potential<S>(b, p[21]);
  }
};

namespace hand {
template <class S> using V3 = std::array<S, 3>;
template <class S> V3<S> cross(const V3<S>& a, const V3<S>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
template <class S> S dot(const V3<S>& a, const V3<S>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
// Rx(a)·Ry(b), row by row: Q[i][j].
template <class S> std::array<V3<S>, 3> rx_ry(const S& a, const S& b) {
  using std::cos, std::sin;
  const S ca = cos(a), sa = sin(a), cb = cos(b), sb = sin(b);
  return {{{cb, S(0), sb}, {sa * sb, ca, -sa * cb}, {-ca * sb, sa, ca * cb}}};
}
template <class S> V3<S> times(const std::array<V3<S>, 3>& Q, const V3<S>& x) {
  return {dot(Q[0], x), dot(Q[1], x), dot(Q[2], x)};
}
template <class S> V3<S> transpose_times(const std::array<V3<S>, 3>& Q, const V3<S>& x) {
  return {Q[0][0] * x[0] + Q[1][0] * x[1] + Q[2][0] * x[2],
          Q[0][1] * x[0] + Q[1][1] * x[1] + Q[2][1] * x[2],
          Q[0][2] * x[0] + Q[1][2] * x[1] + Q[2][2] * x[2]};
}
// ωᵀJω for J = (Jxx, Jyy, Jzz, Jxy, Jxz, Jyz).
template <class S> S quadratic(const S* J, const V3<S>& w) {
  return J[0] * w[0] * w[0] + J[1] * w[1] * w[1] + J[2] * w[2] * w[2] +
         2.0 * (J[3] * w[0] * w[1] + J[4] * w[0] * w[2] + J[5] * w[1] * w[2]);
}
}  // namespace hand

struct UniversalPendulumEnergy : UniversalPendulumNames {
  template <class S> static S kinetic_energy(eom::In<S> q, eom::In<S> qd, eom::In<S> p) {
    using namespace hand;
    using std::cos, std::sin;
    const S &m1 = p[0], &m2 = p[1], &L1 = p[2];
    const V3<S> r1{p[3], p[4], p[5]}, r2{p[6], p[7], p[8]}, d1{S(0), S(0), -L1};
    const V3<S> w1{qd[0] * cos(q[1]), qd[1], qd[0] * sin(q[1])};
    const auto Q = rx_ry(q[2], q[3]);
    const V3<S> relative{qd[2] * cos(q[3]), qd[3], qd[2] * sin(q[3])};
    const V3<S> w1_in_2 = transpose_times(Q, w1);
    const V3<S> w2{w1_in_2[0] + relative[0], w1_in_2[1] + relative[1], w1_in_2[2] + relative[2]};
    const V3<S> v1 = cross(w1, r1);
    const V3<S> joint = cross(w1, d1), arm = times(Q, cross(w2, r2));
    const V3<S> v2{joint[0] + arm[0], joint[1] + arm[1], joint[2] + arm[2]};
    return 0.5 * (m1 * dot(v1, v1) + quadratic(p.data() + 9, w1) + m2 * dot(v2, v2) +
                  quadratic(p.data() + 15, w2));
  }
  // V = g Σ mᵢ (R0 xᵢ)_z: only the third row of the literal R0, (0, 0.8, 0.6).
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    using namespace hand;
    const S &m1 = p[0], &m2 = p[1], &L1 = p[2], &g = p[21];
    const V3<S> r1{p[3], p[4], p[5]}, r2{p[6], p[7], p[8]};
    const auto R1 = rx_ry(q[0], q[1]), Q = rx_ry(q[2], q[3]);
    const V3<S> x1 = times(R1, r1);
    const V3<S> Qr2 = times(Q, r2);
    const V3<S> x2 = times(R1, V3<S>{Qr2[0], Qr2[1], Qr2[2] - L1});
    const V3<S> up{S(R0[2]), S(R0[5]), S(R0[8])};
    return g * (m1 * dot(up, x1) + m2 * dot(up, x2));
  }
};

}  // namespace spatial_test
