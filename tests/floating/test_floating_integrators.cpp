// The integrators on x = (q, v) with a free joint (eom/model/free_joint.hpp, eom/integration/state.hpp):
//   - torque-free FreeBody: angular momentum about the origin, linear momentum and the mass
//     centre's straight line kept by dop853 and the Taylor method; the body rates against the
//     closed form of Euler's equations (tests/support/free_rigid_body.hpp), from dop853 and from
//     extrapolation in long double;
//   - the quaternion on the unit sphere after every step and in dense output, every method;
//   - rk4 still of order 4 with the normalization; FreeTree's energy kept by dop853;
//   - bad input (a quaternion off the unit sphere) refused everywhere, variational refused;
//   - an event located against the closed-form fall of the mass centre; a reset that breaks
//     the quaternion refused;
//   - radau5's embedded Jacobian, sensitivities in the tangent space against differences on the
//     manifold, constraint stabilization with a constraint on the orientation, ensembles bitwise
//     as single runs, a latch on a flying tree.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#include <eom/ensemble/ensemble.hpp>
#include <eom/integration/high_precision.hpp>
#include <eom/integration/integrate.hpp>
#include <eom/integration/locks.hpp>
#include <eom/integration/sensitivity.hpp>
#include <eom/model/free_joint.hpp>
#include <eom/multibody/momentum.hpp>
#include <eom/reference/reference.hpp>

#include "floating_models.hpp"
#include "free_rigid_body.hpp"

namespace {

using floating_test::FreeBody;
using floating_test::FreeTree;
using Body = eom::Reference<FreeBody>;
using Tree = eom::Reference<FreeTree>;
using BodyState = eom::StateFor<Body>;
using TreeState = eom::StateFor<Tree>;

static_assert(Body::nq == 7 && Body::nv == 6 && std::tuple_size_v<BodyState> == 13);
static_assert(std::tuple_size_v<TreeState> == 19);
static_assert(std::is_same_v<eom::StateOf<3>, std::array<double, 6>>);  // nv defaults to nq

template <class K> double norm_error(const eom::StateFor<K>& x) {
  return eom::quaternion_norm_error(eom::Layout(K::nq, K::nv), x.data());
}

template <class K> std::array<double, K::np> parameters() {
  std::array<double, K::np> p;
  std::copy(K::model_type::parameter_values.begin(), K::model_type::parameter_values.end(), p.begin());
  return p;
}

// A tumbling, drifting FreeBody (unit quaternion).
BodyState body_start() {
  BodyState x{0.3, -0.2, 0.5, 0.9, 0.1, -0.3, 0.2, 0.1, 0.2, -0.3, 0.7, -1.1, 1.5};
  eom::normalize_configuration(eom::Layout(7, 6), x.data());
  return x;
}

// FreeTree thrown upwards, spinning, its joints moving.
TreeState tree_start(double spin = 1.0) {
  TreeState x{0.0, 0.0, 1.0, 0.95, 0.05, -0.2, 0.1, 0.4, -0.6, 0.05,
              0.3, -0.1, 2.0, 0.4 * spin, -0.7 * spin, 0.9 * spin, 1.2, -0.8, 0.3};
  eom::normalize_configuration(eom::Layout(10, 9), x.data());
  return x;
}

double max_abs_diff(std::span<const double> a, std::span<const double> b) {
  double d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

std::array<double, 3> momentum_about_origin(const BodyState& x, const double* p) {
  return eom::angular_momentum_of<FreeBody>(std::span(x.data(), 7), std::span(x.data() + 7, 6),
                                            std::span(p, FreeBody::parameters.size()));
}

double norm3(const std::array<double, 3>& a) { return std::hypot(a[0], a[1], a[2]); }

// ---- torque-free motion ---------------------------------------------------------------------

// The invariants of free flight over [0, t1]: H about the world origin, m v_c, and the mass
// centre on its straight line x_c0 + v_c0 t, every accepted step.
template <class Run> void check_free_flight(Run run, double t1, double tolerance) {
  const auto p = parameters<Body>();
  const BodyState x0 = body_start();
  const auto b0 = eom::body_motions_of<FreeBody>(std::span(x0.data(), 7), std::span(x0.data() + 7, 6), p)[0];
  const auto H0 = momentum_about_origin(x0, p.data());
  double worst_H = 0, worst_v = 0, worst_c = 0, worst_norm = 0;
  long seen = 0;
  const auto r = run(x0, p.data(), [&](double t, const BodyState& x) {
    ++seen;
    const auto b = eom::body_motions_of<FreeBody>(std::span(x.data(), 7), std::span(x.data() + 7, 6), p)[0];
    const auto H = momentum_about_origin(x, p.data());
    for (int i = 0; i < 3; ++i) {
      worst_H = std::max(worst_H, std::abs(H[i] - H0[i]) / norm3(H0));
      worst_v = std::max(worst_v, std::abs(b.velocity[i] - b0.velocity[i]));
      worst_c = std::max(worst_c, std::abs(b.position[i] - (b0.position[i] + b0.velocity[i] * t)));
    }
    worst_norm = std::max(worst_norm, norm_error<Body>(x));
  });
  ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status);
  EXPECT_EQ(r.t, t1);
  EXPECT_GT(seen, 5);
  EXPECT_LE(worst_H, tolerance);
  EXPECT_LE(worst_v, tolerance);
  EXPECT_LE(worst_c, 20 * tolerance);
  EXPECT_LE(worst_norm, 1e-15);
  std::printf("  accepted %ld: |ΔH|/|H| %.2e, |Δv_c| %.2e, mass centre off its line %.2e\n",
              r.accepted, worst_H, worst_v, worst_c);
}

TEST(FloatingIntegrators, Dop853KeepsTheInvariantsOfFreeFlight) {
  eom::AdaptiveOptions opt;
  opt.rtol = opt.atol = 1e-13;
  check_free_flight([&](const BodyState& x0, const double* p, auto&& observer) {
    return eom::dop853<Body>(0, 20, x0, nullptr, p, opt, observer);
  }, 20, 1e-11);
}

// (Over 1 s: the reference's Taylor coefficients are its slowest kernel.)
TEST(FloatingIntegrators, TaylorKeepsTheInvariantsOfFreeFlight) {
  eom::AdaptiveOptions opt;
  opt.rtol = opt.atol = 1e-13;
  {
    check_free_flight([&](const BodyState& x0, const double* p, auto&& observer) {
      return eom::taylor<Body>(0, 1, x0, nullptr, p, opt, eom::TaylorOptions{}, observer);
    }, 1, 1e-11);
  }
}

// FreeBody's inertia about its mass centre, in the axes its angular velocity is given in,
// diagonalized: J = P Λ Pᵀ with P a rotation (a reflection would reverse ω × Jω).
struct PrincipalAxes {
  Eigen::Matrix3d P;
  std::array<double, 3> moments;
  explicit PrincipalAxes(const std::array<double, 6>& J) {  // Ixx Iyy Izz Ixy Ixz Iyz
    Eigen::Matrix3d Jm;
    Jm << J[0], J[3], J[4], J[3], J[1], J[5], J[4], J[5], J[2];
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(Jm);
    P = eig.eigenvectors();
    if (P.determinant() < 0) P.col(2) = -P.col(2);
    moments = {eig.eigenvalues()[0], eig.eigenvalues()[1], eig.eigenvalues()[2]};
  }
  std::array<double, 3> operator()(const std::array<double, 3>& w) const {  // Pᵀ ω
    const Eigen::Vector3d v = P.transpose() * Eigen::Vector3d(w[0], w[1], w[2]);
    return {v[0], v[1], v[2]};
  }
};

// The body rates against the closed form: Pᵀ ω(t) solves Euler's equations with the principal
// moments Λ.
TEST(FloatingIntegrators, BodyRatesFollowTheClosedForm) {
  const auto p = parameters<Body>();
  const BodyState x0 = body_start();
  const auto b0 = eom::body_motions_of<FreeBody>(std::span(x0.data(), 7), std::span(x0.data() + 7, 6), p)[0];
  const PrincipalAxes principal(b0.inertia);
  const eomtest::FreeRigidBody exact(principal.moments, principal(b0.angular_velocity));
  std::vector<double> times;
  for (int k = 1; k <= 40; ++k) times.push_back(0.5 * k);
  eom::AdaptiveOptions opt;
  opt.rtol = opt.atol = 1e-13;
  opt.output_times = times;
  double worst = 0;
  const auto r = eom::dop853<Body>(0, 20, x0, nullptr, p.data(), opt, [&](double t, const BodyState& x) {
    const auto b = eom::body_motions_of<FreeBody>(std::span(x.data(), 7), std::span(x.data() + 7, 6), p)[0];
    const auto w = principal(b.angular_velocity), e = exact.omega(t);
    for (int i = 0; i < 3; ++i) worst = std::max(worst, std::abs(w[i] - e[i]));
  });
  ASSERT_EQ(r.status, eom::Status::ok);
  EXPECT_LE(worst, 1e-10);
  std::printf("  |ω − ω_exact| ≤ %.2e over 20 s (principal moments %.4f %.4f %.4f)\n", worst,
              principal.moments[0], principal.moments[1], principal.moments[2]);
}

// Extrapolation in long double (eom/integration/high_precision.hpp) on (q, v) with the quaternion normalized
// in long double: the body rates against the closed form, and dop853 against it.
TEST(FloatingIntegrators, HighPrecisionReferenceOnTheManifold) {
  using L = long double;
  const auto p = parameters<Body>();
  const BodyState x0 = body_start();
  const auto b0 = eom::body_motions_of<FreeBody>(std::span(x0.data(), 7), std::span(x0.data() + 7, 6), p)[0];
  const PrincipalAxes principal(b0.inertia);
  const eomtest::FreeRigidBody exact(principal.moments, principal(b0.angular_velocity));
  std::array<L, 13> xl;
  std::array<L, 11> pl;
  std::copy(x0.begin(), x0.end(), xl.begin());
  std::copy(p.begin(), p.end(), pl.begin());
  const std::vector<double> times{0.5, 1.0};
  eom::ExtrapolationOptions xo;
  xo.tolerance = 1e-16;  // above long double's round-off (≈ 1e-19 a step)
  std::vector<BodyState> ref;
  double worst = 0, worst_norm = 0;
  const auto r = eom::extrapolate<FreeBody, L>(0.0, xl, times, nullptr, pl.data(), xo,
                                               [&](double t, const std::array<L, 13>& x) {
    BodyState xd;
    std::copy(x.begin(), x.end(), xd.begin());
    ref.push_back(xd);
    worst_norm = std::max(worst_norm, double(eom::quaternion_norm_error<L>(eom::Layout(7, 6), x.data())));
    const auto b = eom::body_motions_of<FreeBody>(std::span(xd.data(), 7), std::span(xd.data() + 7, 6), p)[0];
    const auto w = principal(b.angular_velocity), e = exact.omega(t);
    for (int i = 0; i < 3; ++i) worst = std::max(worst, std::abs(w[i] - e[i]));
  });
  ASSERT_EQ(r.status, eom::Status::ok);
  EXPECT_LE(worst, 1e-14);
  EXPECT_LE(worst_norm, 1e-18);
  EXPECT_LT(r.accepted, 100);
  eom::AdaptiveOptions opt;
  opt.rtol = opt.atol = 1e-12;
  opt.output_times = times;
  std::size_t k = 0;
  double error = 0;
  eom::dop853<Body>(0, 1, x0, nullptr, p.data(), opt,
                    [&](double, const BodyState& x) { error = std::max(error, max_abs_diff(x, ref[k++])); });
  std::printf("  extrapolation: %ld steps, |ω − ω_exact| ≤ %.1e; dop853 (1e-12) off it by %.1e\n",
              r.accepted, worst, error);
  EXPECT_LE(error, 1e-10);
  // an initial quaternion off the unit sphere
  xl[3] *= 1 + 1e-5L;
  const auto none = [](double, const std::array<L, 13>&) {};
  EXPECT_EQ((eom::extrapolate<FreeBody, L>(0.0, xl, times, nullptr, pl.data(), xo, none).status),
            eom::Status::invalid_argument);
}

// ---- the unit quaternion, order, energy -----------------------------------------------------

// Every state a method hands out, after every step (when `every_step`) and in dense output, has
// a unit quaternion; without the normalization its norm drifts by about the local error.
template <class K>
void check_unit_quaternion(eom::Method method, const eom::StateFor<K>& x0, const double* p,
                           const double* u, double t1, bool every_step = true) {
  eom::IntegrationOptions opt;
  opt.method = method;
  opt.rtol = opt.atol = 1e-8;
  opt.step = 0.01;
  double worst_steps = 0, worst_dense = 0;
  long steps = 0, dense = 0;
  if (every_step) {
    const auto r = eom::integrate<K>(0, t1, x0, u, p, opt, [&](double, const eom::StateFor<K>& x) {
      worst_steps = std::max(worst_steps, norm_error<K>(x));
      ++steps;
    });
    ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(method) << ": " << eom::to_string(r.status);
    EXPECT_GT(steps, 5) << eom::to_string(method);
  }
  std::vector<double> times;
  for (int k = 0; k <= 20; ++k) times.push_back(t1 * k / 20.0 + (k % 3 == 1 ? 1e-3 * t1 : 0.0));
  times.back() = t1;
  opt.output_times = times;
  const auto d = eom::integrate<K>(0, t1, x0, u, p, opt, [&](double, const eom::StateFor<K>& x) {
    worst_dense = std::max(worst_dense, norm_error<K>(x));
    ++dense;
  });
  ASSERT_EQ(d.status, eom::Status::ok) << eom::to_string(method);
  EXPECT_EQ(dense, 21) << eom::to_string(method);
  EXPECT_LE(worst_steps, 1e-15) << eom::to_string(method);
  EXPECT_LE(worst_dense, 1e-15) << eom::to_string(method);
  EXPECT_LE(norm_error<K>(d.x), 1e-15);
}

TEST(FloatingIntegrators, QuaternionStaysUnitAfterEveryStepAndInDenseOutput) {
  auto pb = parameters<Body>();
  pb[10] = 9.81;  // gravity: the body falls while it tumbles
  const auto pt = parameters<Tree>();
  const std::array<double, 3> u{0.3, -0.2, 0.1};
  for (auto m : {eom::Method::rk4, eom::Method::dopri5, eom::Method::dop853, eom::Method::radau5})
    check_unit_quaternion<Body>(m, body_start(), pb.data(), nullptr, 2.0);
  // The reference's Taylor coefficients are slow (its jets): dense output over a few steps (the
  // free-flight test above watches every step).
  {
    check_unit_quaternion<Body>(eom::Method::taylor, body_start(), pb.data(), nullptr, 0.3, false);
  }
  for (auto m : {eom::Method::rk4, eom::Method::dopri5, eom::Method::dop853})  // radau5: below
    check_unit_quaternion<Tree>(m, tree_start(), pt.data(), u.data(), 0.5);
}

// The normalization is a projection after the step: rk4 keeps its order 4, FreeTree with
// gravity, inputs and damping. The differences between runs at h, h/2, h/4 shrink by 2⁴.
TEST(FloatingIntegrators, Rk4KeepsOrderFourWithTheNormalization) {
  const auto p = parameters<Tree>();
  const std::array<double, 3> u{0.3, -0.2, 0.1};
  const TreeState x0 = tree_start(2.0);
  auto run = [&](long steps) {
    const auto r = eom::rk4<Tree>(0, 1, steps, x0, u.data(), p.data(), [](double, const TreeState&) {});
    EXPECT_EQ(r.status, eom::Status::ok);
    return r.x;
  };
  const TreeState a = run(32), b = run(64), c = run(128);
  const double d1 = max_abs_diff(a, b), d2 = max_abs_diff(b, c);
  std::printf("  rk4 |x_h − x_h/2| %.3e, |x_h/2 − x_h/4| %.3e, ratio %.2f\n", d1, d2, d1 / d2);
  EXPECT_GT(d2, 1e-10);  // well above round-off
  EXPECT_NEAR(d1 / d2, 16, 1.5);
}

TEST(FloatingIntegrators, Dop853ConservesTheEnergyOfTheUndampedTree) {
  auto p = parameters<Tree>();
  p[5] = 0;  // no elbow damping; no inputs: T + V is conserved
  const std::array<double, 3> u{};
  const TreeState x0 = tree_start(2.0);
  auto energy = [&](const TreeState& x) {
    return Tree::kinetic_energy(x.data(), x.data() + 10, p.data()) +
           Tree::potential_energy(x.data(), p.data());
  };
  const double E0 = energy(x0);
  eom::AdaptiveOptions opt;
  opt.rtol = opt.atol = 1e-12;
  double worst = 0;
  const auto r = eom::dop853<Tree>(0, 2, x0, u.data(), p.data(), opt, [&](double, const TreeState& x) {
    worst = std::max(worst, std::abs(energy(x) - E0) / std::abs(E0));
  });
  ASSERT_EQ(r.status, eom::Status::ok);
  std::printf("  %ld steps, |ΔE|/|E| ≤ %.2e\n", r.accepted, worst);
  EXPECT_LE(worst, 1e-10);
  // The damped tree loses energy (the check above can fail).
  p[5] = 0.5;
  opt.rtol = opt.atol = 1e-6;
  const auto d = eom::dop853<Tree>(0, 2, x0, u.data(), p.data(), opt, [](double, const TreeState&) {});
  EXPECT_LT(energy(d.x), E0 - 1e-3);
}

// ---- bad input ------------------------------------------------------------------------------

TEST(FloatingIntegrators, QuaternionOffTheUnitSphereIsRefused) {
  auto p = parameters<Body>();
  p[10] = 9.81;
  BodyState bad = body_start();
  for (int i = 3; i < 7; ++i) bad[i] *= 1 + 1e-5;
  BodyState slightly = body_start();
  for (int i = 3; i < 7; ++i) slightly[i] *= 1 + 1e-7;  // within quaternion_norm_tolerance
  {
    for (auto m : {eom::Method::rk4, eom::Method::dopri5, eom::Method::dop853, eom::Method::radau5,
                   eom::Method::taylor, eom::Method::taylor_paper}) {
      eom::IntegrationOptions opt;
      opt.method = m;
      opt.step = 0.01;
      long calls = 0;
      const auto r = eom::integrate<Body>(0, 1, bad, nullptr, p.data(), opt,
                                          [&](double, const BodyState&) { ++calls; });
      EXPECT_EQ(r.status, eom::Status::invalid_argument) << eom::to_string(m);
      EXPECT_EQ(calls, 0);
      EXPECT_EQ(r.accepted + r.evaluations, 0);
      EXPECT_EQ(r.x, bad);
      const auto ok = eom::integrate<Body>(0, 0.02, slightly, nullptr, p.data(), opt);
      EXPECT_EQ(ok.status, eom::Status::ok) << eom::to_string(m);
      EXPECT_LE(norm_error<Body>(ok.x), 1e-15);
      // with events too
      const eom::Event events[]{{.g = [](double, const double* q, const double*) { return q[2] + 10; }}};
      std::array<eom::EventRecord<7, 6>, 4> storage;
      eom::EventLog<7, 6> log(storage);
      EXPECT_EQ(eom::integrate<Body>(0, 1, bad, nullptr, p.data(), opt, events, log).status,
                eom::Status::invalid_argument);
    }
    // the methods' own entry points
    const auto none = [](double, const BodyState&) {};
    eom::AdaptiveOptions a;
    EXPECT_EQ(eom::rk4<Body>(0, 1, 10, bad, nullptr, p.data(), none).status, eom::Status::invalid_argument);
    EXPECT_EQ(eom::dopri5<Body>(0, 1, bad, nullptr, p.data(), a, none).status, eom::Status::invalid_argument);
    EXPECT_EQ(eom::dop853<Body>(0, 1, bad, nullptr, p.data(), a, none).status, eom::Status::invalid_argument);
    EXPECT_EQ(eom::radau5<Body>(0, 1, bad, nullptr, p.data(), a, none).status, eom::Status::invalid_argument);
    EXPECT_EQ(eom::taylor<Body>(0, 1, bad, nullptr, p.data(), a, eom::TaylorOptions{}, none).status,
              eom::Status::invalid_argument);
    EXPECT_EQ(eom::taylor_fixed<Body>(0, 1, 10, 8, bad, nullptr, p.data(), none).status,
              eom::Status::invalid_argument);
    EXPECT_EQ(eom::taylor_fixed<Body>(0, 0.01, 1, 2, slightly, nullptr, p.data(), none).status,
              eom::Status::ok);
    // NaN in v, as without a free joint
    BodyState nan_v = body_start();
    nan_v[10] = std::nan("");
    EXPECT_EQ(eom::dop853<Body>(0, 1, nan_v, nullptr, p.data(), a, none).status,
              eom::Status::invalid_argument);
  }
}

TEST(FloatingIntegrators, VariationalRefusesAFreeJoint) {
  const auto p = parameters<Body>();
  eom::IntegrationOptions opt;
  opt.method = eom::Method::variational;
  opt.step = 0.01;
  long calls = 0;
  const auto observer = [&](double, const BodyState&) { ++calls; };
  EXPECT_EQ(eom::integrate<Body>(0, 1, body_start(), nullptr, p.data(), opt, observer).status,
            eom::Status::method_unavailable);
  BodyState bad = body_start();
  bad[3] *= 1.1;
  EXPECT_EQ(eom::integrate<Body>(0, 1, bad, nullptr, p.data(), opt, observer).status,
            eom::Status::method_unavailable);
  const auto r = eom::variational<Body>(0, 1, 100, body_start(), nullptr, p.data(), observer);
  EXPECT_EQ(r.status, eom::Status::method_unavailable);
  EXPECT_EQ(r.evaluations, 0);
  EXPECT_EQ(calls, 0);
}

// ---- events ---------------------------------------------------------------------------------

// The mass centre's height, from the body's pose.
double centre_height(const double* q, const double* p) {
  return eom::body_motions_of<FreeBody>(std::span(q, 7), std::span(q, 6), std::span(p, 11))[0].position[2];
}

// FreeBody thrown up while tumbling: its mass centre falls as z_c0 + w t − g t²/2, whatever the
// rotation does, so the time it passes a level is known in closed form.
TEST(FloatingIntegrators, EventLocatedOnTheFallOfTheMassCentre) {
  auto p = parameters<Body>();
  const double g = 9.81, level = -1.0;
  p[10] = g;
  const BodyState x0 = body_start();
  const auto b0 = eom::body_motions_of<FreeBody>(std::span(x0.data(), 7), std::span(x0.data() + 7, 6), p)[0];
  const double z0 = b0.position[2], w = b0.velocity[2];
  const double exact = (w + std::sqrt(w * w + 2 * g * (z0 - level))) / g;
  auto height = [&](double, const double* q, const double*, const double*, const double* pp) {
    return centre_height(q, pp) - level;
  };
  const eom::Event events[]{{.g = height, .direction = eom::EventDirection::falling,
                             .action = eom::EventAction::terminate}};
  for (auto m : {eom::Method::dop853, eom::Method::dopri5, eom::Method::rk4, eom::Method::radau5}) {
    eom::IntegrationOptions opt;
    opt.method = m;
    opt.rtol = opt.atol = 1e-12;
    opt.step = 1e-3;
    std::array<eom::EventRecord<7, 6>, 4> storage;
    eom::EventLog<7, 6> log(storage);
    eom::IntegrationResultFor<Body> r;
    r = eom::integrate<Body>(0, 5, x0, nullptr, p.data(), opt, events, log);
    ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(m);
    ASSERT_EQ(log.size(), 1u);
    EXPECT_EQ(r.event, 0);
    EXPECT_NEAR(r.t, exact, m == eom::Method::rk4 ? 1e-9 : 1e-11) << eom::to_string(m);
    EXPECT_LE(norm_error<Body>(log.records()[0].x), 1e-15);
    EXPECT_NEAR(centre_height(r.x.data(), p.data()), level, 1e-10);
    std::printf("  %s: event at %.15f (closed form %.15f)\n", eom::to_string(m), r.t, exact);
  }
}

// A reset may change q and v; one that moves the quaternion off the unit sphere fails, one that
// keeps it (within the tolerance) goes on normalized.
TEST(FloatingIntegrators, ResetMapsAreCheckedAndNormalized) {
  auto p = parameters<Body>();
  p[10] = 9.81;
  auto height = [&](double, const double* q, const double*, const double*, const double* pp) {
    return centre_height(q, pp) + 1.0;
  };
  auto bounce = [](double, double* q, double* v) {  // up again, the quaternion barely touched
    v[2] = std::abs(v[2]);
    q[3] *= 1 + 1e-9;
    return true;
  };
  auto twist = [](double, double* q, double*) {
    q[3] *= 1.01;
    return true;
  };
  const eom::Event bouncing[]{{.g = height, .direction = eom::EventDirection::falling,
                               .action = eom::EventAction::reset, .reset = bounce}};
  const eom::Event twisting[]{{.g = height, .direction = eom::EventDirection::falling,
                               .action = eom::EventAction::reset, .reset = twist}};
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  std::array<eom::EventRecord<7, 6>, 8> storage;
  eom::EventLog<7, 6> log(storage);
  double worst = 0;
  const auto watch = [&](double, const BodyState& x) { worst = std::max(worst, norm_error<Body>(x)); };
  const auto r = eom::integrate<Body>(0, 3, body_start(), nullptr, p.data(), opt, bouncing, log, watch);
  ASSERT_EQ(r.status, eom::Status::ok);
  EXPECT_GE(log.size(), 2u);
  for (const auto& e : log.records()) EXPECT_LE(norm_error<Body>(e.x_after), 1e-15);
  EXPECT_LE(worst, 1e-15);
  log.clear();
  const auto f = eom::integrate<Body>(0, 3, body_start(), nullptr, p.data(), opt, twisting, log);
  EXPECT_EQ(f.status, eom::Status::event_reset_failed);
  EXPECT_EQ(f.event, 0);
}


// ---- radau5: the Jacobian in the embedding --------------------------------------------------

// radau5 on FreeTree with its iteration matrix from the tangent-space derivatives (D_q G⁺, G,
// ∂(G v)/∂q): it agrees with dop853 to its tolerance, in dense output too, and Newton converges
// as on a model without a free joint (no rejected steps, about two iterations a step).
TEST(FloatingIntegrators, Radau5WithTheEmbeddedJacobian) {
  const auto p = parameters<Tree>();
  const std::array<double, 3> u{0.3, -0.2, 0.1};
  const TreeState x0 = tree_start();
  std::vector<double> times;
  for (int k = 1; k <= 10; ++k) times.push_back(0.05 * k - 0.013 * (k % 2));
  eom::AdaptiveOptions tight, opt;
  tight.rtol = tight.atol = 1e-11;
  opt.rtol = opt.atol = 1e-8;
  tight.output_times = opt.output_times = times;
  std::vector<TreeState> ref, got;
  {
    eom::dop853<Tree>(0, 0.5, x0, u.data(), p.data(), tight,
                      [&](double, const TreeState& x) { ref.push_back(x); });
    const auto r = eom::radau5<Tree>(0, 0.5, x0, u.data(), p.data(), opt,
                                     [&](double, const TreeState& x) { got.push_back(x); });
    ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status);
    ASSERT_EQ(got.size(), times.size());
    double error = 0, worst_norm = norm_error<Tree>(r.x);
    for (std::size_t k = 0; k < times.size(); ++k) {
      error = std::max(error, max_abs_diff(got[k], ref[k]));
      worst_norm = std::max(worst_norm, norm_error<Tree>(got[k]));
    }
    std::printf("  radau5: %ld accepted, %ld rejected, %.1f evaluations a step, dense error %.2e\n",
                r.accepted, r.rejected, double(r.evaluations) / r.accepted, error);
    EXPECT_LE(error, 1e-6);
    EXPECT_LE(r.rejected, 2);
    EXPECT_LE(r.evaluations, 8 * r.accepted + 4);  // ≤ 2⅓ Newton iterations a step on average
    EXPECT_LE(worst_norm, 1e-15);
  }
}

// ---- sensitivities in the tangent space -----------------------------------------------------

// x ⊖ y in the tangent space at y: position, rotation 2 (ȳ ⊗ x).vec, joints, then velocities.
template <class K> std::array<double, 2 * K::nv> minus(const eom::StateFor<K>& x, const eom::StateFor<K>& y) {
  constexpr int nq = K::nq, nv = K::nv;
  std::array<double, 2 * nv> d{};
  for (int i = 0; i < 3; ++i) d[i] = x[i] - y[i];
  const double* a = y.data() + 3;  // ȳ ⊗ x: (a₀ b₀ + a·b, a₀ b − b₀ a − a × b) for a = y's
  const double* b = x.data() + 3;
  d[3] = 2 * (a[0] * b[1] - b[0] * a[1] - (a[2] * b[3] - a[3] * b[2]));
  d[4] = 2 * (a[0] * b[2] - b[0] * a[2] - (a[3] * b[1] - a[1] * b[3]));
  d[5] = 2 * (a[0] * b[3] - b[0] * a[3] - (a[1] * b[2] - a[2] * b[1]));
  for (int i = 6; i < nv; ++i) d[i] = x[i + 1] - y[i + 1];
  for (int i = 0; i < nv; ++i) d[nv + i] = x[nq + i] - y[nq + i];
  return d;
}

// Φ = ∂x(t)/∂x(t0) and S = ∂x(t)/∂p of eom::Sensitivity against central differences on the
// manifold: x0 ⊕ ε e_j (q ⊗ exp(ε e/2) for the rotation), the results compared by ⊖.
TEST(FloatingIntegrators, SensitivitiesMatchDifferencesOnTheManifold) {
  using S = eom::Sensitivity<Body, eom::with_parameters>;
  static_assert(S::nq == S::nv + 1 && S::m == 12 && S::ns == 11);
  auto p = parameters<Body>();
  p[10] = 9.81;
  const BodyState x0 = body_start();
  const double t1 = 1.0, eps = 1e-5;
  {
    eom::IntegrationOptions opt;
    opt.method = eom::Method::dop853;
    opt.rtol = opt.atol = 1e-11;
    const auto r = eom::integrate<S>(0, t1, S::start(x0), nullptr, p.data(), opt);
    ASSERT_EQ(r.status, eom::Status::ok);
    const auto phi = S::transition(r.x);
    const auto sp = S::parameter_sensitivity(r.x);
    opt.rtol = opt.atol = 1e-12;
    auto run = [&](const BodyState& x, const std::array<double, 11>& pp) {
      return eom::integrate<Body>(0, t1, x, nullptr, pp.data(), opt).x;
    };
    const BodyState nominal = run(x0, p);
    double worst = 0, scale = 0;
    for (int j : {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12 + 0, 12 + 1, 12 + 7, 12 + 10}) {  // m, Ixx, cx, g
      BodyState xp = x0, xm = x0;
      std::array<double, 11> pp = p, pm = p;
      if (j < 6) {
        std::array<double, 6> e{};
        e[j] = 1;
        eom::integrate_configuration(eom::Layout(7, 6), x0.data(), e.data(), eps, xp.data());
        eom::integrate_configuration(eom::Layout(7, 6), x0.data(), e.data(), -eps, xm.data());
      } else if (j < 12) {
        xp[7 + j - 6] += eps, xm[7 + j - 6] -= eps;
      } else {
        const double d = eps * std::max(1.0, std::abs(p[j - 12]));
        pp[j - 12] += d, pm[j - 12] -= d;
      }
      const auto dp = minus<Body>(run(xp, pp), nominal), dm = minus<Body>(run(xm, pm), nominal);
      const double width = j < 12 ? 2 * eps : 2 * eps * std::max(1.0, std::abs(p[j - 12]));
      for (int i = 0; i < 12; ++i) {
        const double fd = (dp[i] - dm[i]) / width;
        const double got = j < 12 ? phi[i + 12 * j] : sp[i + 12 * (j - 12)];
        worst = std::max(worst, std::abs(got - fd));
        scale = std::max(scale, std::abs(fd));
      }
    }
    std::printf("  max |Φ, S − differences| %.2e (entries up to %.2e)\n", worst, scale);
    EXPECT_LE(worst, 1e-6 * scale);
  }
}


// ---- constraint stabilization ---------------------------------------------------------------

// FreeBody with one of its points held on the plane z = 0 (it rocks and slides, frictionless):
// a constraint on position and orientation together.
struct PlanePoint : FreeBody {
  static constexpr std::array constraint_names{"on_plane"};
  static constexpr std::array<double, 3> point{0.05, -0.02, -0.3};  // in the body frame
  template <class S> static void constraints(eom::In<S> q, eom::In<S>, eom::Out<S> phi) {
    const auto R = eom::quaternion(q[3], q[4], q[5], q[6]);
    phi[0] = q[2] + R[2] * point[0] + R[5] * point[1] + R[8] * point[2];
  }
};
using Rocking = eom::Reference<PlanePoint>;
static_assert(Rocking::nc == 1 && Rocking::nv == 6);

// Projection moves q by q ⊕ Δ in the tangent space (the quaternion stays unit) and v onto C v = 0;
// Baumgarte uses the kernels as they are. Both keep the body on the plane.
TEST(FloatingIntegrators, StabilizationKeepsAPointOnThePlane) {
  auto p = parameters<Rocking>();
  p[10] = 9.81;
  BodyState x0 = body_start();
  {
    std::array<double, 1> phi;
    Rocking::constraint_residual(x0.data(), p.data(), phi.data());
    x0[2] -= phi[0] - 1e-4;  // 1e-4 off the plane, C v ≠ 0: projection's first job
  }
  auto energy = [&](const BodyState& x) {
    return Rocking::kinetic_energy(x.data(), x.data() + 7, p.data()) +
           Rocking::potential_energy(x.data(), p.data());
  };
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = opt.atol = 1e-10;
  opt.stabilization.method = eom::Stabilization::Method::projection;
  double worst_phi = 0, worst_rate = 0, worst_norm = 0, E0 = 0, worst_E = 0;
  bool first = true;
  auto watch = [&](double, const BodyState& x) {
    const auto res = eom::constraint_residuals<Rocking>(x.data(), x.data() + 7, p.data());
    worst_phi = std::max(worst_phi, res[0]);
    worst_rate = std::max(worst_rate, res[1]);
    worst_norm = std::max(worst_norm, norm_error<Rocking>(x));
    if (first) E0 = energy(x), first = false;
    worst_E = std::max(worst_E, std::abs(energy(x) - E0) / std::abs(E0));
  };
  const auto r = eom::integrate<Rocking>(0, 2, x0, nullptr, p.data(), opt, watch);
  ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status);
  std::printf("  projection: %ld steps, |φ| ≤ %.1e, |C v| ≤ %.1e, |ΔE|/|E| ≤ %.1e\n", r.accepted,
              worst_phi, worst_rate, worst_E);
  EXPECT_LE(worst_phi, 1e-13);
  EXPECT_LE(worst_rate, 1e-12);
  EXPECT_LE(worst_norm, 1e-15);
  EXPECT_LE(worst_E, 1e-8);
  // the dense output is projected and normalized too
  const std::vector<double> times{0.1, 0.37, 1.23, 2.0};
  opt.output_times = times;
  worst_phi = worst_rate = worst_norm = 0;
  ASSERT_EQ(eom::integrate<Rocking>(0, 2, x0, nullptr, p.data(), opt, watch).status, eom::Status::ok);
  EXPECT_LE(worst_phi, 1e-13);
  EXPECT_LE(worst_norm, 1e-15);

  // Baumgarte from the projected start; without stabilization the start off the plane is refused.
  BodyState start = x0;
  ASSERT_TRUE(eom::project<Rocking>(start.data(), start.data() + 7, p.data(), 1e-14));
  EXPECT_LE(norm_error<Rocking>(start), 1e-15);
  opt.output_times = {};
  opt.stabilization.method = eom::Stabilization::Method::baumgarte;
  worst_phi = worst_rate = 0;
  const auto b = eom::integrate<Rocking>(0, 2, start, nullptr, p.data(), opt, watch);
  ASSERT_EQ(b.status, eom::Status::ok);
  std::printf("  Baumgarte: |φ| ≤ %.1e, |C v| ≤ %.1e\n", worst_phi, worst_rate);
  EXPECT_LE(worst_phi, 1e-8);
  EXPECT_LE(worst_rate, 1e-7);
  opt.stabilization.method = eom::Stabilization::Method::none;
  EXPECT_EQ(eom::integrate<Rocking>(0, 2, x0, nullptr, p.data(), opt).status,
            eom::Status::inconsistent_initial_state);
}

// ---- ensembles ------------------------------------------------------------------------------

// FreeTree cases on two threads, each bitwise as eom::integrate gives it alone (end state and
// samples); a case with a quaternion off the unit sphere reports invalid_argument by itself.
TEST(FloatingIntegrators, EnsembleEqualsSingleRunsBitForBit) {
  const auto p = parameters<Tree>();
  const std::array<double, 3> u{0.3, -0.2, 0.1};
  std::vector<TreeState> x0;
  for (int c = 0; c < 4; ++c) {
    TreeState x = tree_start(0.5 + 0.5 * c);
    x[16] += 0.3 * c;  // the shoulder's rate
    x0.push_back(x);
  }
  x0.push_back(x0[0]);
  x0.back()[4] += 1e-3;  // not a unit quaternion
  const std::vector<double> samples{0.1, 0.25, 0.3};
  eom::EnsembleOptions opt;
  opt.t1 = 0.3;
  opt.threads = 2;
  opt.integration.method = eom::Method::dop853;
  opt.integration.rtol = opt.integration.atol = 1e-8;
  opt.sample_times = samples;
  const eom::EnsembleResultFor<Tree> r = eom::ensemble<Tree>({x0, p, u}, opt);
  ASSERT_EQ(r.status, eom::Status::ok);
  ASSERT_EQ(r.cases.size(), x0.size());
  EXPECT_EQ(r.failed(), 1u);
  EXPECT_EQ(r.cases[4].status, eom::Status::invalid_argument);
  for (std::size_t c = 0; c < x0.size(); ++c) {
    eom::IntegrationOptions io = opt.integration;
    io.output_times = samples;
    std::vector<TreeState> seen;
    const auto alone = eom::integrate<Tree>(0, 0.3, x0[c], u.data(), p.data(), io,
                                            [&](double, const TreeState& x) { seen.push_back(x); });
    EXPECT_EQ(r.cases[c].status, alone.status);
    EXPECT_EQ(r.cases[c].x, alone.x) << "case " << c;
    EXPECT_EQ(r.cases[c].accepted, alone.accepted);
    if (alone.status != eom::Status::ok) continue;
    EXPECT_LE(norm_error<Tree>(alone.x), 1e-15);
    ASSERT_EQ(seen.size(), samples.size());
    for (std::size_t k = 0; k < samples.size(); ++k) EXPECT_EQ(r.sample(c, k), seen[k]) << c << ", " << k;
  }
}


// ---- latches --------------------------------------------------------------------------------

// A latch on FreeTree's elbow (eom/integration/locks.hpp): a row over q whose quaternion entries are 0 acts
// on v through the same entries.
struct ElbowRow {
  static constexpr int count = 1;
  static constexpr std::array<std::array<double, 10>, 1> rows{{{0, 0, 0, 0, 0, 0, 0, 0, 1, 0}}};
};
using LockedTree = eom::Locked<Tree, ElbowRow>;
static_assert(LockedTree::nv == 9 && LockedTree::velocity_rows[0][7] == 1);

TEST(FloatingIntegrators, LatchHoldsTheElbowOfAFlyingTree) {
  const auto p = parameters<Tree>();
  const std::array<double, 3> u{};
  TreeState x0 = tree_start();
  x0[17] = -3;  // elbow at −0.6 rad, turning at −3 rad/s
  eom::Latches<LockedTree> latches(p, {-0.7}, x0);
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = opt.atol = 1e-10;
  std::array<eom::EventRecord<10, 9>, 4> storage;
  eom::EventLog<10, 9> log(storage);
  std::vector<std::pair<double, TreeState>> seen;
  const auto r = eom::integrate<LockedTree>(0, 0.5, x0, u.data(), latches.parameters.data(), opt,
                                            latches.events(), log,
                                            [&](double t, const TreeState& x) { seen.emplace_back(t, x); });
  ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status);
  ASSERT_EQ(log.size(), 1u);
  EXPECT_TRUE(latches.locked(0));
  const auto& latch = log.records()[0];
  EXPECT_NEAR(latch.x[8], -0.7, 1e-12);
  EXPECT_NEAR(latch.x_after[17], 0.0, 1e-14);  // the impulse stops the elbow
  double worst_angle = 0, worst_rate = 0, worst_norm = 0;
  long after = 0;
  for (const auto& [t, x] : seen) {
    worst_norm = std::max(worst_norm, norm_error<Tree>(x));
    if (t <= latch.t) continue;
    ++after;
    worst_angle = std::max(worst_angle, std::abs(x[8] - latch.x[8]));
    worst_rate = std::max(worst_rate, std::abs(x[17]));
  }
  EXPECT_GT(after, 3);
  EXPECT_LE(worst_angle, 1e-12);
  EXPECT_LE(worst_rate, 1e-12);
  EXPECT_LE(worst_norm, 1e-15);
  EXPECT_GT(std::abs(r.x[16]), 0.1);  // the shoulder still moves
}

}  // namespace
