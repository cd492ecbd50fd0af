// The closed-form torque-free motion of an asymmetric rigid body, for tests: the body angular
// velocity ω(t) that solves Euler's equations J ω̇ + ω × J ω = 0, J = diag(J1, J2, J3) in the
// principal body axes (three distinct positive moments, in any order), from any ω(0) = ω0, by the
// Jacobi elliptic functions of Boost.Math. Double in and out, long double inside (on x86-64 a
// 64-bit significand), so that the double result is the exact solution to about its rounding.
//
// Derivation. Sort the axes so that the moments are A < B < C and call the components of ω along
// them ω1, ω2, ω3. Euler's equations are
//   A ω̇1 = (B − C) ω2 ω3,   B ω̇2 = (C − A) ω3 ω1,   C ω̇3 = (A − B) ω1 ω2,
// with the invariants
//   2T = ω·Jω  = A ω1² + B ω2² + C ω3²        (twice the kinetic energy),
//   H² = |Jω|² = A² ω1² + B² ω2² + C² ω3²     (the squared angular momentum),
// and three combinations of them, written as the sums they are (no cancellation in P and Q):
//   P = 2TC − H² = A(C−A) ω1² + B(C−B) ω2²  ≥ 0,
//   Q = H² − 2TA = B(B−A) ω2² + C(C−A) ω3²  ≥ 0,
//   S = H² − 2TB = C(C−B) ω3² − A(B−A) ω1²   (the separatrix is S = 0).
// ω2, the middle axis's component, is the one that passes through zero: it gets sn. With
// u = λ t + u0, λ > 0, and σ = ±1 the constant sign of the component that gets dn:
//
//  S > 0 (H²/2T in (B, C]: the polhode circles the axis of the LARGEST moment):
//    ω1 = σ √(P / (A(C−A))) cn u,   ω2 = √(P / (B(C−B))) sn u,   ω3 = σ √(Q / (C(C−A))) dn u,
//    k² = (B−A) P / ((C−B) Q),   k'² = 1 − k² = (C−A) S / ((C−B) Q),   λ² = (C−B) Q / (A B C),
//    σ = sign ω3(0).
//  S < 0 (H²/2T in [A, B): the polhode circles the axis of the SMALLEST moment):
//    ω1 = σ √(P / (A(C−A))) dn u,   ω2 = √(Q / (B(B−A))) sn u,   ω3 = σ √(Q / (C(C−A))) cn u,
//    k² = (C−B) Q / ((B−A) P),   k'² = 1 − k² = (C−A)(−S) / ((B−A) P),   λ² = (B−A) P / (A B C),
//    σ = sign ω1(0).
//
// (Check: the amplitudes make 2T and H² come out right for every u (sn² + cn² = 1,
// dn² = 1 − k² sn²); with sn' = cn dn, cn' = −sn dn, dn' = −k² sn cn each of Euler's equations
// gives the same |λ|, and all three give sign λ = σ1 σ3 for ω1 = σ1 a1 (·), ω3 = σ3 a3 (·): with
// λ > 0 both signs are σ.)
//
// Phase: the amplitude φ0 = am u0 has sin φ0 = sn u0 = ω2(0)/a2 and cos φ0 = cn u0 = σ ω_cn(0)/a_cn
// (a_i the amplitudes above, ω_cn the component that gets cn); atan2 gives φ0 in (−π, π], and
// u0 = F(φ0 | k), the incomplete elliptic integral of the first kind (boost ellint_1), continued
// past π/2 by F(π − φ) = 2K − F(φ), F(−φ) = −F(φ); K = F(π/2 | k) is the quarter period (complete
// ellint_1). ω(0) = ω0 then holds to rounding, and the sign of ω2's motion comes out right.
// ω has the period 4K/λ (sn and cn 4K, dn 2K).
//
// Evaluation: u is reduced to [0, K/2] by sn(u + 2K) = −sn u, cn(u + 2K) = −cn u, sn(2K − u) =
// sn u, cn(2K − u) = −cn u (dn unchanged by both), and sn(K − v) = cn v/dn v, cn(K − v) = k' sn
// v/dn v, dn(K − v) = k'/dn v, with k' from the formula above rather than from 1 − k². (Boost's
// dn = cos φ/cos(φ1 − φ) is 0/0 at u = K; its functions are only used on [0, K/2].)
//
// Axis order: the input may come in any order. Relabelling the axes by an even (cyclic)
// permutation keeps the equations as they are; an odd one flips the sign of the cross product,
// i.e. reverses time. So ω(t) is the sorted solution at ±t, put back in the input order.
//
// Refused with std::invalid_argument: a moment not finite and positive; two equal moments (a
// symmetric body, not this solution); ω0 not finite; ω0 on the separatrix S = 0 (to the rounding
// of S; the solution there is a sech/tanh one). Returned exactly as the constant solution
// ω(t) = ω0: ω0 = 0 and ω0 along one principal axis (the middle one included: an unstable but
// exact equilibrium).
//
// Accuracy: about the double rounding of the result for ω0 away from the separatrix; close to it
// the elliptic functions (Boost's, from k alone) lose about ε_ld / k'² (ε_ld ≈ 1.1e-19), so
// k'² ≳ 1e-5 keeps 1e-14; complementary_modulus_squared() tells.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <boost/math/constants/constants.hpp>
#include <boost/math/special_functions/ellint_1.hpp>
#include <boost/math/special_functions/jacobi_elliptic.hpp>

namespace eomtest {

class FreeRigidBody {
 public:
  FreeRigidBody(std::array<double, 3> principal_moments, std::array<double, 3> omega0)
      : omega0_(omega0) {
    for (double j : principal_moments)
      if (!(std::isfinite(j) && j > 0))
        throw std::invalid_argument("FreeRigidBody: the principal moments must be finite and > 0");
    const auto& J = principal_moments;
    if (J[0] == J[1] || J[1] == J[2] || J[0] == J[2])
      throw std::invalid_argument(
          "FreeRigidBody: two principal moments are equal (a symmetric body); the elliptic "
          "solution needs three distinct moments");
    for (double w : omega0)
      if (!std::isfinite(w)) throw std::invalid_argument("FreeRigidBody: ω0 must be finite");

    // Sorted axis i is input axis perm_[i]; an odd permutation reverses time.
    perm_ = {0, 1, 2};
    std::sort(perm_.begin(), perm_.end(), [&](int a, int b) { return J[a] < J[b]; });
    const int inversions = int(perm_[0] > perm_[1]) + int(perm_[0] > perm_[2]) +
                           int(perm_[1] > perm_[2]);
    time_sign_ = inversions % 2 == 0 ? 1 : -1;

    const W A = J[perm_[0]], B = J[perm_[1]], C = J[perm_[2]];
    const W w1 = omega0[perm_[0]], w2 = omega0[perm_[1]], w3 = omega0[perm_[2]];
    if (int(w1 == 0) + int(w2 == 0) + int(w3 == 0) >= 2) {  // ω0 = 0 or along an axis
      constant_ = true;
      return;
    }

    const W P = A * (C - A) * w1 * w1 + B * (C - B) * w2 * w2;
    const W Q = B * (B - A) * w2 * w2 + C * (C - A) * w3 * w3;
    const W s_plus = C * (C - B) * w3 * w3, s_minus = A * (B - A) * w1 * w1;
    const W S = s_plus - s_minus;
    if (std::abs(S) <= 64 * std::numeric_limits<W>::epsilon() * (s_plus + s_minus))
      throw std::invalid_argument(
          "FreeRigidBody: ω0 lies on the separatrix (H² = 2T·J_middle), where the motion is not "
          "periodic; this solution does not cover it");

    W m, mc, lambda2, y, x;
    if (S > 0) {  // circles the largest-moment axis: ω1 cn, ω2 sn, ω3 dn
      about_largest_ = true;
      const W sigma = w3 > 0 ? 1 : -1;
      amp_ = {sigma * std::sqrt(P / (A * (C - A))), std::sqrt(P / (B * (C - B))),
              sigma * std::sqrt(Q / (C * (C - A)))};
      cn_axis_ = 0;
      dn_axis_ = 2;
      m = (B - A) * P / ((C - B) * Q);
      mc = (C - A) * S / ((C - B) * Q);
      lambda2 = (C - B) * Q / (A * B * C);
      y = w2 * std::sqrt(B * (C - B));
      x = sigma * w1 * std::sqrt(A * (C - A));
    } else {  // circles the smallest-moment axis: ω1 dn, ω2 sn, ω3 cn
      about_largest_ = false;
      const W sigma = w1 > 0 ? 1 : -1;
      amp_ = {sigma * std::sqrt(P / (A * (C - A))), std::sqrt(Q / (B * (B - A))),
              sigma * std::sqrt(Q / (C * (C - A)))};
      cn_axis_ = 2;
      dn_axis_ = 0;
      m = (C - B) * Q / ((B - A) * P);
      mc = (C - A) * (-S) / ((B - A) * P);
      lambda2 = (B - A) * P / (A * B * C);
      y = w2 * std::sqrt(B * (B - A));
      x = sigma * w3 * std::sqrt(C * (C - A));
    }
    k_ = std::sqrt(m);
    kp_ = std::sqrt(mc);
    lambda_ = std::sqrt(lambda2);
    K_ = boost::math::ellint_1(k_);
    u0_ = F(std::atan2(y, x));
  }

  // ω(t) in the input's axis order; ω(0) = ω0 to rounding. Any real t (negative too).
  std::array<double, 3> omega(double t) const {
    if (constant_) return omega0_;
    const W u = lambda_ * (W(time_sign_) * W(t)) + u0_;
    W f[3];  // sn, cn, dn of u
    sncndn(u, f[0], f[1], f[2]);
    std::array<W, 3> sorted{};
    sorted[1] = amp_[1] * f[0];
    sorted[cn_axis_] = amp_[cn_axis_] * f[1];
    sorted[dn_axis_] = amp_[dn_axis_] * f[2];
    std::array<double, 3> out{};
    for (int i = 0; i < 3; ++i) out[perm_[i]] = double(sorted[i]);
    return out;
  }

  // The solution is the constant ω0 (ω0 = 0 or along a principal axis).
  bool constant() const { return constant_; }
  // The polhode circles the axis of the largest moment (else: of the smallest); constant: false.
  bool circles_largest_axis() const { return about_largest_; }
  double modulus_squared() const { return double(k_ * k_); }                 // k²
  double complementary_modulus_squared() const { return double(kp_ * kp_); }  // k'² = 1 − k²
  double frequency() const { return double(lambda_); }                        // λ, rad/s
  double quarter_period() const { return double(K_); }                       // K, in u
  // The period of ω(t), 4K/λ in seconds; infinity for the constant solution.
  double period() const {
    return constant_ ? std::numeric_limits<double>::infinity() : double(4 * K_ / lambda_);
  }

 private:
  using W = long double;

  // F(φ | k) for φ in [−π, π].
  W F(W phi) const {
    const W a = std::abs(phi);
    const W f = a <= boost::math::constants::half_pi<W>()
                    ? boost::math::ellint_1(k_, a)
                    : 2 * K_ - boost::math::ellint_1(k_, boost::math::constants::pi<W>() - a);
    return phi < 0 ? -f : f;
  }

  // sn, cn, dn of u (modulus k_), from Boost's on [0, K/2] only.
  void sncndn(W u, W& sn, W& cn, W& dn) const {
    const W four_k = 4 * K_;
    W r = u - four_k * std::floor(u / four_k);  // [0, 4K]
    W sn_sign = 1, cn_sign = 1;
    if (r >= 2 * K_) {  // u + 2K: sn, cn change sign
      r -= 2 * K_;
      sn_sign = -sn_sign;
      cn_sign = -cn_sign;
    }
    if (r > K_) {  // 2K − u: cn changes sign
      r = 2 * K_ - r;
      cn_sign = -cn_sign;
    }
    if (r <= K_ / 2) {
      sn = boost::math::jacobi_elliptic(k_, r, &cn, &dn);
    } else {  // K − v
      W s, c, d;
      s = boost::math::jacobi_elliptic(k_, K_ - r, &c, &d);
      sn = c / d;
      cn = kp_ * s / d;
      dn = kp_ / d;
    }
    sn *= sn_sign;
    cn *= cn_sign;
  }

  std::array<double, 3> omega0_;
  std::array<int, 3> perm_{0, 1, 2};
  int time_sign_ = 1;
  bool constant_ = false;
  bool about_largest_ = false;
  std::array<W, 3> amp_{};  // signed amplitudes in the sorted order
  int cn_axis_ = 0, dn_axis_ = 2;
  W k_ = 0, kp_ = 1, lambda_ = 0, K_ = 0, u0_ = 0;
};

}  // namespace eomtest
