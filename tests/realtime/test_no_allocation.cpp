// A control loop must not touch the heap: allocation takes locks and has unbounded latency. The
// global allocation functions are replaced here by counting ones; each test runs a loop of
// generated kernels, a controller and integrator steps, and asserts the count did not change.
// The first test shows the counter works (a std::vector is counted).
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include <cartesian_pendulum.hpp>
#include <chain10.hpp>
#include <closed_chain5.hpp>
#include <double_pendulum.hpp>
#include <example_arm3.hpp>
#include <example_cart_pole.hpp>
#include <spring_pendulum.hpp>

#include <models/chain.hpp>

#include <eom/dopri5.hpp>
#include <eom/reference.hpp>
#include <eom/rk4.hpp>
#include <eom/variational.hpp>

#include "arm3.hpp"             // examples/computed_torque: the model, for eom::Reference
#include "computed_torque.hpp"  // examples/computed_torque
#include "lqr.hpp"              // examples/lqr_cartpole

// ---- Counting replacements of every replaceable allocation function ----
namespace {
std::atomic<long> allocations{0};

void* allocate(std::size_t size) noexcept {
  allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(size ? size : 1);
}
void* allocate(std::size_t size, std::align_val_t alignment) noexcept {
  allocations.fetch_add(1, std::memory_order_relaxed);
  const auto a = static_cast<std::size_t>(alignment);
  return std::aligned_alloc(a, (size + a - 1) / a * a);  // the size must be a multiple
}
void* or_throw(void* p) {
  if (!p) throw std::bad_alloc();
  return p;
}
}  // namespace

void* operator new(std::size_t n) { return or_throw(allocate(n)); }
void* operator new[](std::size_t n) { return or_throw(allocate(n)); }
void* operator new(std::size_t n, std::align_val_t a) { return or_throw(allocate(n, a)); }
void* operator new[](std::size_t n, std::align_val_t a) { return or_throw(allocate(n, a)); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return allocate(n); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept { return allocate(n); }
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return allocate(n, a);
}
void* operator new[](std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return allocate(n, a);
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }

namespace {

// Stores a pointer where the optimizer must assume it is read, so no allocation is elided.
double* volatile sink = nullptr;

TEST(NoAllocation, TheCounterSeesAVector) {
  volatile std::size_t size = 64;  // not a constant: the allocation cannot be folded away
  const long before = allocations.load();
  {
    std::vector<double> v(size);
    sink = v.data();
  }
  auto* p = new double[size];
  sink = p;
  delete[] p;
  EXPECT_EQ(allocations.load() - before, 2);
}

// Computed torque on the three-link arm: per 1 ms sample, the reference (sin/cos), the control
// law (mass_matrix, coriolis, potential_gradient) and one RK4 step of the plant, as in
// examples/computed_torque.
TEST(NoAllocation, ComputedTorqueLoop) {
  using Arm = example_arm3::Kernels;
  using Controller = examples::ComputedTorque<Arm>;
  const Controller controller(Controller::critically_damped(10), Arm::parameter_values);
  const auto p = Arm::parameter_values;
  eom::StateOf<3> x{0.9, -1.1, 0.7, 0, 0, 0};
  double max_error = 0;
  bool ok = true;
  const long before = allocations.load();
  for (long k = 0; k < 3000; ++k) {
    const double t = k * 1e-3;
    Controller::Setpoint ref;
    for (int i = 0; i < 3; ++i) {
      const double w = 1.0 + 0.6 * i;
      ref.q[i] = 0.5 * std::sin(w * t);
      ref.qd[i] = 0.5 * w * std::cos(w * t);
      ref.qdd[i] = -0.5 * w * w * std::sin(w * t);
    }
    double tau[3];
    controller.torque(x.data(), x.data() + 3, ref, tau);
    ok = ok && eom::rk4_step<Arm>(t, 1e-3, x, tau, p.data());
    if (k > 2000)
      for (int i = 0; i < 3; ++i) max_error = std::max(max_error, std::abs(ref.q[i] - x[i]));
  }
  EXPECT_EQ(allocations.load() - before, 0);
  // The loop did its job (so nothing was optimized away): the arm follows the reference, started
  // 0.7-1.1 rad off it (examples/computed_torque asserts the tracking performance itself).
  EXPECT_TRUE(ok);
  EXPECT_LT(max_error, 1e-2);
}

// The LQR design (linearization, hold discretization, Riccati recursion) and its loop on the
// cart-pole, with a re-linearization every sample as a gain-scheduled controller would do.
TEST(NoAllocation, LqrDesignAndLoop) {
  using Plant = example_cart_pole::Kernels;
  namespace lqr = examples::lqr;
  const auto p = Plant::parameter_values;
  long before = allocations.load();
  lqr::Regulator<2, 1> regulator;
  lqr::Linearization<2, 1> lin;
  const double zero[2]{};
  ASSERT_TRUE(lqr::linearize<Plant>(zero, zero, zero, p.data(), lin));
  lqr::Matrix<4, 4> Q;  // the weights of examples/lqr_cartpole
  Q(0, 0) = 10, Q(1, 1) = 10, Q(2, 2) = 1, Q(3, 3) = 1;
  lqr::Matrix<1, 1> R;
  R(0, 0) = 0.1;
  const auto riccati = lqr::solve_dare(lqr::zero_order_hold(lin.A, lin.B, 0.01), Q, R);
  regulator.K = riccati.K;
  EXPECT_EQ(allocations.load() - before, 0) << "in the design";
  ASSERT_TRUE(riccati.converged);

  eom::StateOf<2> x{0.2, 0.1, 0, 0};
  bool ok = true;
  before = allocations.load();
  for (long k = 0; k < 1000; ++k) {
    double u[1];
    regulator.control(x.data(), u);
    ok = ok && lqr::linearize<Plant>(x.data(), x.data() + 2, u, p.data(), lin);
    for (int s = 0; s < 10; ++s)
      ok = ok && eom::rk4_step<Plant>(k * 0.01 + s * 1e-3, 1e-3, x, u, p.data());
  }
  EXPECT_EQ(allocations.load() - before, 0) << "in the loop";
  EXPECT_TRUE(ok);
  for (double v : x) EXPECT_LT(std::abs(v), 1e-3);  // stabilized after 10 s
}

// The integrators over the bundled models' generated kernels: DOPRI5, RK4 with projection and
// with Baumgarte stabilization, the variational integrator; and the sensitivities of chain10.
TEST(NoAllocation, IntegratorsOverGeneratedKernels) {
  const auto none = [](auto&&...) {};
  const long before = allocations.load();

  const auto pd = double_pendulum::parameter_values;
  const eom::StateOf<2> xd{2.0, 2.5, 0, 0};
  const auto adaptive =
      eom::dopri5<double_pendulum::Kernels>(0, 1, xd, nullptr, pd.data(), {}, none);

  const auto pc = closed_chain5::parameter_values;
  eom::StateOf<5> xc{};
  for (int i = 0; i < 5; ++i) xc[i] = eom::models::ClosedChain5::initial_q[i];
  eom::Stabilization projection;
  projection.method = eom::Stabilization::Method::projection;
  const auto projected =
      eom::rk4<closed_chain5::Kernels>(0, 0.5, 100, xc, nullptr, pc.data(), none, projection);

  const auto pp = cartesian_pendulum::parameter_values;
  const eom::StateOf<2> xp{0.8 * std::sin(0.3), -0.8 * std::cos(0.3), 1.2 * std::cos(0.3),
                           1.2 * std::sin(0.3)};
  eom::Stabilization baumgarte;
  baumgarte.method = eom::Stabilization::Method::baumgarte;
  const auto stabilized =
      eom::rk4<cartesian_pendulum::Kernels>(0, 1, 200, xp, nullptr, pp.data(), none, baumgarte);

  const auto ps = spring_pendulum::parameter_values;
  const eom::StateOf<2> xs{0.55, 0.0, 0.01, 2.5};
  const auto symplectic =
      eom::variational<spring_pendulum::Kernels>(0, 1, 200, xs, nullptr, ps.data(), none);

  const auto p10 = chain10::parameter_values;
  std::array<double, 10> q10{}, qd10{};
  std::array<double, 100> dq, dqd;
  const bool derivatives = chain10::forward_dynamics_derivatives(
      0, q10.data(), qd10.data(), nullptr, p10.data(), dq.data(), dqd.data(), nullptr);

  EXPECT_EQ(allocations.load() - before, 0);
  EXPECT_EQ(adaptive.status, eom::Status::ok);
  EXPECT_EQ(projected.status, eom::Status::ok);
  EXPECT_EQ(stabilized.status, eom::Status::ok);
  EXPECT_EQ(symplectic.status, eom::Status::ok);
  EXPECT_TRUE(derivatives);
}

// The run-time AD reference keeps its numbers on the stack too.
TEST(NoAllocation, ReferenceKernels) {
  using Ref = eom::Reference<examples::Arm3>;
  const auto p = Ref::parameter_values;
  const double q[3]{0.3, -0.4, 0.5}, qd[3]{1, -2, 3}, u[3]{1, 2, 3};
  double dq[9], dqd[9], du[9], tau[3];
  const long before = allocations.load();
  const bool ok = Ref::forward_dynamics_derivatives(0, q, qd, u, p.data(), dq, dqd, du);
  Ref::inverse_dynamics(0, q, qd, qd, u, p.data(), tau);
  EXPECT_EQ(allocations.load() - before, 0);
  EXPECT_TRUE(ok);
  EXPECT_TRUE(std::isfinite(tau[0]));
}

}  // namespace
