// The heavy symmetric top in ZYZ Euler angles (ψ precession, θ nutation, φ spin), its tip pinned
// at the origin, its mass centre at distance l along the body z axis (the symmetry axis), inertia
// about the mass centre diag(I1, I1, I3), gravity g along −z. Two forms of the same model:
//
//   SymmetricTop        the body form: one eom::SpatialBody, R = Rz(ψ)·Ry(θ)·Rz(φ) built from
//                       the rotation helpers of <eom/multibody/spatial.hpp>;
//   SymmetricTopEnergy  the textbook energy form, written out by hand (no spatial helpers):
//                         T = ½(I1 + m l²)(θ̇² + ψ̇² sin²θ) + ½ I3 (φ̇ + ψ̇ cos θ)²,
//                         V = m g l cos θ.
//
// M is singular at sin θ = 0 (the ZYZ coordinate singularity): sample θ away from 0 and π.
#pragma once

#include <array>
#include <cmath>

#include <eom/model/model.hpp>
#include <eom/multibody/spatial.hpp>

namespace spatial_test {

struct SymmetricTopNames {
  static constexpr std::array coordinates{"psi", "theta", "phi"};
  static constexpr std::array parameters{"m", "l", "I1", "I3", "g"};
  static constexpr std::array parameter_values{2.0, 0.4, 0.05, 0.08, 9.81};
};

struct SymmetricTop : SymmetricTopNames {
  static constexpr int body_count = 1;

  template <class S> static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {
    const S &m = p[0], &l = p[1], &I1 = p[2], &I3 = p[3];
    const eom::Rot3<S> R = eom::multiply(eom::rot_z(q[0]), eom::multiply(eom::rot_y(q[1]), eom::rot_z(q[2])));
    b[0].mass = m;
    b[0].inertia = {I1, I1, I3, S(0), S(0), S(0)};
    b[0].position = eom::rotate<S>(R, {S(0), S(0), l});
    b[0].rotation = R;
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    std::array<eom::SpatialBody<S>, body_count> b;
    bodies<S>(q, p, b);
    return eom::gravity_potential<S>(b, p[4]);
  }
};

struct SymmetricTopEnergy : SymmetricTopNames {
  template <class S> static S kinetic_energy(eom::In<S> q, eom::In<S> qd, eom::In<S> p) {
    using std::cos, std::sin;
    const S &m = p[0], &l = p[1], &I1 = p[2], &I3 = p[3];
    const S &psid = qd[0], &thetad = qd[1], &phid = qd[2];
    const S s = sin(q[1]), c = cos(q[1]);
    const S spin = phid + psid * c;
    return 0.5 * (I1 + m * l * l) * (thetad * thetad + psid * psid * s * s) + 0.5 * I3 * spin * spin;
  }
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    using std::cos;
    return p[0] * p[4] * p[1] * cos(q[1]);
  }
};

}  // namespace spatial_test
