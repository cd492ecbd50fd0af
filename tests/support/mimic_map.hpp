// A robot with mimic joints against the recursive algorithms (recursive_dynamics.hpp): they run on
// the same file WITHOUT its <mimic> elements (full), where every moving joint has a coordinate of
// its own. A mimic joint's position m·q_leader + o is affine in q, so the reduced robot's dynamics
// are the full one's along q_full = (q_root, G q + o), v_full = G v, v̇_full = G v̇:
//   M = Gᵀ M_full G,   c + ∂V/∂q = Gᵀ (c_full + ∂V_full/∂q),
//   Q = u + Gᵀ Q_full with Q_full = −d⊙v_full − f⊙tanh(v_full / friction_smoothing),
// G the constant nv_full × nv matrix of 0, 1 and multipliers (the identity on a free root's six
// velocities). Without mimics G is the identity and every product below is exact.
#pragma once

#include <qd/dd_real.h>

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include <eomgen/urdf.hpp>

namespace eomtest {

struct MimicMap {
  using DD = std::vector<dd_real>;
  eom::urdf::Robot full;  // the robot without its mimics
  int fq = 0, fv = 0;     // the free joint's coordinates and velocities: (7, 6), or none
  int nv = 0, nvf = 0;    // velocities, reduced and full
  bool mimic = false;     // any mimic joint (G is not the identity)
  std::vector<double> G;  // nvf × nv, column-major
  std::vector<double> offset, damping, friction;  // per full velocity (the free joint's 0)

  explicit MimicMap(const eom::urdf::Robot& reduced) : full(reduced) {
    for (auto& j : full.joints) j.mimic.reset();
    fq = reduced.floating ? 7 : 0;
    fv = reduced.floating ? 6 : 0;
    std::vector<std::string> leaders;  // the reduced coordinates
    std::vector<const eom::urdf::Joint*> moving;
    for (const auto& j : reduced.joints)
      if (j.type != eom::urdf::JointType::fixed) {
        moving.push_back(&j);
        if (!j.mimic) leaders.push_back(j.name);
      }
    nv = fv + static_cast<int>(leaders.size());
    nvf = fv + static_cast<int>(moving.size());
    G.assign(static_cast<std::size_t>(nvf * nv), 0.0);
    offset.assign(static_cast<std::size_t>(nvf), 0.0);
    damping = friction = offset;
    for (int i = 0; i < fv; ++i) g(i, i) = 1;
    for (std::size_t m = 0; m < moving.size(); ++m) {
      const auto& j = *moving[m];
      const std::string& leader = j.mimic ? j.mimic->leader : j.name;
      const int k = fv + static_cast<int>(std::find(leaders.begin(), leaders.end(), leader) - leaders.begin());
      const auto i = static_cast<std::size_t>(fv) + m;
      g(static_cast<int>(i), k) = j.mimic ? j.mimic->multiplier : 1.0;
      offset[i] = j.mimic ? j.mimic->offset : 0.0;
      damping[i] = j.damping;
      friction[i] = j.friction;
      mimic = mimic || j.mimic.has_value();
    }
  }

  double& g(int i, int k) { return G[static_cast<std::size_t>(i + nvf * k)]; }
  double g(int i, int k) const { return G[static_cast<std::size_t>(i + nvf * k)]; }

  // q_full = (q_root, G q + o) from the reduced q (fq + nv − fv entries)
  DD positions(const double* q) const {
    DD y(static_cast<std::size_t>(fq + nvf - fv), dd_real(0.0));
    for (int i = 0; i < fq; ++i) y[static_cast<std::size_t>(i)] = q[i];
    for (int i = fv; i < nvf; ++i) {
      dd_real s = offset[static_cast<std::size_t>(i)];
      for (int k = fv; k < nv; ++k)
        if (g(i, k) != 0) s += g(i, k) * dd_real(q[fq + k - fv]);
      y[static_cast<std::size_t>(fq + i - fv)] = s;
    }
    return y;
  }
  // G x, for x of nv entries
  template <class X> DD up(const X& x) const {
    DD y(static_cast<std::size_t>(nvf), dd_real(0.0));
    for (int i = 0; i < nvf; ++i)
      for (int k = 0; k < nv; ++k)
        if (g(i, k) != 0) y[static_cast<std::size_t>(i)] += g(i, k) * dd_real(x[static_cast<std::size_t>(k)]);
    return y;
  }
  // Gᵀ y
  DD down(const DD& y) const {
    DD x(static_cast<std::size_t>(nv), dd_real(0.0));
    for (int k = 0; k < nv; ++k)
      for (int i = 0; i < nvf; ++i)
        if (g(i, k) != 0) x[static_cast<std::size_t>(k)] += g(i, k) * y[static_cast<std::size_t>(i)];
    return x;
  }
  // Gᵀ M_full G
  DD reduce(const DD& Mf) const {
    DD M(static_cast<std::size_t>(nv * nv));
    for (int a = 0; a < nv; ++a)
      for (int b = 0; b < nv; ++b) {
        dd_real s(0.0);
        for (int i = 0; i < nvf; ++i)
          if (g(i, a) != 0)
            for (int j = 0; j < nvf; ++j)
              if (g(j, b) != 0) s += g(i, a) * Mf[static_cast<std::size_t>(i + nvf * j)] * g(j, b);
        M[static_cast<std::size_t>(a + nv * b)] = s;
      }
    return M;
  }
  // −Q_full = d⊙v_full + f⊙tanh(v_full / friction_smoothing), added to tau
  void add_dissipation(const DD& vf, DD& tau) const {
    const dd_real eps(eom::urdf::friction_smoothing);
    for (std::size_t i = 0; i < vf.size(); ++i) tau[i] += damping[i] * vf[i] + friction[i] * tanh(vf[i] / eps);
  }
};

// The worst relative error max_i |got_i − expected_i| / max(1, max_i |expected_i|) over checks,
// and which check gave it.
struct Worst {
  double value = 0;
  std::string where;
  void update(const char* what, const std::vector<dd_real>& got, const std::vector<dd_real>& expected) {
    double diff = 0, scale = 1;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      diff = std::max(diff, std::abs(to_double(got[i] - expected[i])));
      scale = std::max(scale, std::abs(to_double(expected[i])));
    }
    if (diff / scale > value) value = diff / scale, where = what;
  }
};

}  // namespace eomtest
