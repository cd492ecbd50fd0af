// The bundled robots (models/robots: Panda, UR5, our branched robot), generated from their URDF
// files (the Lagrangian route, and for inverse and forward dynamics the tree form's recursive
// algorithms where cheaper), against Featherstone's recursive algorithms run in dd_real on
// the same files (tests/support/recursive_dynamics.hpp: its own spatial algebra, written from the
// book): M against CRBA, c + ∂V/∂q and ∂V/∂q against RNEA, inverse dynamics against RNEA − Q,
// forward dynamics against ABA, T, and ∂q̈/∂(q, q̇, u) against fourth-order central differences of
// the ABA in dd_real; 200 random states each. Then energy conservation with damping off.
#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <branched_robot.hpp>
#include <branched_robot_model.hpp>
#include <panda.hpp>
#include <panda_model.hpp>
#include <ur5.hpp>
#include <ur5_model.hpp>

#include <eom/integration/integrate.hpp>
#include <eom/multibody/tree.hpp>
#include <eomgen/urdf.hpp>
#include <recursive_dynamics.hpp>

namespace {

using DD = std::vector<dd_real>;

struct Worst {
  double value = 0;
  std::string where;
  // max-abs difference / max(1, max-abs reference), as in tests/kernels.
  void update(const char* kernel, const double* got, const DD& expected) {
    double diff = 0, scale = 1;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      diff = std::max(diff, std::abs(got[i] - to_double(expected[i])));
      scale = std::max(scale, std::abs(to_double(expected[i])));
    }
    if (diff / scale > value) value = diff / scale, where = kernel;
  }
};

template <class K>
Worst compare_with_recursive(const char* file) {
  const eom::urdf::Robot robot = eom::urdf::read(std::string(EOM_ROBOTS_DIR) + "/" + file);
  eomtest::RecursiveDynamics<dd_real> rd(robot);
  constexpr int n = K::nq;
  EXPECT_EQ(rd.nq(), n);
  const auto& p = K::parameter_values;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-3.0, 3.0), rate(-2.0, 2.0), slide(-0.1, 0.1);
  Worst worst;
  auto lift = [](const double* x, int m) { return DD(x, x + m); };
  std::vector<bool> prismatic;  // per coordinate: the moving joints in file order
  for (const auto& j : robot.joints)
    if (j.type != eom::urdf::JointType::fixed) prismatic.push_back(j.type == eom::urdf::JointType::prismatic);
  EXPECT_EQ(static_cast<int>(prismatic.size()), n);
  for (int sample = 0; sample < 200; ++sample) {
    double q[n], qd[n], u[n], qdd_in[n];
    for (int i = 0; i < n; ++i) {
      q[i] = prismatic[i] ? slide(rng) : angle(rng);
      qd[i] = rate(rng), u[i] = rate(rng) * 5, qdd_in[i] = rate(rng);
    }
    const DD Q = lift(q, n), QD = lift(qd, n), U = lift(u, n), QDD = lift(qdd_in, n);
    DD M(n * n), bias(n), gravity(n), tau(n), qdd(n);
    double out[n * n], c[n];
    rd.mass_matrix(Q, M);
    K::mass_matrix(q, p.data(), out);
    worst.update("mass_matrix", out, M);
    rd.gravity_forces(Q, gravity);
    K::potential_gradient(q, p.data(), out);
    worst.update("potential_gradient", out, gravity);
    rd.bias_forces(Q, QD, bias);
    K::coriolis(q, qd, p.data(), c);
    for (int i = 0; i < n; ++i) c[i] += out[i];
    worst.update("coriolis + potential_gradient", c, bias);
    rd.inverse_dynamics(Q, QD, QDD, tau);
    for (int i = 0; i < n; ++i) tau[i] -= U[i] - rd.damping()[i] * QD[i];  // minus Q
    K::inverse_dynamics(0.0, q, qd, qdd_in, u, p.data(), out);
    worst.update("inverse_dynamics", out, tau);
    rd.forward_dynamics(Q, QD, U, qdd);
    EXPECT_TRUE(K::forward_dynamics(0.0, q, qd, u, p.data(), out));
    worst.update("forward_dynamics", out, qdd);
    const DD T{rd.kinetic_energy(Q, QD)};
    out[0] = K::kinetic_energy(q, qd, p.data());
    worst.update("kinetic_energy", out, T);
    // ∂q̈/∂x by fourth-order central differences of the ABA in dd_real (error ~1e-25).
    double d_dq[n * n], d_dqd[n * n], d_du[n * n];
    EXPECT_TRUE(K::forward_dynamics_derivatives(0.0, q, qd, u, p.data(), d_dq, d_dqd, d_du));
    // ∂q̈/∂u = M⁻¹ (Q = u − d⊙q̇): written symmetric, its upper triangle mirrored
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < i; ++j) EXPECT_EQ(d_du[i + n * j], d_du[j + n * i]) << i << ", " << j;
    const dd_real h(1e-6);
    DD fd(n * n);
    for (int which = 0; which < 3; ++which) {
      for (int j = 0; j < n; ++j) {
        DD f[4] = {DD(n), DD(n), DD(n), DD(n)};
        const dd_real steps[4] = {-2.0 * h, -h, h, 2.0 * h};
        for (int k = 0; k < 4; ++k) {
          DD y[3] = {Q, QD, U};
          y[which][j] += steps[k];
          rd.forward_dynamics(y[0], y[1], y[2], f[k]);
        }
        for (int i = 0; i < n; ++i)
          fd[i + n * j] = (f[0][i] - 8.0 * f[1][i] + 8.0 * f[2][i] - f[3][i]) / (12.0 * h);
      }
      worst.update("forward_dynamics_derivatives", which == 0 ? d_dq : which == 1 ? d_dqd : d_du, fd);
    }
  }
  return worst;
}

// Measured (worst over every kernel and 200 states): Panda 8.9e-15, UR5 5.6e-15, branched 2.2e-14,
// each from forward_dynamics_derivatives (the others lower).
TEST(UrdfRobots, PandaAgreesWithTheRecursiveAlgorithms) {
  const Worst w = compare_with_recursive<panda::Kernels>("panda.urdf");
  std::printf("panda: generated vs recursive (dd_real), worst %.1e (%s)\n", w.value, w.where.c_str());
  EXPECT_LT(w.value, 1e-12) << w.where;
}
TEST(UrdfRobots, Ur5AgreesWithTheRecursiveAlgorithms) {
  const Worst w = compare_with_recursive<ur5::Kernels>("ur5.urdf");
  std::printf("ur5: generated vs recursive (dd_real), worst %.1e (%s)\n", w.value, w.where.c_str());
  EXPECT_LT(w.value, 1e-12) << w.where;
}
TEST(UrdfRobots, BranchedRobotAgreesWithTheRecursiveAlgorithms) {
  const Worst w = compare_with_recursive<branched_robot::Kernels>("branched.urdf");
  std::printf("branched: generated vs recursive (dd_real), worst %.1e (%s)\n", w.value, w.where.c_str());
  EXPECT_LT(w.value, 1e-12) << w.where;
}

// The tree-form algorithms of eom/multibody/tree.hpp themselves (the generator traces them), run in dd_real
// on the written model headers: tree_inverse_dynamics against the RNEA's M q̈ + c (its τ minus its
// gravity forces), tree_forward_dynamics against the ABA with τ = u, and their pivots positive.
// Not to 1e-30: the headers' origin rotations are computed in double.
template <class Model>
double tree_against_recursive(const char* file) {
  const eom::urdf::Robot robot = eom::urdf::read(std::string(EOM_ROBOTS_DIR) + "/" + file);
  eomtest::RecursiveDynamics<dd_real> rd(robot);
  constexpr int n = eom::ModelInfo<Model>::nq;
  const auto pd = eom::ModelInfo<Model>::default_parameters();
  const DD p(pd.begin(), pd.end());
  const auto links = eom::tree_of<Model, dd_real>(p);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> angle(-3.0, 3.0), rate(-2.0, 2.0);
  double worst = 0;
  auto update = [&worst](const DD& got, const DD& expected) {
    double diff = 0, scale = 1;
    for (std::size_t i = 0; i < got.size(); ++i) {
      diff = std::max(diff, std::abs(to_double(got[i] - expected[i])));
      scale = std::max(scale, std::abs(to_double(expected[i])));
    }
    worst = std::max(worst, diff / scale);
  };
  for (int sample = 0; sample < 50; ++sample) {
    DD q(n), qd(n), qdd(n), u(n);
    for (int i = 0; i < n; ++i) q[i] = angle(rng), qd[i] = rate(rng), qdd[i] = rate(rng), u[i] = 5.0 * rate(rng);
    DD tau(n), gravity(n), tree_tau(n), qdd_aba(n), tree_qdd(n), pivots(n), zero(n, dd_real(0.0));
    rd.inverse_dynamics(q, qd, qdd, tau);
    rd.inverse_dynamics(q, zero, zero, gravity);
    for (int i = 0; i < n; ++i) tau[i] -= gravity[i];
    eom::tree_inverse_dynamics<dd_real>(links, q, qd, qdd, tree_tau);
    update(tree_tau, tau);
    // The recursive ABA applies τ = u − d⊙q̇ and gravity; the tree's takes them as its τ.
    rd.forward_dynamics(q, qd, u, qdd_aba);
    DD force(n);
    for (int i = 0; i < n; ++i) force[i] = u[i] - rd.damping()[i] * qd[i] - gravity[i];
    eom::tree_forward_dynamics<dd_real>(links, q, qd, force, tree_qdd, pivots);
    for (int i = 0; i < n; ++i) EXPECT_GT(to_double(pivots[i]), 0.0);
    update(tree_qdd, qdd_aba);
  }
  return worst;
}

TEST(UrdfRobots, TreeAlgorithmsAgreeWithTheRecursiveOnes) {
  const double panda = tree_against_recursive<eom::urdf_models::panda>("panda.urdf");
  const double ur5 = tree_against_recursive<eom::urdf_models::ur5>("ur5.urdf");
  const double branched = tree_against_recursive<eom::urdf_models::branched_robot>("branched.urdf");
  std::printf("eom/multibody/tree.hpp vs recursive (dd_real): panda %.1e, ur5 %.1e, branched %.1e\n", panda,
              ur5, branched);
  EXPECT_LT(panda, 1e-13);
  EXPECT_LT(ur5, 1e-13);
  EXPECT_LT(branched, 1e-13);
}

// With the joint damping set to 0 and no input, E = T + V is conserved.
TEST(UrdfRobots, PandaConservesEnergyWithoutDamping) {
  using K = panda::Kernels;
  auto p = K::parameter_values;
  int zeroed = 0;
  for (int i = 0; i < K::np; ++i)
    if (std::string_view(K::parameter_names[i]).ends_with("_damping")) p[i] = 0, ++zeroed;
  ASSERT_EQ(zeroed, 7);
  std::array<double, 2 * K::nq> x0{0.3, -0.5, 0.2, -2.0, 0.4, 1.6, 0.7, 0.5, -0.3, 0.8, 0.2, -0.6, 0.4, 1.0};
  const std::array<double, K::nq> u{};
  eom::IntegrationOptions options;
  options.method = eom::Method::dop853;
  options.rtol = options.atol = 1e-12;
  auto energy = [&p](const double* x) {
    return K::kinetic_energy(x, x + K::nq, p.data()) + K::potential_energy(x, p.data());
  };
  const double e0 = energy(x0.data());
  double drift = 0;
  const auto result = eom::integrate<K>(0.0, 2.0, x0, u.data(), p.data(), options,
                                        [&](double, const eom::StateOf<K::nq>& x) {
                                          drift = std::max(drift, std::abs(energy(x.data()) - e0));
                                        });
  ASSERT_EQ(result.status, eom::Status::ok);
  const double scale = K::kinetic_energy(x0.data(), x0.data() + K::nq, p.data());
  std::printf("panda, 2 s undamped, DOP853 tol 1e-12: max |E - E0| / T0 = %.1e\n", drift / scale);
  EXPECT_LT(drift / scale, 1e-9);
}

}  // namespace
