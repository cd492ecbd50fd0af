// A URDF robot's model header (written by eomgen-urdf) on the runtime's paths, which are the
// generator's inputs, against the recursive algorithms (recursive_dynamics.hpp) in dd_real on the
// same Robot: eom::Reference (the Lagrangian route by AD, double) for M, c + ∂V/∂q and v̇, and the
// tree algorithms of eom/multibody/tree.hpp for M, inverse dynamics (without gravity) and forward dynamics.
// Root fixed or freed (Robot::floating), mimic joints by the map of mimic_map.hpp: v̇ of the
// Reference is then checked as the residual Gᵀ(τ_full − Q_full) − u of the full robot's RNEA
// (the recursive ABA has no mimics), and the tree's ABA, which refuses mimics, is left out.
// Friction: −f⊙tanh(v/ε), which the recursive algorithms leave out, goes into their input.
// Needs -ffp-contract=off (qd).
#pragma once

#include <qd/dd_real.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <eom/multibody/tree.hpp>
#include <eom/reference/reference.hpp>
#include <eomgen/urdf.hpp>

#include "mimic_map.hpp"
#include "recursive_dynamics.hpp"

namespace eomtest {

// The worst relative error of all checks over `samples` random states: q ∈ [−1.5, 1.5] (a free
// joint's quaternion normalized), v, v̇ ∈ [−1, 1], u ∈ [−5, 5] (none on the free joint).
template <class Model>
Worst check_runtime(const eom::urdf::Robot& robot, int samples = 20) {
  using DD = std::vector<dd_real>;
  using R = eom::Reference<Model>;
  constexpr int nq = R::nq, nv = R::nv, fv = (nq - nv) * 6;  // a free joint: nq = nv + 1
  const MimicMap map(robot);
  const int nvf = map.nvf;
  EXPECT_EQ(map.fv, fv);
  eomtest::RecursiveDynamics<dd_real> rd(map.full);
  EXPECT_EQ(rd.nv(), nvf);
  EXPECT_EQ(map.nv, nv);
  static_assert(R::nu == nv - fv);  // one input per joint, none for the free joint
  const auto& p = R::parameter_values;
  const DD pd(p.begin(), p.end());
  const auto links = eom::tree_of<Model, dd_real>(pd);
  EXPECT_EQ(eom::tree_has_mimic(links), map.mimic);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(-1.5, 1.5), rate(-1.0, 1.0);
  Worst worst;
  for (int sample = 0; sample < samples; ++sample) {
    std::array<double, nq> q;
    std::array<double, nv> v, a, u;
    for (auto& x : q) x = angle(rng);
    if constexpr (fv != 0) {  // the free joint's unit quaternion
      double norm = 0;
      for (int k = 3; k < 7; ++k) norm += q[k] * q[k];
      for (int k = 3; k < 7; ++k) q[k] /= std::sqrt(norm);
    }
    for (int i = 0; i < nv; ++i) v[i] = rate(rng), a[i] = rate(rng), u[i] = 5 * rate(rng);
    for (int i = 0; i < fv; ++i) u[i] = 0;  // the free joint has no actuator
    const DD Q(q.begin(), q.end()), V(v.begin(), v.end()), A(a.begin(), a.end()), U(u.begin(), u.end());
    const DD qf = map.positions(q.data()), vf = map.up(v), af = map.up(a);
    DD Mf(static_cast<std::size_t>(nvf * nvf)), bias(static_cast<std::size_t>(nvf));
    DD gravity(static_cast<std::size_t>(nvf)), tau(static_cast<std::size_t>(nvf));
    const DD zero(static_cast<std::size_t>(nvf), dd_real(0.0));
    std::array<double, nv * nv> Mr;
    std::array<double, nv> x, y;
    rd.mass_matrix(qf, Mf);
    const DD M = map.reduce(Mf);
    R::mass_matrix(q.data(), p.data(), Mr.data());
    worst.update("Reference mass_matrix", DD(Mr.begin(), Mr.end()), M);
    DD tree_M(nv * nv), tree_tau(nv), tree_qdd(nv), pivots(nv);
    eom::tree_mass_matrix<dd_real>(links, Q, tree_M);
    worst.update("tree_mass_matrix", tree_M, M);
    rd.bias_forces(qf, vf, bias);
    R::coriolis(q.data(), v.data(), p.data(), x.data());
    R::potential_gradient(q.data(), p.data(), y.data());
    for (int i = 0; i < nv; ++i) x[i] += y[i];
    worst.update("Reference coriolis + potential_gradient", DD(x.begin(), x.end()), map.down(bias));
    rd.inverse_dynamics(qf, vf, af, tau);
    rd.inverse_dynamics(qf, zero, zero, gravity);
    for (int i = 0; i < nvf; ++i) tau[i] -= gravity[i];
    eom::tree_inverse_dynamics<dd_real>(links, Q, V, A, tree_tau);
    worst.update("tree_inverse_dynamics", tree_tau, map.down(tau));
    EXPECT_TRUE(R::forward_dynamics(0.0, q.data(), v.data(), u.data() + fv, p.data(), x.data()));
    const DD qdd_reference(x.begin(), x.end());
    if (map.mimic) {  // Gᵀ(τ_full − Q_full) − u = 0 at v̇_full = G v̇
      rd.inverse_dynamics(qf, vf, map.up(x), tau);
      map.add_dissipation(vf, tau);
      worst.update("Reference forward_dynamics (as Gᵀ(τ_full − Q_full))", map.down(tau), U);
      continue;
    }
    DD U_net = U, qdd(nv);
    for (int i = 0; i < nv; ++i)
      U_net[i] -= map.friction[i] * tanh(V[i] / dd_real(eom::urdf::friction_smoothing));
    rd.forward_dynamics(Q, V, U_net, qdd);
    worst.update("Reference forward_dynamics", qdd_reference, qdd);
    DD force(nv);
    for (int i = 0; i < nv; ++i) force[i] = U_net[i] - rd.damping()[i] * V[i] - gravity[i];
    eom::tree_forward_dynamics<dd_real>(links, Q, V, force, tree_qdd, pivots);
    worst.update("tree_forward_dynamics", tree_qdd, qdd);
  }
  return worst;
}

// A test's body: the file read with these options and checked (on the caller's stack: eom::Reference
// keeps its big AD numbers on a heap stack of its own); prints the worst relative error and bounds
// it by 1e-12 (the worst measured: 2.4e-13, iCub's forward dynamics).
template <class Model>
void expect_runtime_agrees(const char* name, const std::string& file, eom::urdf::ReadOptions options) {
  Worst w;
  w = check_runtime<Model>(eom::urdf::read(file, options));
  std::printf("%s (%d velocities): runtime vs recursive, worst %.1e (%s)\n", name, eom::Reference<Model>::nv,
              w.value, w.where.c_str());
  EXPECT_LT(w.value, 1e-12) << w.where;
}

}  // namespace eomtest
