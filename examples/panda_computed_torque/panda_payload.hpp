// The Panda's parameters by name, and a payload on its flange: shared by the computed-torque
// example (panda_tracking.hpp), the operational-space one (examples/panda_osc) and the demo.
#pragma once

#include <array>
#include <string_view>

namespace panda {

// The parameter index named `name` in K::parameter_names, or -1.
template <class K> constexpr int parameter_index(std::string_view name) {
  for (int i = 0; i < K::np; ++i)
    if (K::parameter_names[i] == name) return i;
  return -1;
}

// The parameters with a payload fixed to the flange: a solid sphere of `mass` kg and radius
// 0.04 m resting on the flange (its centre 0.107 + 0.04 m along z of panda_link7), lumped into
// link 7's mass, mass centre and inertia about it (parallel axes; the inertial axes of link 7 are
// its link axes in panda.urdf). A stand-in for a hand and the object it holds; the Panda's rated
// payload is 3 kg.
template <class K> std::array<double, K::np> with_payload(std::array<double, K::np> p, double mass) {
  constexpr int at = parameter_index<K>("panda_link7_mass");
  static_assert(at >= 0 && parameter_index<K>("panda_link7_Iyz") == at + 9,
                "link 7's inertial parameters: mass, com_x, com_y, com_z, Ixx, Iyy, Izz, Ixy, Ixz, Iyz");
  constexpr double radius = 0.04, flange = 0.107;
  const double m7 = p[at], m = m7 + mass;
  const std::array<double, 3> c7{p[at + 1], p[at + 2], p[at + 3]}, cp{0, 0, flange + radius};
  std::array<double, 3> c;
  for (int i = 0; i < 3; ++i) c[i] = (m7 * c7[i] + mass * cp[i]) / m;
  // I about c = Σ (I_body + m_body (|d|² E − d dᵀ)), d = the body's mass centre − c.
  std::array<double, 6> I{p[at + 4], p[at + 5], p[at + 6], p[at + 7], p[at + 8], p[at + 9]};
  const double sphere = 0.4 * mass * radius * radius;
  I[0] += sphere, I[1] += sphere, I[2] += sphere;
  for (const auto& [mb, cb] : {std::pair{m7, c7}, std::pair{mass, cp}}) {
    const double d[3] = {cb[0] - c[0], cb[1] - c[1], cb[2] - c[2]};
    I[0] += mb * (d[1] * d[1] + d[2] * d[2]);
    I[1] += mb * (d[0] * d[0] + d[2] * d[2]);
    I[2] += mb * (d[0] * d[0] + d[1] * d[1]);
    I[3] -= mb * d[0] * d[1];
    I[4] -= mb * d[0] * d[2];
    I[5] -= mb * d[1] * d[2];
  }
  p[at] = m;
  for (int i = 0; i < 3; ++i) p[at + 1 + i] = c[i];
  for (int i = 0; i < 6; ++i) p[at + 4 + i] = I[i];
  return p;
}

}  // namespace panda
