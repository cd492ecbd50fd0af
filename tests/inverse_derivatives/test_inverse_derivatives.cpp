// The composite-rigid-body algorithm (eom::tree_mass_matrix, traced for mass_matrix where it is
// cheaper) against eom::Reference's M = ∂²T/∂v²; ∂τ/∂q and ∂τ/∂v generated (on request) against
// the reference for a URDF arm (every parameter free, and all folded but two), a floating tree and
// a damped planar chain; the reference itself against central differences of its inverse dynamics
// in dd_real; FIXED_PARAMETERS ALL / FREE_PARAMETERS resolved and refused as documented.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <chain5_id.hpp>
#include <free_tree_id.hpp>
#include <models/chain.hpp>
#include <panda_id.hpp>
#include <panda_id_folded.hpp>
#include <panda_id_model.hpp>

#include <qd/dd_real.h>

#include <eom/free_joint.hpp>
#include <eom/reference.hpp>
#include <eom/tree.hpp>
#include <eomgen/tracer.hpp>

#include "floating_models.hpp"
#include "kernel_error.hpp"

namespace {

using eomtest::kernel_error;

template <int nq, int nv> void random_state(std::mt19937_64& rng, std::vector<double>& q, std::vector<double>& v) {
  std::uniform_real_distribution<double> x(-1, 1);
  q.resize(nq);
  v.resize(nv);
  for (double& e : q) e = 1.5 * x(rng);
  for (double& e : v) e = 2 * x(rng);
  eom::normalize_configuration(nq, nv, q.data());
}

template <class Model> double crba_error(int trials) {
  using R = eom::Reference<Model>;
  std::mt19937_64 rng(2);
  double worst = 0;
  for (int t = 0; t < trials; ++t) {
    std::vector<double> q, v;
    random_state<R::nq, R::nv>(rng, q, v);
    std::array<double, R::nv * R::nv> M, M_tree;
    R::mass_matrix(q.data(), R::parameter_values.data(), M.data());
    eom::tree_mass_matrix<double>(eom::tree_of<Model, double>(R::parameter_values), q, M_tree);
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
  eom::normalize_configuration(nq, nv, q.data());
  std::array<dd_real, nv * nv> dq, dv;
  const dd_real t(0.3), eps("1e-12");
  RD::inverse_dynamics_derivatives(t, q.data(), v.data(), a.data(), u.data(), p.data(), dq.data(), dv.data());
  double worst = 0;
  for (int j = 0; j < nv; ++j) {
    std::array<dd_real, nv> e{}, tp, tm;
    e[j] = 1.0;
    std::array<dd_real, nq> qp, qm;
    eom::integrate_configuration(nq, nv, q.data(), e.data(), eps, qp.data());
    eom::integrate_configuration(nq, nv, q.data(), e.data(), dd_real(-eps), qm.data());
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
