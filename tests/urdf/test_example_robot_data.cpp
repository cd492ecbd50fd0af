// Optional (cmake -DEOM_EXAMPLE_ROBOT_DATA=<a checkout of Gepetto/example-robot-data>): published
// robots that are not bundled (Talos' files state CC BY-NC-ND 3.0), generated through
// add_eom_model(... URDF ... FLOATING_BASE [INERTIA_POLICY warn]) and checked against the recursive
// algorithms (tests/support/recursive_dynamics.hpp) in dd_real on the same file without its mimics,
// by the constant map G of tests/support/mimic_map.hpp: M = Gᵀ M_full G, inverse dynamics
// Gᵀ(τ_full − Q_full) − u, forward dynamics by that residual; Q_full = −d⊙v − f⊙tanh(v/ε).
//   - Talos reduced: inertias as published (two gripper links violate the triangle inequality:
//     INERTIA_POLICY warn), its 12 <mimic> on fixed joints ignored;
//   - Talos full v2: 12 mimic joints in the grippers (38 velocities, 50 joints' worth).
// Both also as the model headers add_eom_model wrote, on the runtime's paths (eom::Reference,
// eom/multibody/tree.hpp), as test_published.cpp and test_example_robot_data_runtime.cpp (the other robots).
#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <eomgen/urdf.hpp>
#include <erd_talos_full.hpp>
#include <erd_talos_full_model.hpp>
#include <erd_talos_reduced.hpp>
#include <erd_talos_reduced_model.hpp>
#include <mimic_map.hpp>
#include <recursive_dynamics.hpp>
#include <runtime_check.hpp>

namespace {

using DD = std::vector<dd_real>;

template <class K>
double check(const std::string& file, eom::urdf::InertiaPolicy policy) {
  constexpr int nq = K::nq, nv = K::nv, fv = 6;
  const eomtest::MimicMap map(eom::urdf::read(file, {.free_root = true, .inertia = policy}));
  eomtest::RecursiveDynamics<dd_real> rd(map.full);
  EXPECT_EQ(rd.nv(), map.nvf);
  EXPECT_EQ(nv, map.nv);
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
  for (int sample = 0; sample < 20; ++sample) {
    std::vector<double> q(nq), v(nv), a(nv), u(nv, 0.0), out(static_cast<std::size_t>(nv * nv));
    for (double& x : q) x = angle(rng);
    double norm = 0;
    for (int k = 3; k < 7; ++k) norm += q[static_cast<std::size_t>(k)] * q[static_cast<std::size_t>(k)];
    for (int k = 3; k < 7; ++k) q[static_cast<std::size_t>(k)] /= std::sqrt(norm);
    for (int i = 0; i < nv; ++i) v[static_cast<std::size_t>(i)] = rate(rng), a[static_cast<std::size_t>(i)] = rate(rng);
    for (int i = fv; i < nv; ++i) u[static_cast<std::size_t>(i)] = 5 * rate(rng);
    const DD qf = map.positions(q.data()), vf = map.up(v), af = map.up(a), U(u.begin(), u.end());
    DD Mf(static_cast<std::size_t>(map.nvf * map.nvf)), tau(static_cast<std::size_t>(map.nvf));
    rd.mass_matrix(qf, Mf);
    K::mass_matrix(q.data(), p.data(), out.data());
    update(out.data(), map.reduce(Mf));
    rd.inverse_dynamics(qf, vf, af, tau);
    map.add_dissipation(vf, tau);
    DD expected = map.down(tau);
    for (int i = 0; i < nv; ++i) expected[static_cast<std::size_t>(i)] -= U[static_cast<std::size_t>(i)];
    K::inverse_dynamics(0.0, q.data(), v.data(), a.data(), u.data() + fv, p.data(), out.data());
    update(out.data(), expected);
    EXPECT_TRUE(K::forward_dynamics(0.0, q.data(), v.data(), u.data() + fv, p.data(), out.data()));
    rd.inverse_dynamics(qf, vf, map.up(out), tau);
    map.add_dissipation(vf, tau);
    const DD residual = map.down(tau);
    std::vector<double> r(static_cast<std::size_t>(nv));
    for (int i = 0; i < nv; ++i) r[static_cast<std::size_t>(i)] = to_double(residual[static_cast<std::size_t>(i)]);
    update(r.data(), U);
  }
  return worst;
}

TEST(ExampleRobotData, TalosReducedAsPublished) {
  double w = 1;
  w = check<erd_talos_reduced::Kernels>(EOM_ERD_ROBOTS "/talos_data/robots/talos_reduced.urdf", eom::urdf::InertiaPolicy::warn);
  std::printf("Talos reduced: generated vs recursive (dd_real), worst %.1e\n", w);
  EXPECT_LT(w, 1e-12);
}
TEST(ExampleRobotData, TalosFullWithMimicJoints) {
  double w = 1;
  w = check<erd_talos_full::Kernels>(EOM_ERD_ROBOTS "/talos_data/robots/talos_full_v2.urdf", eom::urdf::InertiaPolicy::error);
  std::printf("Talos full v2 (12 mimic joints): generated vs recursive (dd_real), worst %.1e\n", w);
  EXPECT_LT(w, 1e-12);
}

TEST(ExampleRobotData, TalosReducedOnTheRuntimesPaths) {
  eomtest::expect_runtime_agrees<eom::urdf_models::erd_talos_reduced>(
      "Talos reduced", EOM_ERD_ROBOTS "/talos_data/robots/talos_reduced.urdf",
      {.free_root = true, .inertia = eom::urdf::InertiaPolicy::warn});
}
TEST(ExampleRobotData, TalosFullWithMimicJointsOnTheRuntimesPaths) {
  eomtest::expect_runtime_agrees<eom::urdf_models::erd_talos_full>(
      "Talos full v2 (12 mimic joints)", EOM_ERD_ROBOTS "/talos_data/robots/talos_full_v2.urdf",
      {.free_root = true, .inertia = eom::urdf::InertiaPolicy::error});
}

}  // namespace
