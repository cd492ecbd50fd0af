// Mimic joints, friction and limits of a URDF file (robots/mimic_gripper.urdf), generated through
// add_eom_model(... URDF ...), against the recursive algorithms (tests/support/recursive_dynamics.hpp)
// run in dd_real on the same file WITHOUT its <mimic> elements: every joint then has a coordinate
// of its own, and since a mimic joint's position m·q_leader + o is affine in q, the reduced robot's
// dynamics are those of the full one along q_full = G q + o, v_full = G v, v̇_full = G v̇:
//   M = Gᵀ M_full G,   c + ∂V/∂q = Gᵀ (c_full + ∂V_full/∂q),   T = T_full,
//   Q = u + Gᵀ Q_full with Q_full = −d⊙v_full − f⊙tanh(v_full / friction_smoothing),
// G the constant 0/1/multiplier matrix (tests/support/mimic_map.hpp). Also the tree algorithms of
// the written model header (eom/multibody/tree.hpp, mimic-aware), the frame Jacobian J = J_full G, and the
// limits arrays.
#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include <eom/integration/events.hpp>
#include <eom/integration/integrate.hpp>
#include <eom/multibody/frames.hpp>
#include <eom/multibody/tree.hpp>
#include <eomgen/urdf.hpp>
#include <mimic_map.hpp>
#include <recursive_dynamics.hpp>
#include <urdf_free_two_link.hpp>
#include <urdf_mimic_gripper.hpp>
#include <urdf_mimic_gripper_model.hpp>

namespace {

using DD = std::vector<dd_real>;
using K = urdf_mimic_gripper::Kernels;
using Model = eom::urdf_models::urdf_mimic_gripper;
constexpr int n = K::nq;

using eomtest::Worst;

struct Full {  // the file, and the map to the same file without its mimics (map.full)
  eom::urdf::Robot reduced = eom::urdf::read(EOM_MIMIC_URDF);
  eomtest::MimicMap map{reduced};
};

TEST(UrdfMimic, TheReaderFindsTheMimicsAndWarnsOfTheRest) {
  const Full f;
  EXPECT_EQ(n, 3);     // shoulder, wrist, finger1_joint
  EXPECT_EQ(f.map.nvf, 6);  // + finger2_joint, tip2_joint, slider_joint
  // tip2 → finger2 → finger1: q = 0.5 (−q₁ + 0.1) − 0.2 = −0.5 q₁ − 0.15
  const auto& tip = f.reduced.joints[5];
  ASSERT_TRUE(tip.mimic);
  EXPECT_EQ(tip.mimic->leader, "finger1_joint");
  EXPECT_EQ(tip.mimic->multiplier, -0.5);
  EXPECT_DOUBLE_EQ(tip.mimic->offset, -0.15);
  ASSERT_EQ(f.reduced.warnings.size(), 2u);  // the mimic on a fixed joint, the welded camera
  EXPECT_NE(f.reduced.warnings[0].find("mimic_gripper.urdf:59: joint 'pad_fix'"), std::string::npos) << f.reduced.warnings[0];
  EXPECT_NE(f.reduced.warnings[1].find("mimic_gripper.urdf:10: link 'camera'"), std::string::npos) << f.reduced.warnings[1];
}

TEST(UrdfMimic, KernelsAgreeWithTheFullRobotsRecursiveAlgorithms) {
  const Full f;
  const eomtest::MimicMap& map = f.map;
  const int nf = map.nvf;
  eomtest::RecursiveDynamics<dd_real> rd(map.full);
  ASSERT_EQ(rd.nq(), nf);
  const auto& p = K::parameter_values;
  const DD pd(p.begin(), p.end());
  const auto links = eom::tree_of<Model, dd_real>(pd);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-2.0, 2.0), rate(-1.5, 1.5);
  Worst worst;
  auto lift = [](const double* x) { return DD(x, x + n); };
  for (int sample = 0; sample < 100; ++sample) {
    double q[n], qd[n], qdd[n], u[n], out[n * n];
    for (int i = 0; i < n; ++i) q[i] = angle(rng), qd[i] = rate(rng), qdd[i] = rate(rng), u[i] = rate(rng);
    qd[2] = sample % 4 == 0 ? 1e-3 * qd[2] : qd[2];  // inside the friction's smoothing too
    const DD Q = lift(q), QD = lift(qd), QDD = lift(qdd), U = lift(u);
    const DD qf = map.positions(q), vf = map.up(QD), af = map.up(QDD);
    // M = Gᵀ M_full G
    DD Mf(static_cast<std::size_t>(nf * nf));
    rd.mass_matrix(qf, Mf);
    const DD M = map.reduce(Mf);
    K::mass_matrix(q, p.data(), out);
    worst.update("mass_matrix", DD(out, out + n * n), M);
    DD tree_M(n * n);
    eom::tree_mass_matrix<dd_real>(links, Q, tree_M);
    worst.update("tree_mass_matrix", tree_M, M);
    // gravity and bias
    DD gf(static_cast<std::size_t>(nf)), bf(static_cast<std::size_t>(nf));
    rd.gravity_forces(qf, gf);
    rd.bias_forces(qf, vf, bf);
    K::potential_gradient(q, p.data(), out);
    worst.update("potential_gradient", DD(out, out + n), map.down(gf));
    double c[n];
    K::coriolis(q, qd, p.data(), c);
    K::potential_gradient(q, p.data(), out);
    for (int i = 0; i < n; ++i) c[i] += out[i];
    worst.update("coriolis + potential_gradient", DD(c, c + n), map.down(bf));
    // inverse dynamics: Gᵀ(τ_full − Q_full) − u
    DD tf(static_cast<std::size_t>(nf)), zero(static_cast<std::size_t>(nf), dd_real(0.0));
    rd.inverse_dynamics(qf, vf, af, tf);
    DD tree_expected = map.down(tf);  // M v̇ + c + ∂V/∂q, then the tree's (no gravity)
    DD tg(static_cast<std::size_t>(nf));
    rd.inverse_dynamics(qf, zero, zero, tg);
    map.add_dissipation(vf, tf);
    DD expected = map.down(tf);
    for (int i = 0; i < n; ++i) expected[i] -= U[i];
    K::inverse_dynamics(0.0, q, qd, qdd, u, p.data(), out);
    worst.update("inverse_dynamics", DD(out, out + n), expected);
    const DD gravity = map.down(tg);
    for (int i = 0; i < n; ++i) tree_expected[i] -= gravity[i];
    DD tree_tau(n);
    eom::tree_inverse_dynamics<dd_real>(links, Q, QD, QDD, tree_tau);
    worst.update("tree_inverse_dynamics", tree_tau, tree_expected);
    // forward dynamics: its v̇ put back into the full robot's inverse dynamics gives u
    EXPECT_TRUE(K::forward_dynamics(0.0, q, qd, u, p.data(), out));
    const DD a_fd = map.up(DD(out, out + n));
    rd.inverse_dynamics(qf, vf, a_fd, tf);
    map.add_dissipation(vf, tf);
    worst.update("forward_dynamics (as Gᵀ(τ_full − Q_full))", map.down(tf), U);
    // energy
    out[0] = K::kinetic_energy(q, qd, p.data());
    worst.update("kinetic_energy", DD(out, out + 1), DD{rd.kinetic_energy(qf, vf)});
    // the frame Jacobian of the last finger tip: J = J_full G
    DD Jf(static_cast<std::size_t>(6 * nf)), J(6 * n, dd_real(0.0));
    rd.frame_jacobian("tip2", qf.data(), Jf.data());
    for (int r = 0; r < 6; ++r)
      for (int k = 0; k < n; ++k)
        for (int i = 0; i < nf; ++i)
          J[static_cast<std::size_t>(r + 6 * k)] += Jf[static_cast<std::size_t>(r + 6 * i)] * map.g(i, k);
    double Jk[6 * n];
    K::frame_jacobian(0, q, p.data(), Jk);
    worst.update("frame_jacobian", DD(Jk, Jk + 6 * n), J);
  }
  std::printf("mimic gripper: generated and tree vs full recursive (dd_real), worst %.1e (%s)\n",
              worst.value, worst.where.c_str());
  EXPECT_LT(worst.value, 1e-12) << worst.where;
}

TEST(UrdfMimic, TheArticulatedBodyAlgorithmRefusesMimics) {
  const auto links = eom::tree_of<Model, double>(Model::parameter_values);
  EXPECT_TRUE(eom::tree_has_mimic(links));
  std::array<double, n> q{}, v{}, tau{}, a{}, pivots{};
  EXPECT_THROW(eom::tree_forward_dynamics<double>(links, q, v, tau, a, pivots), std::invalid_argument);
}

TEST(UrdfLimits, TheModelHeaderCarriesTheLimits) {
  // shoulder, wrist (continuous: no position limits), finger1_joint, whose followers narrow its
  // own [-0.5, 1]: the slider (0.03 q + 0.005 within [0, 0.04], at most 0.045 m/s) is the one
  // that binds below and in velocity; finger2 and tip2 allow more than finger1's own.
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(Model::position_lower, (std::array<double, 3>{-2, -inf, (0.0 - 0.005) / 0.03}));
  EXPECT_EQ(Model::position_upper, (std::array<double, 3>{2, inf, 1}));
  EXPECT_EQ(Model::effort_limit, (std::array<double, 3>{50, 5, 2}));
  EXPECT_EQ(Model::velocity_limit, (std::array<double, 3>{3, 6, 0.045 / 0.03}));
}

// The generated header passes the model header's names and limits on (Kernels::coordinate_names,
// velocity_names, input_names, position_lower/upper, effort_limit, velocity_limit).
TEST(UrdfLimits, TheGeneratedHeaderCarriesNamesAndLimits) {
  using Names = std::array<std::string_view, n>;
  EXPECT_EQ(K::coordinate_names, (Names{"shoulder", "wrist", "finger1_joint"}));
  EXPECT_EQ(K::velocity_names, K::coordinate_names);  // no free joint: v = q̇
  EXPECT_EQ(K::input_names, (Names{"u_shoulder", "u_wrist", "u_finger1_joint"}));
  EXPECT_EQ(K::position_lower, Model::position_lower);
  EXPECT_EQ(K::position_upper, Model::position_upper);
  EXPECT_EQ(K::effort_limit, Model::effort_limit);
  EXPECT_EQ(K::velocity_limit, Model::velocity_limit);
}

// A free joint's velocities are named after its coordinates: <root>_vx … <root>_wz.
TEST(UrdfLimits, AFreeJointsVelocitiesAreNamed) {
  using F = urdf_free_two_link::Kernels;
  ASSERT_EQ(F::nv, 8);
  EXPECT_EQ(F::coordinate_names[0], "base_x");
  EXPECT_EQ(F::coordinate_names[3], "base_qw");
  EXPECT_EQ((std::array<std::string_view, 8>{"base_vx", "base_vy", "base_vz", "base_wx", "base_wy",
                                             "base_wz", "j1", "j2"}),
            F::velocity_names);
  EXPECT_EQ(F::position_lower[0], -std::numeric_limits<double>::infinity());  // the free joint
  EXPECT_EQ(F::effort_limit[5], std::numeric_limits<double>::infinity());
}

// The limits with the events API: the arm (an inverted pendulum about the shoulder, damped, with
// friction) falls from 0.3 rad at rest and the integration stops where the shoulder reaches its
// <limit upper="2">: a terminating event on position_upper − q. The stop state is at the limit to
// the event location's accuracy, and the same integration without the event, run to that time,
// passes through the same state (the event cut nothing but the end).
TEST(UrdfLimits, AnEventStopsTheIntegrationAtAJointLimit) {
  const auto& p = K::parameter_values;
  const eom::StateOf<n> x0{0.3, 0.0, 0.2, 0.0, 0.0, 0.0};
  const std::array<double, n> u{};
  auto upper = [](double, const double* q, const double*) { return K::position_upper[0] - q[0]; };
  auto lower = [](double, const double* q, const double*) { return q[0] - K::position_lower[0]; };
  const eom::Event events[]{
      {.g = lower, .direction = eom::EventDirection::falling, .action = eom::EventAction::terminate},
      {.g = upper, .direction = eom::EventDirection::falling, .action = eom::EventAction::terminate}};
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = opt.atol = 1e-11;
  std::array<eom::EventRecord<n>, 4> storage;
  eom::EventLog<n> log(storage);
  double highest = -1e300;
  const auto r = eom::integrate<K>(0.0, 10.0, x0, u.data(), p.data(), opt, events, log,
                                   [&](double, const auto& x) { highest = std::max(highest, x[0]); });
  ASSERT_EQ(r.status, eom::Status::ok);
  EXPECT_EQ(r.event, 1);  // the upper limit
  EXPECT_GT(r.t, 0.1);
  EXPECT_LT(r.t, 10.0);
  EXPECT_NEAR(r.x[0], K::position_upper[0], 1e-9);
  EXPECT_GT(r.x[n], 0.0);  // still rising into the limit
  EXPECT_LE(highest, K::position_upper[0] + 1e-9);
  ASSERT_EQ(log.size(), 1u);
  EXPECT_EQ(log.records()[0].t, r.t);
  const auto free_run = eom::integrate<K>(0.0, r.t, x0, u.data(), p.data(), opt);
  ASSERT_EQ(free_run.status, eom::Status::ok);
  for (int i = 0; i < 2 * n; ++i) EXPECT_NEAR(free_run.x[i], r.x[i], 1e-8) << i;
  std::printf("shoulder reaches its upper limit 2 rad at t = %.9f s (qd = %.4f rad/s)\n", r.t, r.x[n]);
}

}  // namespace
