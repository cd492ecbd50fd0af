// The composite-rigid-body algorithm (eom::tree_mass_matrix, traced for mass_matrix where it is
// cheaper) against eom::Reference's M = ∂²T/∂v²; ∂τ/∂q and ∂τ/∂v generated (on request) against
// the reference for a URDF arm (every parameter free, and all folded but two), a floating tree and
// a damped planar chain; a 30-link chain from URDF (where the tree's closed form is kept) against
// differences of the recursive RNEA (tests/support) in dd_real; the reference
// itself against central differences of its inverse dynamics in dd_real; the closed form
// (eom::tree_inverse_dynamics_derivatives) against differences of tree_inverse_dynamics in dd_real
// on the Panda, a branching tree and two trees on a free root, and behind M⁻¹ on the Panda and
// two of them on one base;
// FIXED_PARAMETERS ALL / FREE_PARAMETERS resolved and refused as
// documented.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string_view>
#include <string>
#include <vector>

#include <chain30_id.hpp>
#include <chain30_id_model.hpp>
#include <chain5_id.hpp>
#include <free_tree_id.hpp>
#include <models/chain.hpp>
#include <panda_id.hpp>
#include <panda_id_folded.hpp>
#include <panda_id_model.hpp>

#include <qd/dd_real.h>

#include <eom/model/free_joint.hpp>
#include <eom/multibody/tree.hpp>
#include <eom/multibody/tree_derivatives.hpp>
#include <eom/reference/reference.hpp>
#include <eomgen/tracer.hpp>
#include <eomgen/urdf.hpp>

#include "floating_models.hpp"
#include "kernel_error.hpp"
#include "recursive_dynamics.hpp"

namespace {

using eomtest::kernel_error;

template <int nq, int nv> void random_state(std::mt19937_64& rng, std::vector<double>& q, std::vector<double>& v) {
  std::uniform_real_distribution<double> x(-1, 1);
  q.resize(nq);
  v.resize(nv);
  for (double& e : q) e = 1.5 * x(rng);
  for (double& e : v) e = 2 * x(rng);
  eom::normalize_configuration(eom::Layout(nq, nv), q.data());
}

template <class Model> double crba_error(int trials, bool world = false) {
  using R = eom::Reference<Model>;
  std::mt19937_64 rng(2);
  double worst = 0;
  for (int t = 0; t < trials; ++t) {
    std::vector<double> q, v;
    random_state<R::nq, R::nv>(rng, q, v);
    std::array<double, R::nv * R::nv> M, M_tree;
    R::mass_matrix(q.data(), R::parameter_values.data(), M.data());
    const auto links = eom::tree_of<Model, double>(R::parameter_values);
    if (world)
      eom::tree_mass_matrix_world<double>(links, q, M_tree);
    else
      eom::tree_mass_matrix<double>(links, q, M_tree);
    worst = std::max(worst, kernel_error(M_tree.data(), M.data(), R::nv * R::nv));
  }
  return worst;
}

TEST(CompositeRigidBody, MassMatrixMatchesTheReference) {
  const double panda = crba_error<eom::urdf_models::panda_id>(20);
  const double tree = crba_error<floating_test::FreeTree>(20);
  const double body = crba_error<floating_test::FreeBodyTree>(20);
  std::printf("tree_mass_matrix against the reference: panda %.1e, free tree %.1e, free body %.1e\n",
              panda, tree, body);
  EXPECT_LT(panda, 1e-14);
  EXPECT_LT(tree, 1e-14);
  EXPECT_LT(body, 1e-14);
  // The columns' forces dotted in world axes: a fixed base only.
  const double world = crba_error<eom::urdf_models::panda_id>(20, true);
  std::printf("tree_mass_matrix_world against the reference: panda %.1e\n", world);
  EXPECT_LT(world, 1e-14);
  EXPECT_THROW(crba_error<floating_test::FreeTree>(1, true), std::invalid_argument);
}

// The 30-link chain's generated M, by tree_mass_matrix_world where it has fewer operations,
// against the recursive CRBA in dd_real.
TEST(CompositeRigidBody, GeneratedChainMassMatrixMatchesTheRecursiveAlgorithm) {
  using K = chain30_id::Kernels;
  constexpr int n = K::nv;
  eomtest::RecursiveDynamics<dd_real> rd(eom::urdf::read(EOM_CHAIN30_URDF),
                                         eom::urdf_models::chain30_id::parameter_values[0]);
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> x(-1, 1);
  double worst = 0;
  for (int t = 0; t < 20; ++t) {
    std::vector<double> q(n);
    for (double& e : q) e = 3 * x(rng);
    std::array<double, n * n> g, r;
    std::vector<dd_real> Q(q.begin(), q.end()), M(n * n);
    K::mass_matrix(q.data(), nullptr, g.data());
    rd.mass_matrix(Q, M);
    for (int i = 0; i < n * n; ++i) r[i] = to_double(M[i]);
    worst = std::max(worst, kernel_error(g.data(), r.data(), n * n));
  }
  std::printf("chain30 mass_matrix against the recursive CRBA: %.1e\n", worst);
  EXPECT_LT(worst, 1e-14);
}

// The chain's inverse and forward dynamics, gravity taken as the root's upward acceleration in
// the RNEA and the ABA where that is cheaper than ∂V/∂q beside them, against the recursive
// algorithms in dd_real.
TEST(CompositeRigidBody, GeneratedChainDynamicsWithGravityMatchTheRecursiveAlgorithms) {
  using K = chain30_id::Kernels;
  constexpr int n = K::nv;
  eomtest::RecursiveDynamics<dd_real> rd(eom::urdf::read(EOM_CHAIN30_URDF),
                                         eom::urdf_models::chain30_id::parameter_values[0]);
  const std::vector<dd_real>& d = rd.damping();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> x(-1, 1);
  double tau_error = 0, qdd_error = 0;
  for (int t = 0; t < 20; ++t) {
    std::vector<double> q(n), v(n), a(n), u(n), g(n), r(n);
    for (int i = 0; i < n; ++i) q[i] = 3 * x(rng), v[i] = 2 * x(rng), a[i] = 2 * x(rng), u[i] = 50 * x(rng);
    const std::vector<dd_real> Q(q.begin(), q.end()), V(v.begin(), v.end()), A(a.begin(), a.end()),
        U(u.begin(), u.end());
    std::vector<dd_real> out(n);
    K::inverse_dynamics(0.0, q.data(), v.data(), a.data(), u.data(), nullptr, g.data());
    rd.inverse_dynamics(Q, V, A, out);
    for (int i = 0; i < n; ++i) r[i] = to_double(out[i] - (U[i] - d[i] * V[i]));
    tau_error = std::max(tau_error, kernel_error(g.data(), r.data(), n));
    ASSERT_TRUE(K::forward_dynamics(0.0, q.data(), v.data(), u.data(), nullptr, g.data()));
    rd.forward_dynamics(Q, V, U, out);
    for (int i = 0; i < n; ++i) r[i] = to_double(out[i]);
    qdd_error = std::max(qdd_error, kernel_error(g.data(), r.data(), n));
  }
  std::printf("chain30 against the recursive algorithms: inverse_dynamics %.1e, forward_dynamics %.1e\n",
              tau_error, qdd_error);
  EXPECT_LT(tau_error, 1e-14);
  EXPECT_LT(qdd_error, 1e-13);
}

// On a free root gravity as the world's upward acceleration g adds ∂V/∂q = g M e_z (the tree
// lifted at unit speed moves every body up: V's rate is g Σ m ż = g (M e_z)ᵀ v) to the RNEA's τ,
// and the ABA's v̇ at τ is the gravity-free one at τ − g M e_z, M from the composite-rigid-body
// algorithm (independent of both), all in dd_real. The bound is relative, 1e-14: the model's
// constant rotations (eom::constant_rpy, rounded to double) are orthogonal to about 1e-16 only,
// and the CRBA and the RNEA use them differently (M's free columns and the RNEA's at v = 0, v̇ = e
// differ by 1.5e-16 in dd_real and in qd_real alike).
TEST(CompositeRigidBody, GravityAsTheWorldsAccelerationOnAFreeRoot) {
  using floating_test::FreeTree;
  const auto links = eom::tree_of<FreeTree, dd_real>(std::vector<dd_real>(
      FreeTree::parameter_values.begin(), FreeTree::parameter_values.end()));
  constexpr int nq = 10, nv = 9;
  const dd_real g = 9.81;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> x(-1, 1);
  double tau_error = 0, qdd_error = 0;
  for (int t = 0; t < 20; ++t) {
    std::vector<dd_real> q(nq), v(nv), a(nv), tau(nv);
    for (dd_real& e : q) e = x(rng);
    const dd_real norm = sqrt(q[3] * q[3] + q[4] * q[4] + q[5] * q[5] + q[6] * q[6]);
    for (int k = 3; k < 7; ++k) q[k] /= norm;
    for (int i = 0; i < nv; ++i) v[i] = 2 * x(rng), a[i] = 2 * x(rng), tau[i] = 5 * x(rng);
    std::vector<dd_real> M(nv * nv), plain(nv), lifted(nv), pivots(nv);
    eom::tree_mass_matrix<dd_real>(links, q, M);
    eom::tree_inverse_dynamics<dd_real>(links, q, v, a, plain);
    eom::tree_inverse_dynamics<dd_real>(links, q, v, a, lifted, g);
    std::vector<double> got(nv), want(nv);
    for (int i = 0; i < nv; ++i) got[i] = to_double(lifted[i]), want[i] = to_double(plain[i] + g * M[i + nv * 2]);
    tau_error = std::max(tau_error, kernel_error(got.data(), want.data(), nv));
    std::vector<dd_real> shifted = tau;
    for (int i = 0; i < nv; ++i) shifted[i] -= g * M[i + nv * 2];
    eom::tree_forward_dynamics<dd_real>(links, q, v, shifted, plain, pivots);
    eom::tree_forward_dynamics<dd_real>(links, q, v, tau, lifted, pivots, g);
    for (int i = 0; i < nv; ++i) got[i] = to_double(lifted[i]), want[i] = to_double(plain[i]);
    qdd_error = std::max(qdd_error, kernel_error(got.data(), want.data(), nv));
    // the outward pass from the parent's acceleration, the free root's children included
    eom::tree_forward_dynamics<dd_real>(links, q, v, tau, lifted, pivots, g, eom::AbaOutward::from_parent);
    for (int i = 0; i < nv; ++i) got[i] = to_double(lifted[i]);
    qdd_error = std::max(qdd_error, kernel_error(got.data(), want.data(), nv));
  }
  std::printf("free root, gravity as the world's acceleration: tau %.1e, qdd %.1e\n", tau_error, qdd_error);
  EXPECT_LT(tau_error, 1e-14);
  EXPECT_LT(qdd_error, 1e-14);
}

// The generated M (now the traced CRBA for the Panda) against the reference.
TEST(CompositeRigidBody, GeneratedMassMatrixMatchesTheReference) {
  using K = panda_id::Kernels;
  using R = eom::Reference<eom::urdf_models::panda_id>;
  std::mt19937_64 rng(4);
  double worst = 0;
  for (int t = 0; t < 20; ++t) {
    std::vector<double> q, v;
    random_state<K::nq, K::nv>(rng, q, v);
    std::array<double, K::nv * K::nv> g, r;
    K::mass_matrix(q.data(), K::parameter_values.data(), g.data());
    R::mass_matrix(q.data(), K::parameter_values.data(), r.data());
    worst = std::max(worst, kernel_error(g.data(), r.data(), K::nv * K::nv));
  }
  EXPECT_LT(worst, 1e-14);
}

// Generated ∂τ/∂q, ∂τ/∂v of K against the reference of Model at parameters p.
template <class K, class Model> void compare(const char* name, const std::array<double, eom::ModelInfo<Model>::np>& p) {
  using R = eom::Reference<Model>;
  constexpr int nq = K::nq, nv = K::nv, nu = K::nu;
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> x(-1, 1);
  double worst = 0;
  for (int t = 0; t < 20; ++t) {
    std::vector<double> q, v, a(nv), u(nu + 1);
    random_state<nq, nv>(rng, q, v);
    for (double& e : a) e = 2 * x(rng);
    for (double& e : u) e = x(rng);
    std::array<double, nv * nv> gq, gv, rq, rv;
    K::inverse_dynamics_derivatives(0.3, q.data(), v.data(), a.data(), u.data(),
                                    K::parameter_values.data(), gq.data(), gv.data());
    R::inverse_dynamics_derivatives(0.3, q.data(), v.data(), a.data(), u.data(), p.data(), rq.data(), rv.data());
    worst = std::max({worst, kernel_error(gq.data(), rq.data(), nv * nv), kernel_error(gv.data(), rv.data(), nv * nv)});
  }
  std::printf("%-16s inverse_dynamics_derivatives against the reference: %.1e\n", name, worst);
  EXPECT_LT(worst, 1e-12) << name;
}

TEST(InverseDynamicsDerivatives, GeneratedMatchTheReference) {
  compare<panda_id::Kernels, eom::urdf_models::panda_id>("panda", panda_id::parameter_values);
  compare<free_tree_id::Kernels, floating_test::FreeTree>("free_tree", free_tree_id::parameter_values);
  compare<chain5_id::Kernels, eom::models::Chain<5>>("chain5", chain5_id::parameter_values);
  // Folded: every parameter at its default but g = 9.80665 and link 7's mass, which stays free.
  using R = eom::Reference<eom::urdf_models::panda_id>;
  static_assert(panda_id_folded::np == 1);
  EXPECT_EQ(panda_id_folded::parameter_names[0], "panda_link7_mass");
  auto p = R::parameter_values;
  p[0] = 9.80665;
  compare<panda_id_folded::Kernels, eom::urdf_models::panda_id>("panda (folded)", p);
}

// A 30-link chain read from URDF, where the generator keeps the tree's closed form (with gravity:
// 10,413 operations, against 37,625 by sweeps): against central differences (h = 1e-10) of the
// recursive RNEA in dd_real minus Q = u − d⊙v, and at the first state against eom::Reference
// (whose numbers for all 60 directions at once overflowed its stack on this model).
TEST(InverseDynamicsDerivatives, GeneratedClosedFormMatchesTheRecursiveAlgorithm) {
  using K = chain30_id::Kernels;
  using DD = std::vector<dd_real>;
  constexpr int n = K::nv;
  static_assert(K::np == 0);
  ASSERT_EQ(std::string_view(eom::urdf_models::chain30_id::parameters[0]), "g");
  eomtest::RecursiveDynamics<dd_real> rd(eom::urdf::read(EOM_CHAIN30_URDF),
                                         eom::urdf_models::chain30_id::parameter_values[0]);
  const DD& d = rd.damping();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> x(-1, 1);
  double worst = 0, reference = 1;  // reference: 1 unless computed
  for (int t = 0; t < 3; ++t) {
    std::vector<double> q(n), v(n), a(n), u(n);
    for (int i = 0; i < n; ++i) q[i] = 1.5 * x(rng), v[i] = 2 * x(rng), a[i] = 2 * x(rng), u[i] = x(rng);
    std::array<double, n * n> gq, gv, rq, rv;
    K::inverse_dynamics_derivatives(0.0, q.data(), v.data(), a.data(), u.data(), nullptr, gq.data(), gv.data());
    const DD Q(q.begin(), q.end()), V(v.begin(), v.end()), A(a.begin(), a.end());
    auto tau = [&](const DD& q_, const DD& v_) {
      DD r(n);
      rd.inverse_dynamics(q_, v_, A, r);
      for (int i = 0; i < n; ++i) r[i] -= u[i] - d[i] * v_[i];
      return r;
    };
    const dd_real h(1e-10);
    for (int j = 0; j < n; ++j) {
      DD qp = Q, qm = Q, vp = V, vm = V;
      qp[j] += h, qm[j] -= h, vp[j] += h, vm[j] -= h;
      const DD tqp = tau(qp, V), tqm = tau(qm, V), tvp = tau(Q, vp), tvm = tau(Q, vm);
      for (int i = 0; i < n; ++i) {
        rq[i + n * j] = to_double((tqp[i] - tqm[i]) / (2.0 * h));
        rv[i + n * j] = to_double((tvp[i] - tvm[i]) / (2.0 * h));
      }
    }
    worst = std::max({worst, kernel_error(gq.data(), rq.data(), n * n), kernel_error(gv.data(), rv.data(), n * n)});
    if (t == 0) {
      using R = eom::Reference<eom::urdf_models::chain30_id>;
      R::inverse_dynamics_derivatives(0.0, q.data(), v.data(), a.data(), u.data(),
                                      R::parameter_values.data(), rq.data(), rv.data());
      reference = std::max(kernel_error(gq.data(), rq.data(), n * n), kernel_error(gv.data(), rv.data(), n * n));
    }
  }
  std::printf("chain30 (closed form) inverse_dynamics_derivatives against differences: %.1e, "
              "against the reference: %.1e\n", worst, reference);
  EXPECT_LT(worst, 1e-13);
  EXPECT_LT(reference, 1e-13);
}

// ∂τ/∂q along the tangent directions and ∂τ/∂v against central differences in dd_real (ε = 1e-12).
template <class Model> void reference_against_differences(const char* name) {
  using RD = eom::Reference<Model, dd_real>;
  constexpr int nq = RD::nq, nv = RD::nv, nu = RD::nu, np = RD::np;
  std::mt19937_64 rng(21);
  std::vector<double> qd_, vd_;
  random_state<nq, nv>(rng, qd_, vd_);
  std::array<dd_real, nq> q;
  std::array<dd_real, nv> v, a;
  std::array<dd_real, nu + 1> u;
  std::array<dd_real, np> p;
  for (int i = 0; i < nq; ++i) q[i] = qd_[i];
  for (int i = 0; i < nv; ++i) v[i] = vd_[i], a[i] = 0.3 - 0.1 * i;
  for (int i = 0; i <= nu; ++i) u[i] = 0.2 * i;
  for (int i = 0; i < np; ++i) p[i] = RD::parameter_values[i];
  eom::normalize_configuration(eom::Layout(nq, nv), q.data());
  std::array<dd_real, nv * nv> dq, dv;
  const dd_real t(0.3), eps("1e-12");
  RD::inverse_dynamics_derivatives(t, q.data(), v.data(), a.data(), u.data(), p.data(), dq.data(), dv.data());
  double worst = 0;
  for (int j = 0; j < nv; ++j) {
    std::array<dd_real, nv> e{}, tp, tm;
    e[j] = 1.0;
    std::array<dd_real, nq> qp, qm;
    eom::integrate_configuration(eom::Layout(nq, nv), q.data(), e.data(), eps, qp.data());
    eom::integrate_configuration(eom::Layout(nq, nv), q.data(), e.data(), dd_real(-eps), qm.data());
    RD::inverse_dynamics(t, qp.data(), v.data(), a.data(), u.data(), p.data(), tp.data());
    RD::inverse_dynamics(t, qm.data(), v.data(), a.data(), u.data(), p.data(), tm.data());
    for (int i = 0; i < nv; ++i)
      worst = std::max(worst, to_double(abs((tp[i] - tm[i]) / (2 * eps) - dq[i + nv * j])));
    auto vp = v, vm = v;
    vp[j] += eps;
    vm[j] -= eps;
    RD::inverse_dynamics(t, q.data(), vp.data(), a.data(), u.data(), p.data(), tp.data());
    RD::inverse_dynamics(t, q.data(), vm.data(), a.data(), u.data(), p.data(), tm.data());
    for (int i = 0; i < nv; ++i)
      worst = std::max(worst, to_double(abs((tp[i] - tm[i]) / (2 * eps) - dv[i + nv * j])));
  }
  std::printf("%-16s reference ∂τ/∂(q, v) against differences in dd_real: %.1e\n", name, worst);
  EXPECT_LT(worst, 1e-17) << name;
}

TEST(InverseDynamicsDerivatives, ReferenceAgreesWithDifferences) {
  reference_against_differences<floating_test::FreeTree>("free_tree");
  reference_against_differences<eom::models::Chain<5>>("chain5");
}

// A branching tree with what the Panda lacks: prismatic joints (one on a tilted axis), a revolute
// joint on a tilted axis and one on −z, a fixed joint carrying a body, a massless end link, inertias
// off centre and turned.
template <class S> std::array<eom::TreeLink<S>, 7> branching_tree() {
  std::array<eom::TreeLink<S>, 7> l;
  auto joint = [&](int i, int parent, std::array<double, 3> xyz, std::array<double, 3> rpy, int coordinate,
                   std::array<double, 3> axis, bool prismatic) {
    l[i].parent = parent;
    l[i].origin = eom::origin<S>(xyz, rpy);
    l[i].coordinate = coordinate;
    l[i].axis = axis;
    l[i].prismatic = prismatic;
  };
  auto body = [&](int i, double m, std::array<double, 3> c, std::array<double, 3> rpy) {
    l[i].mass = S(m);
    l[i].inertia = {S(0.02), S(0.03), S(0.025), S(0.001), S(-0.002), S(0.0015)};
    l[i].inertial = eom::origin<S>(c, rpy);
  };
  joint(0, -1, {0.1, 0.0, 0.3}, {0.0, 0.2, 0.0}, 0, {0, 0, 1}, false);
  body(0, 2.0, {0.05, 0.01, 0.1}, {0.1, 0, 0});
  joint(1, 0, {0.0, 0.1, 0.2}, {0.3, 0.0, 0.1}, 1, {0.3, 1, 0.2}, false);
  body(1, 1.5, {0.2, 0.0, 0.0}, {0, 0.3, 0});
  joint(2, 1, {0.4, 0.0, 0.0}, {0.0, 0.0, 0.0}, 2, {1, 0, 0}, true);
  body(2, 0.8, {0.1, 0.02, 0.0}, {0, 0, 0.2});
  joint(3, 2, {0.1, 0.0, 0.05}, {0.0, 0.5, 0.0}, -1, {0, 0, 1}, false);
  body(3, 0.3, {0.0, 0.05, 0.0}, {0, 0, 0});
  joint(4, 3, {0.0, 0.2, 0.0}, {0.2, 0.0, 0.0}, 3, {0, 1, 0}, false);
  body(4, 0.6, {0.0, 0.1, 0.02}, {0.2, 0.1, 0});
  joint(5, 0, {0.0, -0.2, 0.1}, {0.0, 0.0, 0.4}, 4, {0, 0, -1}, false);
  body(5, 1.1, {0.1, -0.1, 0.0}, {0, 0, 0});
  joint(6, 5, {0.3, 0.0, 0.0}, {0.0, 0.0, 0.0}, 5, {0, 1, 1}, true);  // massless
  return l;
}

// M⁻¹ B in dd_real (M symmetric positive definite, column-major), rounded to double.
template <int n>
std::array<double, n * n> solved(std::array<dd_real, n * n> M, const std::array<double, n * n>& B) {
  std::array<dd_real, n * n> X;
  for (int k = 0; k < n * n; ++k) X[k] = B[k];
  for (int k = 0; k < n; ++k)  // Gaussian elimination without pivoting (M is positive definite)
    for (int i = k + 1; i < n; ++i) {
      const dd_real f = M[i + n * k] / M[k + n * k];
      for (int j = k; j < n; ++j) M[i + n * j] -= f * M[k + n * j];
      for (int j = 0; j < n; ++j) X[i + n * j] -= f * X[k + n * j];
    }
  std::array<double, n * n> r;
  for (int j = 0; j < n; ++j)
    for (int k = n - 1; k >= 0; --k) {
      dd_real x = X[k + n * j];
      for (int i = k + 1; i < n; ++i) x -= M[k + n * i] * X[i + n * j];
      X[k + n * j] = x / M[k + n * k];
      r[k + n * j] = to_double(X[k + n * j]);
    }
  return r;
}

// The closed form in double against central differences of tree_inverse_dynamics in dd_real
// (ε = 1e-12), both blocks, on random states: max error over max(1, max |∂τ|); behind_solve:
// of M⁻¹ ∂τ (M in dd_real, what forward_dynamics_derivatives makes of ∂τ), over max(1, max |M⁻¹ ∂τ|).
template <int nv>
double closed_form_error(const auto& links, const auto& links_dd, int trials, bool behind_solve = false) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> x(-1, 1);
  double worst = 0;
  for (int t = 0; t < trials; ++t) {
    std::array<double, nv> q, v, a;
    for (int i = 0; i < nv; ++i) q[i] = 1.5 * x(rng), v[i] = 2 * x(rng), a[i] = 2 * x(rng);
    std::array<double, nv * nv> dq, dv;
    eom::tree_inverse_dynamics_derivatives<double>(links, q, v, a, dq, dv);
    std::array<dd_real, nv> Q, V, A, tp, tm;
    for (int i = 0; i < nv; ++i) Q[i] = q[i], V[i] = v[i], A[i] = a[i];
    const dd_real eps("1e-12");
    std::array<double, nv * nv> rq, rv;
    for (int j = 0; j < nv; ++j) {
      auto Qp = Q, Qm = Q, Vp = V, Vm = V;
      Qp[j] += eps, Qm[j] -= eps, Vp[j] += eps, Vm[j] -= eps;
      eom::tree_inverse_dynamics<dd_real>(links_dd, Qp, V, A, tp);
      eom::tree_inverse_dynamics<dd_real>(links_dd, Qm, V, A, tm);
      for (int i = 0; i < nv; ++i) rq[i + nv * j] = to_double((tp[i] - tm[i]) / (2 * eps));
      eom::tree_inverse_dynamics<dd_real>(links_dd, Q, Vp, A, tp);
      eom::tree_inverse_dynamics<dd_real>(links_dd, Q, Vm, A, tm);
      for (int i = 0; i < nv; ++i) rv[i + nv * j] = to_double((tp[i] - tm[i]) / (2 * eps));
    }
    if (behind_solve) {
      std::array<dd_real, nv * nv> M;
      eom::tree_mass_matrix<dd_real>(links_dd, Q, M);
      for (auto* x : {&dq, &dv, &rq, &rv}) *x = solved<nv>(M, *x);
    }
    worst = std::max({worst, kernel_error(dq.data(), rq.data(), nv * nv), kernel_error(dv.data(), rv.data(), nv * nv)});
  }
  return worst;
}


TEST(TreeDerivatives, ClosedFormMatchesDifferences) {
  using Panda = eom::urdf_models::panda_id;
  using R = eom::Reference<Panda>;
  std::array<dd_real, R::np> p_dd;
  for (int i = 0; i < R::np; ++i) p_dd[i] = R::parameter_values[i];
  const double panda = closed_form_error<R::nv>(eom::tree_of<Panda, double>(R::parameter_values),
                                                eom::tree_of<Panda, dd_real>(p_dd), 10);
  const double tree = closed_form_error<6>(branching_tree<double>(), branching_tree<dd_real>(), 10);
  std::printf("tree_inverse_dynamics_derivatives against differences in dd_real: panda %.1e, "
              "branching tree %.1e\n", panda, tree);
  EXPECT_LT(panda, 1e-13);
  EXPECT_LT(tree, 1e-13);
}

// Two of a tree's arms on one fixed base, side by side (their roots 1.2 apart): two branches.
template <class S, std::size_t N>
std::array<eom::TreeLink<S>, 2 * N> two_arms(const std::array<eom::TreeLink<S>, N>& arm) {
  std::array<eom::TreeLink<S>, 2 * N> l;
  for (std::size_t i = 0; i < N; ++i) {
    l[i] = l[i + N] = arm[i];
    l[i + N].coordinate += static_cast<int>(N);
    if (arm[i].parent >= 0) l[i + N].parent += static_cast<int>(N);
  }
  l[0].origin.translation[1] = l[0].origin.translation[1] - S(0.6);
  l[N].origin.translation[1] = l[N].origin.translation[1] + S(0.6);
  return l;
}

// Behind a solve the closed form must keep the rounding of the rows solved for: M⁻¹ magnifies
// the light links' rows, where a subtree's inertia about a far point has large terms that cancel.
// About the world origin (before) 2.5e-14 (the Panda) and 3.5e-14 (two Pandas) here; about each
// branch's end 3.7e-15 and 3.3e-15.
TEST(TreeDerivatives, ClosedFormIsAccurateBehindASolve) {
  using Panda = eom::urdf_models::panda_id;
  using R = eom::Reference<Panda>;
  static_assert(R::nv == R::nq && R::nv == 7);
  std::array<dd_real, R::np> p_dd;
  for (int i = 0; i < R::np; ++i) p_dd[i] = R::parameter_values[i];
  const auto arm = eom::tree_of<Panda, double>(R::parameter_values);
  const auto arm_dd = eom::tree_of<Panda, dd_real>(p_dd);
  const double panda = closed_form_error<7>(arm, arm_dd, 20, true);
  const double two = closed_form_error<14>(two_arms(arm), two_arms(arm_dd), 20, true);
  std::printf("M⁻¹ tree_inverse_dynamics_derivatives against differences in dd_real: panda %.1e, "
              "two pandas %.1e\n", panda, two);
  EXPECT_LT(panda, 8e-15);
  EXPECT_LT(two, 8e-15);
}

// With gravity g (the URDF header's V = g Σ m z): ∂τ/∂q against the reference's, whose τ has ∂V/∂q
// (Q = u − d⊙v does not depend on q); ∂τ/∂v is unchanged by gravity.
TEST(TreeDerivatives, ClosedFormCarriesGravity) {
  using Panda = eom::urdf_models::panda_id;
  using R = eom::Reference<Panda>;
  ASSERT_EQ(std::string_view(Panda::parameters[0]), "g");
  const auto& p = R::parameter_values;
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> x(-1, 1);
  double worst = 0;
  for (int t = 0; t < 10; ++t) {
    std::vector<double> q, v, a(R::nv), u(R::nu, 0.0);
    random_state<R::nq, R::nv>(rng, q, v);
    for (double& e : a) e = 2 * x(rng);
    std::array<double, R::nv * R::nv> dq, dv, dq0, dv0, rq, rv;
    R::inverse_dynamics_derivatives(0.3, q.data(), v.data(), a.data(), u.data(), p.data(), rq.data(), rv.data());
    const auto links = eom::tree_of<Panda, double>(p);
    eom::tree_inverse_dynamics_derivatives<double>(links, q, v, a, dq, dv, p[0]);
    eom::tree_inverse_dynamics_derivatives<double>(links, q, v, a, dq0, dv0);
    worst = std::max({worst, kernel_error(dq.data(), rq.data(), R::nv * R::nv),
                      kernel_error(dv.data(), dv0.data(), R::nv * R::nv)});
  }
  std::printf("tree_inverse_dynamics_derivatives with gravity against the reference: panda %.1e\n", worst);
  EXPECT_LT(worst, 1e-13);
}

// τ and M against tree_inverse_dynamics and the link-axes tree_mass_matrix in dd_real at (Q, V, A).
template <std::size_t nq, std::size_t nv>
double byproducts_error_at(const auto& links_dd, const std::array<dd_real, nq>& Q,
                           const std::array<dd_real, nv>& V, const std::array<dd_real, nv>& A,
                           const std::array<double, nv>& tau, const std::array<double, nv * nv>& M) {
  std::array<dd_real, nv> tau_dd;
  std::array<dd_real, nv * nv> M_dd;
  eom::tree_inverse_dynamics<dd_real>(links_dd, Q, V, A, tau_dd);
  eom::tree_mass_matrix<dd_real>(links_dd, Q, M_dd);
  std::array<double, nv> rt;
  std::array<double, nv * nv> rm;
  for (std::size_t i = 0; i < nv; ++i) rt[i] = to_double(tau_dd[i]);
  for (std::size_t k = 0; k < nv * nv; ++k) rm[k] = to_double(M_dd[k]);
  return std::max(kernel_error(tau.data(), rt.data(), nv), kernel_error(M.data(), rm.data(), nv * nv));
}

// The by-products τ and M (about each branch's end) against tree_inverse_dynamics and the
// link-axes tree_mass_matrix in dd_real, on the Panda and the branching tree; M exactly symmetric.
template <int nv>
double byproducts_error(const auto& links, const auto& links_dd, int trials) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> x(-1, 1);
  double worst = 0;
  for (int t = 0; t < trials; ++t) {
    std::array<double, nv> q, v, a, tau;
    for (int i = 0; i < nv; ++i) q[i] = 1.5 * x(rng), v[i] = 2 * x(rng), a[i] = 2 * x(rng);
    std::array<double, nv * nv> dq, dv, M;
    eom::tree_inverse_dynamics_derivatives<double>(links, q, v, a, dq, dv, 0.0, tau, M);
    std::array<dd_real, nv> Q, V, A;
    for (int i = 0; i < nv; ++i) Q[i] = q[i], V[i] = v[i], A[i] = a[i];
    worst = std::max(worst, byproducts_error_at(links_dd, Q, V, A, tau, M));
    for (int i = 0; i < nv; ++i)
      for (int j = 0; j < nv; ++j) EXPECT_EQ(M[i + nv * j], M[j + nv * i]);
  }
  return worst;
}

TEST(TreeDerivatives, ClosedFormGivesTauAndTheMassMatrix) {
  using Panda = eom::urdf_models::panda_id;
  using R = eom::Reference<Panda>;
  std::array<dd_real, R::np> p_dd;
  for (int i = 0; i < R::np; ++i) p_dd[i] = R::parameter_values[i];
  const double panda = byproducts_error<R::nv>(eom::tree_of<Panda, double>(R::parameter_values),
                                               eom::tree_of<Panda, dd_real>(p_dd), 10);
  const double tree = byproducts_error<6>(branching_tree<double>(), branching_tree<dd_real>(), 10);
  std::printf("tree_inverse_dynamics_derivatives' tau and M against the recursions in dd_real: "
              "panda %.1e, branching tree %.1e\n", panda, tree);
  EXPECT_LT(panda, 1e-14);
  EXPECT_LT(tree, 1e-14);
  // outputs of the wrong size are refused, naming the sizes
  const auto links = branching_tree<double>();
  std::vector<double> x(6, 0.1), d(36), short_tau(5);
  EXPECT_THROW(eom::tree_inverse_dynamics_derivatives<double>(links, x, x, x, d, d, 0.0, short_tau),
               std::invalid_argument);
  EXPECT_THROW(eom::tree_inverse_dynamics_derivatives<double>(links, x, x, x, d, std::span(d).first(35)),
               std::invalid_argument);
}

// The articulated-body algorithm takes the articulated inertia's row and column along a joint's
// coordinate axis as ±U a / D (a the rotor's armature: zero without one) rather than Iᴬ − U U_k / D,
// and its outward pass two ways (eom::AbaOutward): on the branching tree (revolute joints about
// ±z and ±y, prismatic ones along ±x, tilted axes), with and without armature and with every axis
// reversed, in dd_real, its v̇ against the composite-rigid-body M and the RNEA's c: M v̇ + c = τ.
// Not to 1e-30: a tilted axis's rotation takes products of the axis's components in double
// (3.7e-17 on a scratch tree).
TEST(ArticulatedBody, CoordinateAxesWithAndWithoutRotors) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> x(-1, 1);
  double worst = 0;
  for (int variant = 0; variant < 8; ++variant) {
    const auto outward = variant & 4 ? eom::AbaOutward::from_parent : eom::AbaOutward::carried;
    auto links = branching_tree<dd_real>();
    for (auto& l : links) {
      if (variant & 1) l.axis = {-l.axis[0], -l.axis[1], -l.axis[2]};
      if (variant & 2 && l.coordinate >= 0) l.armature = 0.01 * (l.coordinate + 1);
    }
    constexpr int n = 6;
    for (int trial = 0; trial < 10; ++trial) {
      std::vector<dd_real> q(n), v(n), tau(n), a(n), pivots(n), M(n * n), c(n), zero(n, dd_real(0));
      for (int i = 0; i < n; ++i) q[i] = 1.5 * x(rng), v[i] = 2 * x(rng), tau[i] = 2 * x(rng);
      eom::tree_forward_dynamics<dd_real>(links, q, v, tau, a, pivots, outward);
      eom::tree_mass_matrix<dd_real>(links, q, M);
      eom::tree_inverse_dynamics<dd_real>(links, q, v, zero, c);
      for (int i = 0; i < n; ++i) {
        dd_real r = c[i] - tau[i];
        for (int j = 0; j < n; ++j) r += M[i * n + j] * a[j];
        worst = std::max(worst, std::abs(to_double(r)) / 2);  // |τ| ≤ 2
      }
    }
  }
  std::printf("the ABA's M v̇ + c − τ, relative: %.2e\n", worst);
  EXPECT_LE(worst, 1e-15);  // a rotor's sign taken wrong: 0.6 on a scratch tree
}

TEST(TreeDerivatives, ClosedFormRefusesBallAndMimicJoints) {
  using Top = floating_test::BallTop;
  const auto top = eom::tree_of<Top, double>(eom::ModelInfo<Top>::default_parameters());
  std::vector<double> q(eom::ModelInfo<Top>::nq, 0.0), v(eom::ModelInfo<Top>::nv, 0.0),
      d(v.size() * v.size());
  q[1] = 1.0;
  EXPECT_THROW(eom::tree_inverse_dynamics_derivatives<double>(top, q, v, v, d, d), std::invalid_argument);
  auto mimic = branching_tree<double>();
  mimic[4].coordinate = 2;  // link 4 follows link 2's coordinate: a mimic joint
  mimic[4].multiplier = 0.5;
  mimic[5].coordinate = 3;
  mimic[6].coordinate = 4;
  std::vector<double> x(5, 0.1), dm(25);
  EXPECT_THROW(eom::tree_inverse_dynamics_derivatives<double>(mimic, x, x, x, dm, dm), std::invalid_argument);
}

// A free root (docs/CONTRACT.md §1: v = [ẋ world, ω root axes], ∂/∂q along q ⊕ δ): the closed form
// against central differences of tree_inverse_dynamics in dd_real (ε = 1e-12) along the tangent
// directions, with gravity (the root's ẍ raised by g there) and without; τ and M against the
// recursions. A tree with an arm and a slider (FreeTree), and a lone body whose centre of mass is
// off its origin (FreeBodyTree).
template <class Model> void free_root_against_differences(const char* name) {
  using Info = eom::ModelInfo<Model>;
  constexpr int nq = Info::nq, nv = Info::nv;
  const auto p = Info::default_parameters();
  std::array<dd_real, Info::np> p_dd;
  for (int i = 0; i < Info::np; ++i) p_dd[i] = p[i];
  const auto links = eom::tree_of<Model, double>(p);
  const auto links_dd = eom::tree_of<Model, dd_real>(p_dd);
  const eom::Layout layout(nq, nv);
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> x(-1, 1);
  double worst = 0, byproducts = 0;
  for (int t = 0; t < 10; ++t) {
    std::vector<double> qv, vv;
    random_state<nq, nv>(rng, qv, vv);
    std::array<double, nq> q;
    std::array<double, nv> v, a, tau;
    std::copy(qv.begin(), qv.end(), q.begin());
    std::copy(vv.begin(), vv.end(), v.begin());
    for (double& e : a) e = 2 * x(rng);
    const double g = t % 2 ? 9.81 : 0.0;
    std::array<double, nv * nv> dq, dv, M;
    eom::tree_inverse_dynamics_derivatives<double>(links, q, v, a, dq, dv, g, tau, M);
    std::array<dd_real, nq> Q;
    std::array<dd_real, nv> V, A, tp, tm;
    for (int i = 0; i < nq; ++i) Q[i] = q[i];
    // unit in dd_real too: the closed form turns the tree rigidly, the differences would also
    // see the double quaternion's norm (5.5e-15 here, not 7e-16)
    eom::normalize_configuration(layout, Q.data());
    for (int i = 0; i < nv; ++i) V[i] = v[i], A[i] = a[i];
    A[2] += g;  // gravity: the root accelerated upwards at g
    const dd_real eps("1e-12");
    std::array<double, nv * nv> rq, rv;
    for (int j = 0; j < nv; ++j) {
      std::array<dd_real, nv> e{};
      e[j] = 1.0;
      std::array<dd_real, nq> Qp, Qm;
      eom::integrate_configuration(layout, Q.data(), e.data(), eps, Qp.data());
      eom::integrate_configuration(layout, Q.data(), e.data(), dd_real(-eps), Qm.data());
      eom::tree_inverse_dynamics<dd_real>(links_dd, Qp, V, A, tp);
      eom::tree_inverse_dynamics<dd_real>(links_dd, Qm, V, A, tm);
      for (int i = 0; i < nv; ++i) rq[i + nv * j] = to_double((tp[i] - tm[i]) / (2 * eps));
      auto Vp = V, Vm = V;
      Vp[j] += eps, Vm[j] -= eps;
      eom::tree_inverse_dynamics<dd_real>(links_dd, Q, Vp, A, tp);
      eom::tree_inverse_dynamics<dd_real>(links_dd, Q, Vm, A, tm);
      for (int i = 0; i < nv; ++i) rv[i + nv * j] = to_double((tp[i] - tm[i]) / (2 * eps));
    }
    worst = std::max({worst, kernel_error(dq.data(), rq.data(), nv * nv), kernel_error(dv.data(), rv.data(), nv * nv)});
    byproducts = std::max(byproducts, byproducts_error_at(links_dd, Q, V, A, tau, M));
  }
  std::printf("%-14s free root: tree_inverse_dynamics_derivatives against differences in dd_real "
              "%.1e, tau and M %.1e\n", name, worst, byproducts);
  EXPECT_LT(worst, 1e-13) << name;
  EXPECT_LT(byproducts, 1e-14) << name;
}

TEST(TreeDerivatives, ClosedFormWithAFreeRootMatchesDifferences) {
  free_root_against_differences<floating_test::FreeTree>("free_tree");
  free_root_against_differences<floating_test::FreeBodyTree>("free_body");
}

TEST(FixedParametersAll, ResolvesAndRefusesAsDocumented) {
  using eom::gen::TracerError;
  const std::array<std::string_view, 3> names{"m", "k", "g"};
  const std::array<double, 3> defaults{1.0, 75.0, 9.81};
  eom::gen::TracerOptions o;
  o.fixed = {"ALL", "g=9.8"};
  o.free = {"k"};
  const auto fixed = eom::gen::resolve_fixed(o, names, defaults);
  ASSERT_EQ(fixed.size(), 3u);
  EXPECT_EQ(fixed[0], 1.0);
  EXPECT_FALSE(fixed[1].has_value());
  EXPECT_EQ(fixed[2], 9.8);
  auto error = [&](std::vector<std::string> f, std::vector<std::string> free) {
    o.fixed = std::move(f);
    o.free = std::move(free);
    try {
      eom::gen::resolve_fixed(o, names, defaults);
    } catch (const TracerError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error({"ALL"}, {"kk"}),
            "FREE_PARAMETERS: unknown parameter 'kk'; did you mean 'k'? (the model's parameters: m, k, g)");
  EXPECT_NE(error({"g=1"}, {"k"}).find("FREE_PARAMETERS names the exceptions to FIXED_PARAMETERS ALL"),
            std::string::npos);
  EXPECT_EQ(error({"ALL", "ALL"}, {}), "FIXED_PARAMETERS gives ALL twice");
  EXPECT_NE(error({"ALL", "k=3"}, {"k"}).find("both in FIXED_PARAMETERS"), std::string::npos);
}

}  // namespace
