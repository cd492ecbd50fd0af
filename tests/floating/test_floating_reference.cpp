// The free joint in eom::Reference and in the tree form's recursions (eom/multibody/tree.hpp):
//   - a lone free body against Newton–Euler written out by hand (F = m a_c, τ = J ω̇ + ω × J ω
//     about the mass centre), in the contract's conventions (world force, body moment);
//   - the floating tree's RNEA and ABA against the Reference's Lagrangian (Hamel) route;
//   - tangent-space derivatives against central differences on the manifold, q ⊕ ε e_j;
//   - G(q), its transpose and Ġ v against their definitions.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

#include <eom/model/free_joint.hpp>
#include <eom/multibody/tree.hpp>
#include <eom/reference/reference.hpp>

#include "floating_models.hpp"

namespace {

using floating_test::BallTop;
using floating_test::FreeBody;
using floating_test::FreeTree;

template <class Model> struct State {
  static constexpr int nq = eom::ModelInfo<Model>::nq, nv = eom::ModelInfo<Model>::nv;
  std::array<double, nq> q;
  std::array<double, nv> v, a;
};

// A random state with a unit quaternion.
template <class Model> State<Model> random_state(std::mt19937& rng) {
  std::uniform_real_distribution<double> x(-1.0, 1.0);
  State<Model> s;
  for (double& e : s.q) e = x(rng);
  for (double& e : s.v) e = 2 * x(rng);
  for (double& e : s.a) e = 2 * x(rng);
  eom::normalize_configuration(eom::ModelInfo<Model>::layout, s.q.data());
  return s;
}

double max_abs_diff(const double* a, const double* b, int n) {
  double d = 0;
  for (int i = 0; i < n; ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

using Vec = std::array<double, 3>;
Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

TEST(FreeJoint, ConfigurationRateIsTheQuaternionKinematics) {
  // q̇ = ½ q ⊗ (0, ω): then Rᵀ Ṙ = [ω]× (body rates), checked by a central difference of R.
  std::mt19937 rng(1);
  const auto s = random_state<FreeBody>(rng);
  std::array<double, 7> rate;
  eom::configuration_rate(eom::Layout(7, 6), s.q.data(), s.v.data(), rate.data());
  const double h = 1e-6;
  std::array<double, 7> qp, qm;
  for (int i = 0; i < 7; ++i) {
    qp[i] = s.q[i] + h * rate[i];
    qm[i] = s.q[i] - h * rate[i];
  }
  const auto R = eom::quaternion(s.q[3], s.q[4], s.q[5], s.q[6]);
  const auto Rp = eom::quaternion(qp[3], qp[4], qp[5], qp[6]), Rm = eom::quaternion(qm[3], qm[4], qm[5], qm[6]);
  std::array<double, 9> Rdot, W;  // Ṙ, then RᵀṘ
  for (int k = 0; k < 9; ++k) Rdot[k] = (Rp[k] - Rm[k]) / (2 * h);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      W[i + 3 * j] = R[3 * i] * Rdot[3 * j] + R[3 * i + 1] * Rdot[3 * j + 1] + R[3 * i + 2] * Rdot[3 * j + 2];
  EXPECT_NEAR(W[2 + 3 * 1], s.v[3], 1e-8);  // (RᵀṘ)₃₂ = ω₁
  EXPECT_NEAR(W[0 + 3 * 2], s.v[4], 1e-8);
  EXPECT_NEAR(W[1 + 3 * 0], s.v[5], 1e-8);
  EXPECT_NEAR(W[1 + 3 * 2], -s.v[3], 1e-8);  // skew
  for (int i = 0; i < 3; ++i) EXPECT_EQ(rate[i], s.v[i]);
}

TEST(FreeJoint, TangentGradientIsTheTransposeOfG) {
  std::mt19937 rng(2);
  const auto s = random_state<FreeTree>(rng);
  std::array<double, 10> g;
  for (double& e : g) e = std::uniform_real_distribution<double>(-1, 1)(rng);
  std::array<double, 9> out;
  eom::tangent_gradient(eom::Layout(10, 9), s.q.data(), g.data(), out.data());
  for (int j = 0; j < 9; ++j) {
    std::array<double, 10> column;
    eom::configuration_direction(eom::Layout(10, 9), s.q.data(), j, column.data());
    double dot = 0;
    for (int i = 0; i < 10; ++i) dot += column[i] * g[i];
    EXPECT_NEAR(out[j], dot, 1e-15) << j;
  }
}

TEST(FreeJoint, IntegrateConfigurationStaysOnTheSphereAndFollowsTheRate) {
  std::mt19937 rng(3);
  const auto s = random_state<FreeTree>(rng);
  std::array<double, 10> next, rate;
  eom::integrate_configuration(eom::Layout(10, 9), s.q.data(), s.v.data(), 1e-7, next.data());
  eom::configuration_rate(eom::Layout(10, 9), s.q.data(), s.v.data(), rate.data());
  EXPECT_LT(eom::quaternion_norm_error(eom::Layout(10, 9), next.data()), 1e-15);
  for (int i = 0; i < 10; ++i) EXPECT_NEAR((next[i] - s.q[i]) / 1e-7, rate[i], 1e-6) << i;
  eom::integrate_configuration(eom::Layout(10, 9), s.q.data(), s.v.data(), 2.5, next.data());  // a large step
  EXPECT_LT(eom::quaternion_norm_error(eom::Layout(10, 9), next.data()), 4e-16);
}

TEST(FreeJoint, ReferenceMatchesNewtonEulerForALoneBody) {
  using R = eom::Reference<FreeBody>;
  static_assert(R::nq == 7 && R::nv == 6);
  std::mt19937 rng(4);
  const auto& p = FreeBody::parameter_values;
  for (int trial = 0; trial < 20; ++trial) {
    const auto s = random_state<FreeBody>(rng);
    // Newton–Euler about the mass centre c (world position x + R c_b): the body's inertia J in
    // body axes; a_c = a + R(ω̇ × c + ω × (ω × c)) with a the origin's world acceleration.
    const auto Rq = eom::quaternion(s.q[3], s.q[4], s.q[5], s.q[6]);
    const auto Ri = eom::constant_rpy<double>({0.3, -0.2, 0.5});
    const std::array<double, 6> Jin{p[1], p[2], p[3], p[4], p[5], p[6]};
    const auto J6 = eom::detail::rotated_inertia(Ri, Jin);  // body axes
    auto J = [&](const Vec& w) { return eom::detail::inertia_times(J6, w); };
    const Vec c{p[7], p[8], p[9]}, w{s.v[3], s.v[4], s.v[5]}, dw{s.a[3], s.a[4], s.a[5]};
    const Vec a_body = eom::detail::rotate_back(Rq, Vec{s.a[0], s.a[1], s.a[2]});
    Vec ac;
    const Vec wc = cross(w, c), dwc = cross(dw, c), wwc = cross(w, wc);
    for (int k = 0; k < 3; ++k) ac[k] = a_body[k] + dwc[k] + wwc[k];
    const double m = p[0];
    const Vec F_body{m * ac[0], m * ac[1], m * ac[2]};
    const Vec Jdw = J(dw), wJw = cross(w, J(w)), cF = cross(c, F_body);
    const Vec F = eom::rotate(Rq, F_body);
    std::array<double, 6> expected{F[0], F[1], F[2]}, tau;
    for (int k = 0; k < 3; ++k) expected[3 + k] = Jdw[k] + wJw[k] + cF[k];  // about the origin
    R::inverse_dynamics(0.0, s.q.data(), s.v.data(), s.a.data(), nullptr, p.data(), tau.data());
    EXPECT_LT(max_abs_diff(tau.data(), expected.data(), 6), 1e-13) << "trial " << trial;
    // and the forward dynamics inverts it
    std::array<double, 6> a;
    ASSERT_TRUE(R::forward_dynamics(0.0, s.q.data(), s.v.data(), nullptr, p.data(), a.data()));
    std::array<double, 6> zero{}, tau0;
    R::inverse_dynamics(0.0, s.q.data(), s.v.data(), a.data(), nullptr, p.data(), tau0.data());
    EXPECT_LT(max_abs_diff(tau0.data(), zero.data(), 6), 1e-13);
  }
}

TEST(FreeJoint, GravityIsAWorldForceAndAMomentInBodyAxes) {
  using R = eom::Reference<FreeBody>;
  auto p = FreeBody::parameter_values;
  p[10] = 9.81;
  std::mt19937 rng(5);
  const auto s = random_state<FreeBody>(rng);
  std::array<double, 6> dV;
  R::potential_gradient(s.q.data(), p.data(), dV.data());
  // force: m g along +z (the gradient of m g z); moment about the origin: c × (Rᵀ m g e_z)
  EXPECT_NEAR(dV[0], 0.0, 1e-15);
  EXPECT_NEAR(dV[1], 0.0, 1e-15);
  EXPECT_NEAR(dV[2], p[0] * 9.81, 1e-13);
  const auto Rq = eom::quaternion(s.q[3], s.q[4], s.q[5], s.q[6]);
  const Vec up = eom::detail::rotate_back(Rq, Vec{0.0, 0.0, p[0] * 9.81});
  const Vec moment = cross(Vec{p[7], p[8], p[9]}, up);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(dV[3 + k], moment[k], 1e-13) << k;
}

TEST(FreeJoint, TreeRecursionsMatchTheReference) {
  using R = eom::Reference<FreeTree>;
  static_assert(R::nq == 10 && R::nv == 9 && R::nu == 3);
  const auto& p = FreeTree::parameter_values;
  const auto links = eom::tree_of<FreeTree, double>(p);
  std::mt19937 rng(6);
  for (int trial = 0; trial < 20; ++trial) {
    const auto s = random_state<FreeTree>(rng);
    const std::array<double, 3> u{0.3, -0.2, 0.5};
    // RNEA + ∂V/∂q − Q against the Reference's Lagrangian route
    std::array<double, 9> rnea, dV, Q, expected;
    eom::tree_inverse_dynamics<double>(links, s.q, s.v, s.a, rnea);
    R::potential_gradient(s.q.data(), p.data(), dV.data());
    R::generalized_forces(0.0, s.q.data(), s.v.data(), u.data(), p.data(), Q.data());
    R::inverse_dynamics(0.0, s.q.data(), s.v.data(), s.a.data(), u.data(), p.data(), expected.data());
    for (int i = 0; i < 9; ++i) rnea[i] += dV[i] - Q[i];
    EXPECT_LT(max_abs_diff(rnea.data(), expected.data(), 9), 1e-12) << "trial " << trial;
    // ABA with τ = Q − ∂V/∂q against the Reference's forward dynamics
    std::array<double, 9> tau, aba, pivots, a;
    for (int i = 0; i < 9; ++i) tau[i] = Q[i] - dV[i];
    eom::tree_forward_dynamics<double>(links, s.q, s.v, tau, aba, pivots);
    ASSERT_TRUE(R::forward_dynamics(0.0, s.q.data(), s.v.data(), u.data(), p.data(), a.data()));
    EXPECT_LT(max_abs_diff(aba.data(), a.data(), 9), 1e-11) << "trial " << trial;
    for (double d : pivots) EXPECT_GT(d, 0.0);
    // M from the energy is the RNEA's columns
    std::array<double, 81> M;
    R::mass_matrix(s.q.data(), p.data(), M.data());
    const std::array<double, 9> zero{};
    std::array<double, 9> bias, column;
    eom::tree_inverse_dynamics<double>(links, s.q, zero, zero, bias);
    for (int j = 0; j < 9; ++j) {
      std::array<double, 9> e{};
      e[j] = 1;
      eom::tree_inverse_dynamics<double>(links, s.q, zero, e, column);
      for (int i = 0; i < 9; ++i) EXPECT_NEAR(column[i] - bias[i], M[i + 9 * j], 1e-13);
    }
  }
}

TEST(FreeJoint, DerivativesAreTakenInTheTangentSpace) {
  using R = eom::Reference<FreeTree>;
  const auto& p = FreeTree::parameter_values;
  std::mt19937 rng(7);
  const auto s = random_state<FreeTree>(rng);
  const std::array<double, 3> u{0.3, -0.2, 0.5};
  std::array<double, 81> dq, dv;
  std::array<double, 27> du;
  ASSERT_TRUE(R::forward_dynamics_derivatives(0.0, s.q.data(), s.v.data(), u.data(), p.data(),
                                              dq.data(), dv.data(), du.data()));
  const double h = 1e-5;
  for (int j = 0; j < 9; ++j) {  // v̇(q ⊕ ±h e_j), by the exp map, central difference
    std::array<double, 9> e{};
    e[j] = 1;
    std::array<double, 10> qp, qm;
    eom::integrate_configuration(eom::Layout(10, 9), s.q.data(), e.data(), h, qp.data());
    eom::integrate_configuration(eom::Layout(10, 9), s.q.data(), e.data(), -h, qm.data());
    std::array<double, 9> ap, am;
    ASSERT_TRUE(R::forward_dynamics(0.0, qp.data(), s.v.data(), u.data(), p.data(), ap.data()));
    ASSERT_TRUE(R::forward_dynamics(0.0, qm.data(), s.v.data(), u.data(), p.data(), am.data()));
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(dq[i + 9 * j], (ap[i] - am[i]) / (2 * h), 1e-7) << i << "," << j;
  }
}

TEST(FreeJoint, FreeFallAcceleratesTheMassCentreByGravity) {
  using R = eom::Reference<FreeTree>;
  auto p = FreeTree::parameter_values;
  p[5] = 0.0;  // no damping: every generalized force but gravity is zero
  std::mt19937 rng(8);
  for (int trial = 0; trial < 5; ++trial) {
    const auto s = random_state<FreeTree>(rng);
    const std::array<double, 3> u{};
    std::array<double, 9> a;
    ASSERT_TRUE(R::forward_dynamics(0.0, s.q.data(), s.v.data(), u.data(), p.data(), a.data()));
    // The mass centre's acceleration: Σ mᵢ a_cᵢ / m = the free joint's force row of M a + c
    // over m, since the bodies' total linear momentum is Σ mᵢ vᵢ = the momentum conjugate to
    // v_lin. Compute it independently: d²/dt² Σ mᵢ xᵢ by central differences along the motion.
    const double h = 1e-4;
    auto com = [&](const std::array<double, 10>& q) {
      std::array<eom::SpatialBody<double>, 4> b;
      FreeTree::bodies<double>(q, p, b);
      Vec x{};
      double m = 0;
      for (const auto& body : b) {
        m += body.mass;
        for (int k = 0; k < 3; ++k) x[k] += body.mass * body.position[k];
      }
      for (double& e : x) e /= m;
      return x;
    };
    // second-order Taylor step of the configuration along (v, a): q(±h)
    auto at = [&](double t) {
      std::array<double, 9> vt;
      for (int i = 0; i < 9; ++i) vt[i] = s.v[i] + 0.5 * t * a[i];  // mean velocity over [0, t]
      std::array<double, 10> q;
      eom::integrate_configuration(eom::Layout(10, 9), s.q.data(), vt.data(), t, q.data());
      return q;
    };
    const Vec xp = com(at(h)), x0 = com(s.q), xm = com(at(-h));
    // integrate_configuration with the mean velocity is second-order exact only for the linear
    // part and the joints; the rotation's error is O(h³) and cancels in the central difference
    for (int k = 0; k < 2; ++k) EXPECT_NEAR((xp[k] - 2 * x0[k] + xm[k]) / (h * h), 0.0, 2e-5) << k;
    EXPECT_NEAR((xp[2] - 2 * x0[2] + xm[2]) / (h * h), -9.81, 2e-5);
  }
}


// A ball joint whose quaternion is not q's first (BallTop: q = [lift, qw, qx, qy, qz, flap]).
// With the slide held (v, v̇ = 0 there) and the flap massless, the top turns about a fixed pivot
// and the ball joint's generalized force is Euler's, about the pivot in the top's axes:
// τ = I_p ω̇ + ω × I_p ω − c × Rᵀ m g, I_p = J + m (|c|² 1 − c cᵀ). The AD reference (T along
// q̇ = G(q) v, its Euler bracket) and the tree's Newton–Euler recursion both give it; with the
// flap's mass back, the recursions agree with the reference (τ, M) and the reference's
// derivatives with differences on the manifold.
TEST(BallJoint, ReferenceAndTreeGiveEulersEquationsAboutThePivot) {
  using R = eom::Reference<BallTop>;
  static_assert(R::nq == 6 && R::nv == 5 && R::quaternions[0] == 1);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> x(-1.0, 1.0);
  const std::array<double, 2> massless{9.81, 0.0};
  double worst = 0, worst_tree = 0;
  for (int trial = 0; trial < 20; ++trial) {
    State<BallTop> s = random_state<BallTop>(rng);
    s.v[0] = s.a[0] = 0;  // the slide held: the pivot fixed
    s.a[4] = 0;
    std::array<double, 5> tau, tau_tree;
    const std::array<double, 1> u{};
    R::inverse_dynamics(0.0, s.q.data(), s.v.data(), s.a.data(), u.data(), massless.data(),
                        tau.data());
    // Euler about the pivot
    const double m = BallTop::mass;
    const auto& J = BallTop::inertia;
    const Vec c = BallTop::centre;
    const double cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    auto Ip = [&](int i, int j) {
      static constexpr int at[3][3] = {{0, 3, 4}, {3, 1, 5}, {4, 5, 2}};
      return J[at[i][j]] + m * ((i == j ? cc : 0.0) - c[i] * c[j]);
    };
    auto times = [&](const Vec& w) {
      Vec r{};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r[i] += Ip(i, j) * w[j];
      return r;
    };
    const Vec w{s.v[1], s.v[2], s.v[3]}, dw{s.a[1], s.a[2], s.a[3]};
    const auto links = eom::tree_of<BallTop, double>(massless);
    const eom::Rot3<double> Rw = eom::tree_placements<double>(links, s.q)[1].rotation;
    const Vec g_body{-Rw[2] * 9.81 * m, -Rw[5] * 9.81 * m, -Rw[8] * 9.81 * m};  // Rᵀ (0, 0, −m g)
    const Vec Iw = times(w), Idw = times(dw), wIw = cross(w, Iw), cg = cross(c, g_body);
    for (int k = 0; k < 3; ++k)
      worst = std::max(worst, std::abs(tau[1 + k] - (Idw[k] + wIw[k] - cg[k])));
    // the tree's RNEA (without gravity: τ − its moment) and CRBA, on the massive flap too
    const auto heavy = eom::tree_of<BallTop, double>(BallTop::parameter_values);
    std::array<double, 5> tau_ad, zero{};
    std::array<double, 25> M_tree, M_ad;
    R::inverse_dynamics(0.0, s.q.data(), s.v.data(), s.a.data(), u.data(),
                        BallTop::parameter_values.data(), tau_ad.data());
    eom::tree_inverse_dynamics<double>(heavy, s.q, s.v, s.a, tau_tree);
    std::array<double, 5> gravity_only;
    R::inverse_dynamics(0.0, s.q.data(), zero.data(), zero.data(), u.data(),
                        BallTop::parameter_values.data(), gravity_only.data());
    for (int k = 0; k < 5; ++k) tau_tree[k] += gravity_only[k];
    worst_tree = std::max(worst_tree, max_abs_diff(tau_tree.data(), tau_ad.data(), 5));
    eom::tree_mass_matrix<double>(heavy, s.q, M_tree);
    R::mass_matrix(s.q.data(), BallTop::parameter_values.data(), M_ad.data());
    worst_tree = std::max(worst_tree, max_abs_diff(M_tree.data(), M_ad.data(), 25));
  }
  std::printf("ball joint after a slide: Euler's equations about the pivot %.2e; tree "
              "recursions against the reference %.2e\n", worst, worst_tree);
  EXPECT_LT(worst, 1e-14);
  EXPECT_LT(worst_tree, 1e-14);
}

// A tree whose quaternions the model does not list is stopped before it computes anything
// wrong: check_tree counts them against nq − nv.
TEST(BallJoint, TreeAndLayoutMustAgree) {
  const auto links = eom::tree_of<BallTop, double>(BallTop::parameter_values);
  std::array<double, 6> q{0.0, 1.0, 0.0, 0.0, 0.0, 0.0};
  std::array<double, 6> v{}, a{}, tau{};  // as if nv = nq: no quaternion
  try {
    eom::tree_inverse_dynamics<double>(links, q, v, a, tau);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("hold 1 quaternions but the model has 6 coordinates and 6 "
                                         "velocities"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
