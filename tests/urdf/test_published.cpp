// Published robot descriptions (robots/published, README there: sources and licenses), read with
// the inertia policy each needs, their root freed (FLOATING_BASE: they walk), and written as model
// headers by eomgen-urdf at build time. Generating every kernel of a 12–31-joint floating robot
// takes longer than the suite's budget, so they are checked on the runtime's paths, which are the
// generator's inputs: eom::Reference (the Lagrangian route by AD, double) for M, c + ∂V/∂q and v̇,
// and the tree algorithms of eom/tree.hpp (traced for inverse and forward dynamics) — against
// the recursive algorithms of tests/support/recursive_dynamics.hpp in dd_real on the same file.
#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <eom/reference.hpp>
#include <eom/tree.hpp>
#include <eomgen/urdf.hpp>
#include <go1_model.hpp>
#include <hyq_model.hpp>
#include <recursive_dynamics.hpp>
#include <romeo_model.hpp>

namespace {

using DD = std::vector<dd_real>;

struct Worst {
  double value = 0;
  std::string where;
  void update(const char* what, const DD& got, const DD& expected) {
    double diff = 0, scale = 1;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      diff = std::max(diff, std::abs(to_double(got[i] - expected[i])));
      scale = std::max(scale, std::abs(to_double(expected[i])));
    }
    if (diff / scale > value) value = diff / scale, where = what;
  }
};

template <class Model>
Worst check(const char* file, eom::urdf::InertiaPolicy policy) {
  using R = eom::Reference<Model>;
  constexpr int nq = R::nq, nv = R::nv;
  const eom::urdf::Robot robot =
      eom::urdf::read(std::string(EOM_PUBLISHED_DIR) + "/" + file, {.free_root = true, .inertia = policy});
  eomtest::RecursiveDynamics<dd_real> rd(robot);
  EXPECT_EQ(rd.nq(), nq);
  const auto& p = R::parameter_values;
  const DD pd(p.begin(), p.end());
  const auto links = eom::tree_of<Model, dd_real>(pd);
  // <dynamics friction> (Go1's): −f⊙tanh(v / friction_smoothing), which the recursive algorithms
  // leave out, is put into their input: u − f⊙tanh(v/ε) (per velocity; the free joint's 0).
  std::vector<double> friction(6, 0.0);
  for (const auto& j : robot.joints)
    if (j.type != eom::urdf::JointType::fixed) friction.push_back(j.friction);
  EXPECT_EQ(static_cast<int>(friction.size()), nv);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(-1.5, 1.5), rate(-1.0, 1.0);
  Worst worst;
  for (int sample = 0; sample < 20; ++sample) {
    std::array<double, nq> q;
    std::array<double, nv> v, a, u;
    for (auto& x : q) x = angle(rng);
    double norm = 0;  // the free joint's unit quaternion
    for (int k = 3; k < 7; ++k) norm += q[k] * q[k];
    for (int k = 3; k < 7; ++k) q[k] /= std::sqrt(norm);
    for (int i = 0; i < nv; ++i) v[i] = rate(rng), a[i] = rate(rng), u[i] = 5 * rate(rng);
    for (int i = 0; i < 6; ++i) u[i] = 0;  // the free joint has no actuator
    const DD Q(q.begin(), q.end()), V(v.begin(), v.end()), A(a.begin(), a.end()), U(u.begin(), u.end());
    DD M(nv * nv), bias(nv), gravity(nv), zero(nv, dd_real(0.0)), tau(nv), qdd(nv);
    std::array<double, nv * nv> Mr;
    std::array<double, nv> x, y;
    rd.mass_matrix(Q, M);
    R::mass_matrix(q.data(), p.data(), Mr.data());
    worst.update("Reference mass_matrix", DD(Mr.begin(), Mr.end()), M);
    rd.bias_forces(Q, V, bias);
    R::coriolis(q.data(), v.data(), p.data(), x.data());
    R::potential_gradient(q.data(), p.data(), y.data());
    for (int i = 0; i < nv; ++i) x[i] += y[i];
    worst.update("Reference coriolis + potential_gradient", DD(x.begin(), x.end()), bias);
    DD U_net = U;
    for (int i = 0; i < nv; ++i) U_net[i] -= friction[i] * tanh(V[i] / dd_real(eom::urdf::friction_smoothing));
    rd.forward_dynamics(Q, V, U_net, qdd);
    static_assert(R::nu == nv - 6);  // one input per joint, none for the free joint
    EXPECT_TRUE(R::forward_dynamics(0.0, q.data(), v.data(), u.data() + 6, p.data(), x.data()));
    worst.update("Reference forward_dynamics", DD(x.begin(), x.end()), qdd);
    DD tree_M(nv * nv), tree_tau(nv), tree_qdd(nv), pivots(nv);
    eom::tree_mass_matrix<dd_real>(links, Q, tree_M);
    worst.update("tree_mass_matrix", tree_M, M);
    rd.inverse_dynamics(Q, V, A, tau);
    rd.inverse_dynamics(Q, zero, zero, gravity);
    for (int i = 0; i < nv; ++i) tau[i] -= gravity[i];
    eom::tree_inverse_dynamics<dd_real>(links, Q, V, A, tree_tau);
    worst.update("tree_inverse_dynamics", tree_tau, tau);
    DD force(nv);
    for (int i = 0; i < nv; ++i) force[i] = U_net[i] - rd.damping()[i] * V[i] - gravity[i];
    eom::tree_forward_dynamics<dd_real>(links, Q, V, force, tree_qdd, pivots);
    worst.update("tree_forward_dynamics", tree_qdd, qdd);
  }
  return worst;
}

// Measured (20 states, worst relative error of all seven checks): HyQ 1.9e-15, Go1 2.4e-15, Romeo
// 1.5e-14, each from the Reference's forward dynamics (which keeps its big AD numbers on a heap
// stack of its own, eom/heap_stack.hpp, so 37 velocities run on the test's main thread).
TEST(UrdfPublished, HyqWithNearestInertias) {
  Worst w;
  w = check<eom::published::hyq>("hyq_no_sensors.urdf", eom::urdf::InertiaPolicy::nearest);
  std::printf("HyQ (18 velocities): runtime vs recursive, worst %.1e (%s)\n", w.value, w.where.c_str());
  EXPECT_LT(w.value, 1e-12) << w.where;
}
TEST(UrdfPublished, Go1WithNearestInertias) {
  Worst w;
  w = check<eom::published::go1>("go1.urdf", eom::urdf::InertiaPolicy::nearest);
  std::printf("Go1 (18 velocities): runtime vs recursive, worst %.1e (%s)\n", w.value, w.where.c_str());
  EXPECT_LT(w.value, 1e-12) << w.where;
}
TEST(UrdfPublished, RomeoWithInertiasAsPublished) {
  Worst w;
  w = check<eom::published::romeo>("romeo_small.urdf", eom::urdf::InertiaPolicy::warn);
  std::printf("Romeo small (37 velocities): runtime vs recursive, worst %.1e (%s)\n", w.value, w.where.c_str());
  EXPECT_LT(w.value, 1e-12) << w.where;
}

}  // namespace
