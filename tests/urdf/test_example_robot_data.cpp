// Optional (cmake -DEOM_EXAMPLE_ROBOT_DATA=<a checkout of Gepetto/example-robot-data>): published
// robots that are not bundled (Talos' files state CC BY-NC-ND 3.0), generated through
// add_eom_model(... URDF ... FLOATING_BASE [INERTIA_POLICY warn]) and checked against the recursive
// algorithms (tests/support/recursive_dynamics.hpp) in dd_real on the same file without its mimics,
// by the constant map G of test_mimic.cpp: M = Gᵀ M_full G, inverse dynamics
// Gᵀ(τ_full − Q_full) − u, forward dynamics by that residual; Q_full = −d⊙v − f⊙tanh(v/ε).
//   - Talos reduced: inertias as published (two gripper links violate the triangle inequality:
//     INERTIA_POLICY warn), its 12 <mimic> on fixed joints ignored;
//   - Talos full v2: 12 mimic joints in the grippers (38 velocities, 50 joints' worth).
#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <big_stack.hpp>
#include <eomgen/urdf.hpp>
#include <erd_talos_full.hpp>
#include <erd_talos_reduced.hpp>
#include <recursive_dynamics.hpp>

namespace {

using DD = std::vector<dd_real>;

template <class K>
double check(const std::string& file, eom::urdf::InertiaPolicy policy) {
  constexpr int nq = K::nq, nv = K::nv, fv = 6;
  const eom::urdf::Robot reduced = eom::urdf::read(file, {.free_root = true, .inertia = policy});
  eom::urdf::Robot full = reduced;
  for (auto& j : full.joints) j.mimic.reset();
  eomtest::RecursiveDynamics<dd_real> rd(full);
  std::vector<std::string> leaders;
  std::vector<const eom::urdf::Joint*> moving;
  for (const auto& j : reduced.joints)
    if (j.type != eom::urdf::JointType::fixed) {
      moving.push_back(&j);
      if (!j.mimic) leaders.push_back(j.name);
    }
  const int nj = static_cast<int>(moving.size()), nvf = fv + nj;
  EXPECT_EQ(rd.nv(), nvf);
  EXPECT_EQ(nv, fv + static_cast<int>(leaders.size()));
  std::vector<double> G(static_cast<std::size_t>(nvf * nv), 0.0), offset(static_cast<std::size_t>(nvf), 0.0);
  std::vector<double> damping(static_cast<std::size_t>(nvf), 0.0), friction(static_cast<std::size_t>(nvf), 0.0);
  auto g = [&](int i, int k) -> double& { return G[static_cast<std::size_t>(i + nvf * k)]; };
  for (int i = 0; i < fv; ++i) g(i, i) = 1;
  for (int i = 0; i < nj; ++i) {
    const auto& j = *moving[static_cast<std::size_t>(i)];
    const std::string& leader = j.mimic ? j.mimic->leader : j.name;
    const int k = fv + static_cast<int>(std::find(leaders.begin(), leaders.end(), leader) - leaders.begin());
    g(fv + i, k) = j.mimic ? j.mimic->multiplier : 1.0;
    offset[static_cast<std::size_t>(fv + i)] = j.mimic ? j.mimic->offset : 0.0;
    damping[static_cast<std::size_t>(fv + i)] = j.damping;
    friction[static_cast<std::size_t>(fv + i)] = j.friction;
  }
  const dd_real eps(eom::urdf::friction_smoothing);
  const auto& p = K::parameter_values;
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> angle(-1.5, 1.5), rate(-1.0, 1.0);
  double worst = 0;
  auto update = [&worst](const double* got, const DD& expected) {
    double diff = 0, scale = 1;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      diff = std::max(diff, std::abs(got[i] - to_double(expected[i])));
      scale = std::max(scale, std::abs(to_double(expected[i])));
    }
    worst = std::max(worst, diff / scale);
  };
  auto down = [&](const DD& y) {  // Gᵀ y
    DD x(static_cast<std::size_t>(nv), dd_real(0.0));
    for (int k = 0; k < nv; ++k)
      for (int i = 0; i < nvf; ++i) x[static_cast<std::size_t>(k)] += g(i, k) * y[static_cast<std::size_t>(i)];
    return x;
  };
  auto up = [&](const double* x) {  // G x
    DD y(static_cast<std::size_t>(nvf), dd_real(0.0));
    for (int i = 0; i < nvf; ++i)
      for (int k = 0; k < nv; ++k) y[static_cast<std::size_t>(i)] += g(i, k) * x[k];
    return y;
  };
  for (int sample = 0; sample < 20; ++sample) {
    std::vector<double> q(nq), v(nv), a(nv), u(nv, 0.0), out(static_cast<std::size_t>(nv * nv));
    for (double& x : q) x = angle(rng);
    double norm = 0;
    for (int k = 3; k < 7; ++k) norm += q[static_cast<std::size_t>(k)] * q[static_cast<std::size_t>(k)];
    for (int k = 3; k < 7; ++k) q[static_cast<std::size_t>(k)] /= std::sqrt(norm);
    for (int i = 0; i < nv; ++i) v[static_cast<std::size_t>(i)] = rate(rng), a[static_cast<std::size_t>(i)] = rate(rng);
    for (int i = fv; i < nv; ++i) u[static_cast<std::size_t>(i)] = 5 * rate(rng);
    DD qf(static_cast<std::size_t>(7 + nj));
    for (int i = 0; i < 7; ++i) qf[static_cast<std::size_t>(i)] = q[static_cast<std::size_t>(i)];
    for (int i = 0; i < nj; ++i) {
      dd_real x = offset[static_cast<std::size_t>(fv + i)];
      for (int k = fv; k < nv; ++k) x += g(fv + i, k) * q[static_cast<std::size_t>(k + 1)];
      qf[static_cast<std::size_t>(7 + i)] = x;
    }
    const DD vf = up(v.data()), af = up(a.data()), U(u.begin(), u.end());
    auto dissipation = [&](DD& tau) {  // τ_full − Q_full's dissipative part
      for (int i = 0; i < nvf; ++i) {
        const dd_real& w = vf[static_cast<std::size_t>(i)];
        tau[static_cast<std::size_t>(i)] += damping[static_cast<std::size_t>(i)] * w +
                                            friction[static_cast<std::size_t>(i)] * tanh(w / eps);
      }
    };
    DD Mf(static_cast<std::size_t>(nvf * nvf)), M(static_cast<std::size_t>(nv * nv)), tau(static_cast<std::size_t>(nvf));
    rd.mass_matrix(qf, Mf);
    for (int x = 0; x < nv; ++x)
      for (int y = 0; y < nv; ++y) {
        dd_real s(0.0);
        for (int i = 0; i < nvf; ++i)
          if (g(i, x) != 0)
            for (int j = 0; j < nvf; ++j)
              if (g(j, y) != 0) s += g(i, x) * Mf[static_cast<std::size_t>(i + nvf * j)] * g(j, y);
        M[static_cast<std::size_t>(x + nv * y)] = s;
      }
    K::mass_matrix(q.data(), p.data(), out.data());
    update(out.data(), M);
    rd.inverse_dynamics(qf, vf, af, tau);
    dissipation(tau);
    DD expected = down(tau);
    for (int i = 0; i < nv; ++i) expected[static_cast<std::size_t>(i)] -= U[static_cast<std::size_t>(i)];
    K::inverse_dynamics(0.0, q.data(), v.data(), a.data(), u.data() + fv, p.data(), out.data());
    update(out.data(), expected);
    EXPECT_TRUE(K::forward_dynamics(0.0, q.data(), v.data(), u.data() + fv, p.data(), out.data()));
    rd.inverse_dynamics(qf, vf, up(out.data()), tau);
    dissipation(tau);
    const DD residual = down(tau);
    std::vector<double> r(static_cast<std::size_t>(nv));
    for (int i = 0; i < nv; ++i) r[static_cast<std::size_t>(i)] = to_double(residual[static_cast<std::size_t>(i)]);
    update(r.data(), U);
  }
  return worst;
}

TEST(ExampleRobotData, TalosReducedAsPublished) {
  double w = 1;
  on_big_stack([&] {
    w = check<erd_talos_reduced::Kernels>(EOM_ERD_TALOS "/talos_reduced.urdf", eom::urdf::InertiaPolicy::warn);
  });
  std::printf("Talos reduced: generated vs recursive (dd_real), worst %.1e\n", w);
  EXPECT_LT(w, 1e-12);
}
TEST(ExampleRobotData, TalosFullWithMimicJoints) {
  double w = 1;
  on_big_stack([&] {
    w = check<erd_talos_full::Kernels>(EOM_ERD_TALOS "/talos_full_v2.urdf", eom::urdf::InertiaPolicy::error);
  });
  std::printf("Talos full v2 (12 mimic joints): generated vs recursive (dd_real), worst %.1e\n", w);
  EXPECT_LT(w, 1e-12);
}

}  // namespace
