// Unit quaternions in q (docs/CONTRACT.md §1): the free joint and ball joints.
//
// The free joint: a model with `static constexpr bool floating_base = true` flies free. Its first
// 7 coordinates place the root and its first 6 velocities move it:
//
//   q = [x, y, z, qw, qx, qy, qz, ...]   root origin in the world; unit quaternion (root axes → world)
//   v = [vx, vy, vz, ωx, ωy, ωz, ...]    ẋ, ẏ, ż in world axes; angular velocity in root axes
//
// A ball joint: 4 coordinates, a unit quaternion (child axes → parent axes, scalar first), and 3
// velocities, the child's angular velocity relative to its parent in child axes. Either way a
// unit quaternion q[k..k+4) moves by three velocities ω = v[j..j+3), q̇ = ½ q ⊗ (0, ω), and
// every other coordinate by its own velocity. A model's Layout lists where its quaternions are
// (the q index of each w, ascending): nq = nv + their count, and the velocity of a coordinate
// is shifted back by one for each quaternion before it. The generalized forces conjugate to v
// are, for a quaternion, a moment in the same axes as ω. A model without quaternions has
// nq == nv and q̇ = v: every function here is then the identity or a copy. Everything is
// templated on the scalar: the tracer, the AD reference and the integrators use the same G.
#pragma once

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace eom {

inline constexpr int free_joint_nq = 7, free_joint_nv = 6;
inline constexpr int free_joint_quaternion[1] = {3};  // the free joint's w: q[3]

// Where a model's unit quaternions are: the q index of each one's w, ascending, nq − nv of them,
// each four coordinates apart at least. Layout(nq, nv) is a model's whose only quaternion, if
// any, is a free joint's at q[3] (nq = nv + 1; any other count is a misuse that aborts, naming
// it): what a Kernels type that does not state `quaternions` means. A model with ball joints
// states them: use eom::ModelInfo<M>::layout or eom::layout_of<K>(). (The pointer is to static
// data: K::quaternions.)
struct Layout {
  int nq = 0, nv = 0;
  const int* quaternions = nullptr;
  constexpr Layout(int nq_, int nv_, const int* quaternions_)
      : nq(nq_), nv(nv_), quaternions(quaternions_) {}
  constexpr Layout(int nq_, int nv_)
      : nq(nq_), nv(nv_), quaternions(nq_ == nv_ + 1 ? free_joint_quaternion : nullptr) {
    if (nq_ != nv_ && nq_ != nv_ + 1) {  // a misuse: such a model says where (layout_of<K>())
      std::fputs("eom::Layout(nq, nv): more than one quaternion; give their places "
                 "(eom::layout_of<K>(), eom::ModelInfo<M>::layout)\n", stderr);
      std::abort();
    }
  }
  constexpr int count() const { return nq - nv; }
  // Only the free joint's quaternion, or none: what methods written for the free joint take.
  constexpr bool free_joint_only() const {
    return count() == 0 || (count() == 1 && quaternions[0] == 3);
  }

  // Walks q and v together: scalar(i, j) for a coordinate q[i] moved by v[j], quaternion(i, j)
  // for a unit quaternion q[i..i+4) moved by ω = v[j..j+3).
  template <class Scalar, class Quaternion>
  constexpr void walk(Scalar&& scalar, Quaternion&& quaternion) const {
    for (int i = 0, j = 0, k = 0; i < nq;) {
      if (k < count() && quaternions[k] == i) {
        quaternion(i, j);
        i += 4, j += 3, ++k;
      } else {
        scalar(i, j);
        ++i, ++j;
      }
    }
  }
};

// q ⊗ (0, a): a quaternion (scalar first) times a pure quaternion.
template <class S> std::array<S, 4> times_pure(const S* q, const S* a) {
  return {-(q[1] * a[0] + q[2] * a[1] + q[3] * a[2]), q[0] * a[0] + q[2] * a[2] - q[3] * a[1],
          q[0] * a[1] + q[3] * a[0] - q[1] * a[2], q[0] * a[2] + q[1] * a[1] - q[2] * a[0]};
}

// q̇ = G(q) v (nq entries).
template <class S> void configuration_rate(const Layout& L, const S* q, const S* v, S* qdot) {
  L.walk([&](int i, int j) { qdot[i] = v[j]; },
         [&](int i, int j) {
           const std::array<S, 4> r = times_pure(q + i, v + j);
           for (int k = 0; k < 4; ++k) qdot[i + k] = 0.5 * r[k];
         });
}

// Column j of G(q): the configuration rate of the unit velocity e_j (nq entries).
template <class S> void configuration_direction(const Layout& L, const S* q, int j, S* out) {
  for (int i = 0; i < L.nq; ++i) out[i] = S(0);
  L.walk([&](int i, int jj) { if (jj == j) out[i] = S(1); },
         [&](int i, int jj) {
           if (j < jj || j >= jj + 3) return;
           std::array<S, 3> e{S(0), S(0), S(0)};
           e[j - jj] = S(1);
           const std::array<S, 4> r = times_pure(q + i, e.data());
           for (int k = 0; k < 4; ++k) out[i + k] = 0.5 * r[k];
         });
}

// Gᵀ g: a gradient over q (nq) as the generalized force conjugate to v (nv), e.g. ∂V/∂q.
template <class S> void tangent_gradient(const Layout& L, const S* q, const S* g, S* out) {
  L.walk([&](int i, int j) { out[j] = g[i]; },
         [&](int i, int j) {
           for (int a = 0; a < 3; ++a) {  // ½ (q ⊗ e_a) · g_quaternion
             std::array<S, 3> e{S(0), S(0), S(0)};
             e[a] = S(1);
             const std::array<S, 4> c = times_pure(q + i, e.data());
             out[j + a] = 0.5 * (c[0] * g[i] + c[1] * g[i + 1] + c[2] * g[i + 2] + c[3] * g[i + 3]);
           }
         });
}

// Ġ v = d/dt(G(q)) v along q̇ = G(q) v at constant v (nq entries): the configuration's
// acceleration when v̇ = 0, ½ q̇ ⊗ (0, ω) for a quaternion, 0 elsewhere.
template <class S> void configuration_rate_bias(const Layout& L, const S* q, const S* v, S* out) {
  L.walk([&](int i, int) { out[i] = S(0); },
         [&](int i, int j) {
           std::array<S, 4> rate = times_pure(q + i, v + j);  // 2 × the quaternion's rate
           for (S& x : rate) x = 0.5 * x;
           const std::array<S, 4> r = times_pure(rate.data(), v + j);
           for (int k = 0; k < 4; ++k) out[i + k] = 0.5 * r[k];
         });
}

// The largest |‖quaternion‖ − 1| of a configuration (0 without quaternions).
template <class S> S quaternion_norm_error(const Layout& L, const S* q) {
  using std::abs, std::sqrt;
  S worst(0);
  L.walk([](int, int) {}, [&](int i, int) {
    const S e = abs(sqrt(q[i] * q[i] + q[i + 1] * q[i + 1] + q[i + 2] * q[i + 2] + q[i + 3] * q[i + 3]) - S(1));
    if (!(e <= worst)) worst = e;  // NaN wins
  });
  return worst;
}

// Puts every quaternion back on the unit sphere; false (q unchanged) when a norm is 0 or not
// finite.
template <class S> bool normalize_configuration(const Layout& L, S* q) {
  using std::sqrt;
  bool ok = true;
  L.walk([](int, int) {}, [&](int i, int) {
    const S n = sqrt(q[i] * q[i] + q[i + 1] * q[i + 1] + q[i + 2] * q[i + 2] + q[i + 3] * q[i + 3]);
    if (!(n > S(0)) || !(n < S(1e300))) ok = false;  // also false for NaN
  });
  if (!ok) return false;
  L.walk([](int, int) {}, [&](int i, int) {
    const S n = sqrt(q[i] * q[i] + q[i + 1] * q[i + 1] + q[i + 2] * q[i + 2] + q[i + 3] * q[i + 3]);
    for (int k = i; k < i + 4; ++k) q[k] = q[k] / n;
  });
  return true;
}

// q ⊕ h v: the configuration reached by moving with constant v for a time h, on the group:
// coordinates + h v, each quaternion q ⊗ exp(h ω / 2) (exact for a constant rate in its moving
// axes). out may alias q.
template <class S> void integrate_configuration(const Layout& L, const S* q, const S* v, S h, S* out) {
  using std::cos, std::sin, std::sqrt;
  L.walk([&](int i, int j) { out[i] = q[i] + h * v[j]; },
         [&](int i, int j) {
           const std::array<S, 3> a{h * v[j], h * v[j + 1], h * v[j + 2]};  // the rotation vector
           const S angle = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), half = 0.5 * angle;
           // exp(a / 2) = (cos |a|/2, sin(|a|/2) / |a| a); sin(x/2)/x by its series near 0
           const S c = cos(half),
                   s = angle < S(1e-4) ? 0.5 - angle * angle / 48.0 : sin(half) / angle;
           const std::array<S, 4> qq{q[i], q[i + 1], q[i + 2], q[i + 3]};
           const std::array<S, 4> r = times_pure(qq.data(), a.data());  // q ⊗ (0, a)
           for (int k = 0; k < 4; ++k) out[i + k] = c * qq[k] + s * r[k];
         });
}

}  // namespace eom
