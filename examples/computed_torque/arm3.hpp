// A three-link planar arm in a vertical plane, driven by a motor at each joint: the robot of the
// computed-torque example. This is a user's model: it lives with the example, not in eomgen.
//
// Joint angles are relative (the robotics convention): q1 is link 1 from the horizontal, q2 and
// q3 are links 2 and 3 relative to the link before. Links are uniform rods (mass mᵢ, length lᵢ,
// inertia mᵢlᵢ²/12 about the middle); a point payload m_load sits at the tip; gravity acts
// along −y. The motor torques u = (tau1, tau2, tau3) do virtual work uᵢ δqᵢ, so Q = u.
#pragma once

#include <array>
#include <cmath>

#include <eom/model/model.hpp>

namespace examples {

struct Arm3 {
  static constexpr std::array coordinates{"q1", "q2", "q3"};
  static constexpr std::array parameters{"m1", "m2", "m3", "l1", "l2", "l3", "m_load", "g"};
  static constexpr std::array parameter_values{4.0, 3.0, 1.5, 0.6, 0.5, 0.3, 0.5, 9.81};
  static constexpr std::array inputs{"tau1", "tau2", "tau3"};

  // Body form: eomgen derives M = Σ mᵢAᵢᵀAᵢ + IᵢBᵢᵀBᵢ from these positions and angles.
  static constexpr int body_count = 4;  // three links and the payload
  template <class S>
  static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::PlanarBody<S>> b) {
    using std::cos, std::sin;
    S angle(0), jx(0), jy(0);  // absolute angle of the current link, its proximal joint
    for (int i = 0; i < 3; ++i) {
      const S& m = p[i];
      const S& l = p[3 + i];
      angle = angle + q[i];
      const S c = cos(angle), s = sin(angle);
      b[i].mass = m;
      b[i].inertia = m * l * l / 12.0;
      b[i].x = jx + 0.5 * l * c;
      b[i].y = jy + 0.5 * l * s;
      b[i].angle = angle;
      jx = jx + l * c;
      jy = jy + l * s;
    }
    b[3].mass = p[6];
    b[3].inertia = S(0);
    b[3].x = jx;
    b[3].y = jy;
    b[3].angle = angle;
  }

  // V = g Σ mᵢ yᵢ over the links' mass centres and the payload.
  template <class S> static S potential_energy(eom::In<S> q, eom::In<S> p) {
    using std::sin;
    const S& g = p[7];
    S angle(0), jy(0), V(0);
    for (int i = 0; i < 3; ++i) {
      const S& l = p[3 + i];
      angle = angle + q[i];
      const S s = sin(angle);
      V = V + p[i] * g * (jy + 0.5 * l * s);
      jy = jy + l * s;
    }
    return V + p[6] * g * jy;
  }

  template <class S> static void generalized_forces(const S&, eom::In<S>, eom::In<S>, eom::In<S> u,
                                                    eom::In<S>, eom::Out<S> Q) {
    for (int i = 0; i < 3; ++i) Q[i] = u[i];
  }
};

}  // namespace examples
