// eom::contact_step_derivatives (the Euler contact step's Jacobians) against MuJoCo's
// mjd_transitionFD (central differences of mj_step, its Newton solver run to its limit) at states
// along contact rollouts, with MuJoCo's step eps 1e-6 (the figure: within 1e-5) and 1e-7
// (its truncation over the impedance's 1 mm width, (eps / width)², 1e-6 at eps 1e-6, is then
// below our differences' error: within 1e-6): models/mjcf/primitives.xml with pyramidal and with
// elliptic cones (a free ball with condim 6, bodies on slides and hinges, limits with margins,
// friction loss), and MuJoCo's humanoid under random controls on the floor (joint damping, so
// the implicit damping's terms, and 21 actuators for B). The step it takes is contact_step's,
// bit for bit; bad input leaves the state and the Jacobians as they were.
#include <gtest/gtest.h>

#include <mujoco/mujoco.h>

#include "contact_peer.hpp"
#include "mujoco_peer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include <mjcf_primitives.hpp>
#include <mjcf_primitives_elliptic.hpp>
#include <mjcf_primitives_elliptic_model.hpp>
#include <mjcf_primitives_model.hpp>
#ifdef EOM_MJCF_HUMANOID
#include <mjcf_humanoid.hpp>
#include <mjcf_humanoid_model.hpp>
#endif

#include <eom/contact/step.hpp>
#include <eom/contact/step_derivatives.hpp>

namespace {

// max |ours − MuJoCo's| over max(1, max |MuJoCo's|): ours column-major n × m, MuJoCo's row-major.
double difference(const double* ours, const double* theirs, int n, int m) {
  double diff = 0, scale = 1;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      diff = std::max(diff, std::abs(ours[i + n * j] - theirs[m * i + j]));
      scale = std::max(scale, std::abs(theirs[m * i + j]));
    }
  return diff / scale;
}

struct Agreement {
  double A = 0, B = 0;               // the worst differences from MuJoCo's at eps 1e-7
  double A6 = 0, B6 = 0;             // at eps 1e-6
  double largest = 0;                // the largest |A| entry seen
  int states = 0, rows = 0;          // states compared, constraint rows over them
};

// At (q, v) under u (a copy of `stepper`'s warm start): our step and Jacobians against
// contact_step (the state after it, bitwise) and mjd_transitionFD (MuJoCo at the same state).
template <class K, class Model>
void compare_at(mjModel* m, mjData* d, const eom::ContactStepper<K, Model>& stepper, double t,
                const std::array<double, K::nq>& q, const std::array<double, K::nv>& v,
                const std::array<double, std::max(K::nu, 1)>& u, Agreement& out) {
  constexpr int nq = K::nq, nv = K::nv, nu = K::nu, n = 2 * nv;
  const double* p = K::parameter_values.data();
  auto ours = std::make_unique<eom::ContactStepper<K, Model>>(stepper);
  auto plain = std::make_unique<eom::ContactStepper<K, Model>>(stepper);
  auto jacobians = std::make_unique<eom::StepDerivatives<K, Model>>();
  std::array<double, nq> q1 = q, q2 = q;
  std::array<double, nv> v1 = v, v2 = v;
  double t1 = t, t2 = t;
  const auto derived = eom::contact_step_derivatives<K, Model>(*ours, *jacobians, t1, q1, v1, u.data(), p);
  ASSERT_EQ(derived, eom::StepStatus::ok);
  ASSERT_EQ((eom::contact_step<K, Model>(*plain, t2, q2, v2, u.data(), p)), eom::StepStatus::ok);
  EXPECT_EQ(q1, q2);
  EXPECT_EQ(v1, v2);
  EXPECT_EQ(t1, t2);

  mj_resetData(m, d);
  std::copy(q.begin(), q.end(), d->qpos);
  std::copy(v.begin(), v.end(), d->qvel);
  for (int k = 0; k < nu; ++k) d->ctrl[k] = u[k];
  d->time = t;
  mj_forward(m, d);
  std::vector<double> A(n * n), B(n * std::max(nu, 1));
  for (const double eps : {1e-6, 1e-7}) {
    mjd_transitionFD(m, d, eps, 1, A.data(), nu > 0 ? B.data() : nullptr, nullptr, nullptr);
    double& a = eps == 1e-6 ? out.A6 : out.A;
    double& b = eps == 1e-6 ? out.B6 : out.B;
    a = std::max(a, difference(jacobians->A.data(), A.data(), n, n));
    if (nu > 0) b = std::max(b, difference(jacobians->B.data(), B.data(), n, nu));
  }
  for (double x : A) out.largest = std::max(out.largest, std::abs(x));
  out.rows += ours->rows.rows;
  ++out.states;
}

// Four rollouts of the primitives from spread states with random velocities, compared every
// 40 steps after the first 40 (the bodies on the planes and each other by then).
template <class K, class Model>
void primitives_agree(const char* file, const char* cone) {
  eom::test::MujocoModel model = eom::test::solver_run_to_its_limit(file);
  ASSERT_TRUE(model);
  eom::test::MujocoData data(mj_makeData(model.get()));
  std::mt19937_64 rng(71);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> q0(K::nq);
  Agreement agreement;
  for (int run = 0; run < 4; ++run) {
    eom::test::spread(model.get(), rng, q0);
    auto stepper = std::make_unique<eom::ContactStepper<K, Model>>();
    std::array<double, K::nq> q;
    std::array<double, K::nv> v;
    std::copy(q0.begin(), q0.end(), q.begin());
    for (double& x : v) x = unit(rng);
    const std::array<double, 1> u{};
    double t = 0;
    for (int k = 1; k <= 200; ++k) {
      ASSERT_EQ((eom::contact_step<K, Model>(*stepper, t, q, v, nullptr, K::parameter_values.data())),
                eom::StepStatus::ok);
      if (k % 40 == 0) compare_at<K, Model>(model.get(), data.get(), *stepper, t, q, v, u, agreement);
    }
  }
  std::printf("%s (%s cone): eom::contact_step_derivatives against mjd_transitionFD (centered) "
              "at %d states (%d constraint rows in all): A within %.2e of max(1, |A|) at MuJoCo's "
              "eps 1e-6, %.2e at 1e-7 (its largest entry %.3g)\n",
              file, cone, agreement.states, agreement.rows, agreement.A6, agreement.A,
              agreement.largest);
  EXPECT_EQ(agreement.states, 20);
  EXPECT_GT(agreement.rows, 20 * 4);  // contacts at most states compared, several rows each
  EXPECT_LE(agreement.A6, 1e-5);
  EXPECT_LE(agreement.A, 1e-6);
}

TEST(step_derivatives, PyramidalAgreeWithMuJoCo) {
  primitives_agree<mjcf_primitives::Kernels, eom::mjcf_models::mjcf_primitives>(EOM_MJCF_PRIMITIVES,
                                                                               "pyramidal");
}
TEST(step_derivatives, EllipticAgreeWithMuJoCo) {
  primitives_agree<mjcf_primitives_elliptic::Kernels, eom::mjcf_models::mjcf_primitives_elliptic>(
      EOM_MJCF_PRIMITIVES_ELLIPTIC, "elliptic");
}

#ifdef EOM_MJCF_HUMANOID
// The humanoid let fall from its standing pose under random controls (within its ctrlrange),
// compared every 20 steps from the 200th (on the floor by then) to the 400th.
TEST(step_derivatives, HumanoidAgreesWithMuJoCo) {
  using K = mjcf_humanoid::Kernels;
  using Model = eom::mjcf_models::mjcf_humanoid;
  eom::test::MujocoModel model = eom::test::solver_run_to_its_limit(EOM_MJCF_HUMANOID);
  ASSERT_TRUE(model);
  eom::test::MujocoData data(mj_makeData(model.get()));
  std::mt19937_64 rng(72);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  auto stepper = std::make_unique<eom::ContactStepper<K, Model>>();
  std::array<double, K::nq> q;
  std::array<double, K::nv> v{};
  std::array<double, K::nu> u;
  std::copy(model->qpos0, model->qpos0 + K::nq, q.begin());
  v[0] = 0.3, v[4] = 0.5;  // a push forward and a turn about y
  double t = 0;
  Agreement agreement;
  for (int k = 1; k <= 400; ++k) {
    for (int j = 0; j < K::nu; ++j)
      u[j] = 0.9 * unit(rng) * model->actuator_ctrlrange[2 * j + 1];  // within the range
    ASSERT_EQ((eom::contact_step<K, Model>(*stepper, t, q, v, u.data(), K::parameter_values.data())),
              eom::StepStatus::ok);
    if (k >= 200 && k % 20 == 0)
      compare_at<K, Model>(model.get(), data.get(), *stepper, t, q, v, u, agreement);
  }
  std::printf("humanoid.xml: eom::contact_step_derivatives against mjd_transitionFD (centered) at "
              "%d states on the floor (%d constraint rows in all): A within %.2e, B within %.2e "
              "of max(1, their largest) at MuJoCo's eps 1e-6, %.2e and %.2e at 1e-7 (A's largest "
              "entry %.3g)\n",
              agreement.states, agreement.rows, agreement.A6, agreement.B6, agreement.A,
              agreement.B, agreement.largest);
  EXPECT_EQ(agreement.states, 11);
  EXPECT_GT(agreement.rows, 11 * 4);
  EXPECT_LE(agreement.A6, 1e-5);
  EXPECT_LE(agreement.B6, 1e-5);
  EXPECT_LE(agreement.A, 1e-6);
  EXPECT_LE(agreement.B, 1e-6);
}
#endif

// A NaN velocity: dynamics_failed, the state, the stepper's warm start and the Jacobians as they
// were.
TEST(step_derivatives, BadInputLeavesEverythingAsItWas) {
  using K = mjcf_primitives::Kernels;
  using Model = eom::mjcf_models::mjcf_primitives;
  auto stepper = std::make_unique<eom::ContactStepper<K, Model>>();
  auto jacobians = std::make_unique<eom::StepDerivatives<K, Model>>();
  jacobians->A.fill(7), jacobians->B.fill(7);
  std::array<double, K::nq> q{};
  std::array<double, K::nv> v{};
  q[3] = 1;  // the ball's unit quaternion
  v[2] = std::numeric_limits<double>::quiet_NaN();
  const auto q0 = q;
  double t = 0;
  const auto status = eom::contact_step_derivatives<K, Model>(*stepper, *jacobians, t, q, v, nullptr,
                                                               K::parameter_values.data());
  EXPECT_EQ(status, eom::StepStatus::dynamics_failed);
  EXPECT_EQ(q, q0);
  EXPECT_TRUE(std::isnan(v[2]));
  EXPECT_EQ(t, 0);
  for (double x : jacobians->A) EXPECT_EQ(x, 7);
}

}  // namespace
