// The free joint (docs/CONTRACT.md §1): a model with `static constexpr bool floating_base = true`
// flies free. Its first 7 coordinates place the root and its first 6 velocities move it:
//
//   q = [x, y, z, qw, qx, qy, qz, ...]   root origin in the world; unit quaternion (root axes → world)
//   v = [vx, vy, vz, ωx, ωy, ωz, ...]    ẋ, ẏ, ż in world axes; angular velocity in root axes
//   q̇ = G(q) v:  position rate v[0..3),  quaternion rate ½ q ⊗ (0, ω),  the rest q̇ᵢ₊₁ = vᵢ
//
// so nq = nv + 1. The generalized forces conjugate to v are a force in world axes, a moment in
// root axes, then the joints'. A model without a free joint has nq == nv and q̇ = v: every
// function here is then the identity or a copy. Everything is templated on the scalar: the
// tracer, the AD reference and the integrators use the same G.
#pragma once

#include <array>
#include <cmath>

namespace eom {

inline constexpr int free_joint_nq = 7, free_joint_nv = 6;

// Whether a model of nq coordinates and nv velocities has a free joint.
constexpr bool has_free_joint(int nq, int nv) { return nq == nv + 1; }

// q ⊗ (0, a): a quaternion (scalar first) times a pure quaternion.
template <class S> std::array<S, 4> times_pure(const S* q, const S* a) {
  return {-(q[1] * a[0] + q[2] * a[1] + q[3] * a[2]), q[0] * a[0] + q[2] * a[2] - q[3] * a[1],
          q[0] * a[1] + q[3] * a[0] - q[1] * a[2], q[0] * a[2] + q[1] * a[1] - q[2] * a[0]};
}

// q̇ = G(q) v (nq entries).
template <class S> void configuration_rate(int nq, int nv, const S* q, const S* v, S* qdot) {
  if (!has_free_joint(nq, nv)) {
    for (int i = 0; i < nq; ++i) qdot[i] = v[i];
    return;
  }
  for (int i = 0; i < 3; ++i) qdot[i] = v[i];
  const std::array<S, 4> r = times_pure(q + 3, v + 3);
  for (int i = 0; i < 4; ++i) qdot[3 + i] = 0.5 * r[i];
  for (int i = free_joint_nv; i < nv; ++i) qdot[i + 1] = v[i];
}

// Column j of G(q): the configuration rate of the unit velocity e_j (nq entries).
template <class S> void configuration_direction(int nq, int nv, const S* q, int j, S* out) {
  for (int i = 0; i < nq; ++i) out[i] = S(0);
  const bool free = has_free_joint(nq, nv);
  if (!free || j < 3 || j >= free_joint_nv) {  // a coordinate of its own: x, y, z or a joint's
    out[free && j >= free_joint_nv ? j + 1 : j] = S(1);
    return;
  }
  std::array<S, 3> e{S(0), S(0), S(0)};
  e[j - 3] = S(1);
  const std::array<S, 4> r = times_pure(q + 3, e.data());
  for (int i = 0; i < 4; ++i) out[3 + i] = 0.5 * r[i];
}

// Gᵀ g: a gradient over q (nq) as the generalized force conjugate to v (nv), e.g. ∂V/∂q.
template <class S> void tangent_gradient(int nq, int nv, const S* q, const S* g, S* out) {
  if (!has_free_joint(nq, nv)) {
    for (int i = 0; i < nv; ++i) out[i] = g[i];
    return;
  }
  for (int i = 0; i < 3; ++i) out[i] = g[i];
  std::array<S, 4> column;
  for (int j = 0; j < 3; ++j) {  // ½ (q ⊗ e_j) · g_quaternion
    std::array<S, 3> e{S(0), S(0), S(0)};
    e[j] = S(1);
    column = times_pure(q + 3, e.data());
    out[3 + j] = 0.5 * (column[0] * g[3] + column[1] * g[4] + column[2] * g[5] + column[3] * g[6]);
  }
  for (int i = free_joint_nv; i < nv; ++i) out[i] = g[i + 1];
}

// Ġ v = d/dt(G(q)) v along q̇ = G(q) v at constant v (nq entries): the configuration's
// acceleration when v̇ = 0, ½ q̇ ⊗ (0, ω) for the quaternion, 0 elsewhere.
template <class S> void configuration_rate_bias(int nq, int nv, const S* q, const S* v, S* out) {
  for (int i = 0; i < nq; ++i) out[i] = S(0);
  if (!has_free_joint(nq, nv)) return;
  std::array<S, 4> rate = times_pure(q + 3, v + 3);  // 2 × the quaternion's rate
  for (S& x : rate) x = 0.5 * x;
  const std::array<S, 4> r = times_pure(rate.data(), v + 3);
  for (int i = 0; i < 4; ++i) out[3 + i] = 0.5 * r[i];
}

// |‖quaternion‖ − 1| of a configuration (0 without a free joint).
template <class S> S quaternion_norm_error(int nq, int nv, const S* q) {
  using std::abs, std::sqrt;
  if (!has_free_joint(nq, nv)) return S(0);
  return abs(sqrt(q[3] * q[3] + q[4] * q[4] + q[5] * q[5] + q[6] * q[6]) - S(1));
}

// Puts the quaternion back on the unit sphere; false (q unchanged) when its norm is 0 or not
// finite.
template <class S> bool normalize_configuration(int nq, int nv, S* q) {
  using std::sqrt;
  if (!has_free_joint(nq, nv)) return true;
  const S n = sqrt(q[3] * q[3] + q[4] * q[4] + q[5] * q[5] + q[6] * q[6]);
  if (!(n > S(0)) || !(n < S(1e300))) return false;  // also false for NaN
  for (int i = 3; i < 7; ++i) q[i] = q[i] / n;
  return true;
}

// q ⊕ h v: the configuration reached by moving with constant v for a time h, on the group:
// x + h v_lin, q ⊗ exp(h ω / 2) (exact for a constant body rate), joints + h v. out may alias q.
template <class S> void integrate_configuration(int nq, int nv, const S* q, const S* v, S h, S* out) {
  using std::cos, std::sin, std::sqrt;
  if (!has_free_joint(nq, nv)) {
    for (int i = 0; i < nq; ++i) out[i] = q[i] + h * v[i];
    return;
  }
  for (int i = 0; i < 3; ++i) out[i] = q[i] + h * v[i];
  const std::array<S, 3> a{h * v[3], h * v[4], h * v[5]};  // the rotation vector h ω
  const S angle = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), half = 0.5 * angle;
  // exp(a / 2) = (cos |a|/2, sin(|a|/2) / |a| a); sin(x/2)/x by its series near 0
  const S c = cos(half),
          s = angle < S(1e-4) ? 0.5 - angle * angle / 48.0 : sin(half) / angle;
  const std::array<S, 4> qq{q[3], q[4], q[5], q[6]};
  const std::array<S, 4> r = times_pure(qq.data(), a.data());  // q ⊗ (0, a)
  for (int i = 0; i < 4; ++i) out[3 + i] = c * qq[i] + s * r[i];
  for (int i = free_joint_nv; i < nv; ++i) out[i + 1] = q[i + 1] + h * v[i];
}

}  // namespace eom
