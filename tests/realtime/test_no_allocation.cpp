// A control loop must not touch the heap: allocation takes locks and has unbounded latency. The
// global allocation functions are replaced here by counting ones; each test runs a loop of
// generated kernels, a controller and integrator steps, and asserts the count did not change.
// The counter is shown to work on a std::vector, and on the one allocation the Taylor
// integrator makes when the caller gives it no workspace.
#include <array>
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

#include <eom/integration/dop853.hpp>
#include <eom/integration/dopri5.hpp>
#include <eom/integration/integrate.hpp>
#include <eom/integration/radau5.hpp>
#include <eom/integration/rk4.hpp>
#include <eom/integration/taylor.hpp>
#include <eom/integration/variational.hpp>
#include <eom/reference/reference.hpp>

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

// The replaced operator delete frees what the replaced operator new took from malloc; GCC 12 at
// -O1 (tests/CMakeLists.txt: EOM_TEST_OPTIMIZATION) sees only "new" paired with free.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
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
// law (mass_matrix, coriolis, potential_gradient) and the plant carried to the next sample by
// eom::integrate (DOP853, the torque held), as in examples/computed_torque.
TEST(NoAllocation, ComputedTorqueLoop) {
  using Arm = example_arm3::Kernels;
  using Controller = examples::ComputedTorque<Arm>;
  const Controller controller(Controller::critically_damped(10), Arm::parameter_values);
  const auto p = Arm::parameter_values;
  eom::StateOf<3> x{0.9, -1.1, 0.7, 0, 0, 0};
  double max_error = 0;
  bool ok = true;
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = 1e-10, opt.atol = 1e-12;
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
    const auto r = eom::integrate<Arm>(t, (k + 1) * 1e-3, x, tau, p.data(), opt);
    ok = ok && r.status == eom::Status::ok;
    x = r.x;
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
// cart-pole, with a re-linearization every sample as a gain-scheduled controller would do; the
// plant by eom::integrate (DOP853, the force held) as in examples/lqr_cartpole, and by RK4
// steps.
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

  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = 1e-10, opt.atol = 1e-12;
  for (const bool by_integrate : {true, false}) {
    eom::StateOf<2> x{0.2, 0.1, 0, 0};
    bool ok = true;
    before = allocations.load();
    for (long k = 0; k < 1000; ++k) {
      double u[1];
      regulator.control(x.data(), u);
      ok = ok && lqr::linearize<Plant>(x.data(), x.data() + 2, u, p.data(), lin);
      if (by_integrate) {
        const auto r = eom::integrate<Plant>(k * 0.01, (k + 1) * 0.01, x, u, p.data(), opt);
        ok = ok && r.status == eom::Status::ok;
        x = r.x;
      } else {
        for (int s = 0; s < 10; ++s)
          ok = ok && eom::rk4_step<Plant>(k * 0.01 + s * 1e-3, 1e-3, x, u, p.data());
      }
    }
    EXPECT_EQ(allocations.load() - before, 0) << "in the loop, by_integrate " << by_integrate;
    EXPECT_TRUE(ok);
    for (double v : x) EXPECT_LT(std::abs(v), 1e-3);  // stabilized after 10 s
  }
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

// DOP853 and Radau5 over the generated kernels, with dense output (their continuous
// extensions), and on a constrained model with projection.
TEST(NoAllocation, Dop853AndRadau5) {
  const auto none = [](auto&&...) {};
  const std::array<double, 5> times{0.1, 0.25, 0.5, 0.75, 1.0};
  eom::AdaptiveOptions dense;
  dense.output_times = times;
  long outputs = 0;
  const auto count = [&](double, const auto&) { ++outputs; };
  const auto pd = double_pendulum::parameter_values;
  const eom::StateOf<2> xd{2.0, 2.5, 0, 0};
  const auto pc = closed_chain5::parameter_values;
  eom::StateOf<5> xc{};
  for (int i = 0; i < 5; ++i) xc[i] = eom::models::ClosedChain5::initial_q[i];
  eom::Stabilization projection;
  projection.method = eom::Stabilization::Method::projection;

  const long before = allocations.load();
  const auto dop = eom::dop853<double_pendulum::Kernels>(0, 1, xd, nullptr, pd.data(), {}, none);
  const auto dop_dense =
      eom::dop853<double_pendulum::Kernels>(0, 1, xd, nullptr, pd.data(), dense, count);
  const auto dop_projected = eom::dop853<closed_chain5::Kernels>(0, 0.5, xc, nullptr, pc.data(),
                                                                 {}, none, projection);
  const auto radau = eom::radau5<double_pendulum::Kernels>(0, 1, xd, nullptr, pd.data(), {}, none);
  const auto radau_dense =
      eom::radau5<double_pendulum::Kernels>(0, 1, xd, nullptr, pd.data(), dense, count);
  const auto radau_projected = eom::radau5<closed_chain5::Kernels>(0, 0.5, xc, nullptr, pc.data(),
                                                                   {}, none, projection);
  EXPECT_EQ(allocations.load() - before, 0);

  for (const auto* r : {&dop, &dop_dense, &radau, &radau_dense}) {
    EXPECT_EQ(r->status, eom::Status::ok);
    EXPECT_GT(r->accepted, 10);  // they stepped (the chaotic pendulum needs many steps)
  }
  EXPECT_EQ(dop_projected.status, eom::Status::ok);
  EXPECT_EQ(radau_projected.status, eom::Status::ok);
  EXPECT_EQ(outputs, 2 * static_cast<long>(times.size()));
  // Both at rtol 1e-8 over 1 s: the end states agree to about the tolerance (1e-6 leaves room
  // for the growth of errors on the chaotic pendulum).
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(dop.x[i], radau.x[i], 1e-6) << i;
}

// The Taylor integrator allocates the kernel's workspace once per call unless the caller gives
// it one: with TaylorOptions::workspace (a static array of taylor_workspace_capacity doubles) it
// allocates nothing, for either scheme and for taylor_fixed; without, exactly one allocation per
// call, however many steps it takes (so its stepping loop does not allocate).
TEST(NoAllocation, TaylorWithCallersWorkspace) {
  using K = chain10::Kernels;
  static_assert(K::taylor_workspace > 0, "the test needs a kernel that uses a workspace");
  static std::array<double, eom::taylor_workspace_capacity<K>> workspace;
  const auto none = [](auto&&...) {};
  const auto p = chain10::parameter_values;
  eom::StateOf<10> x0{};
  for (int i = 0; i < 10; ++i) x0[i] = 0.1 * (i + 1);
  eom::AdaptiveOptions opt;
  eom::TaylorOptions jorba_zou, paper{eom::TaylorOptions::Scheme::paper, 0};
  jorba_zou.workspace = workspace;
  paper.workspace = workspace;

  long before = allocations.load();
  const auto short_run = eom::taylor<K>(0, 0.05, x0, nullptr, p.data(), opt, jorba_zou, none);
  const auto long_run = eom::taylor<K>(0, 0.5, x0, nullptr, p.data(), opt, jorba_zou, none);
  const auto paper_run = eom::taylor<K>(0, 0.2, x0, nullptr, p.data(), opt, paper, none);
  const auto fixed = eom::taylor_fixed<K>(0, 0.2, 50, 8, x0, nullptr, p.data(), none, {},
                                          std::span<double>(workspace));
  EXPECT_EQ(allocations.load() - before, 0) << "with the caller's workspace";
  for (const auto* r : {&short_run, &long_run, &paper_run, &fixed})
    EXPECT_EQ(r->status, eom::Status::ok);
  EXPECT_GT(long_run.accepted, 3 * short_run.accepted);  // more steps: the loop ran

  // Without a workspace: one allocation per call, the same for a run 10× as long.
  jorba_zou.workspace = {};
  before = allocations.load();
  const auto short_own = eom::taylor<K>(0, 0.05, x0, nullptr, p.data(), opt, jorba_zou, none);
  const long short_count = allocations.load() - before;
  before = allocations.load();
  const auto long_own = eom::taylor<K>(0, 0.5, x0, nullptr, p.data(), opt, jorba_zou, none);
  const long long_count = allocations.load() - before;
  EXPECT_EQ(short_count, 1);
  EXPECT_EQ(long_count, 1);
  EXPECT_EQ(long_own.accepted, long_run.accepted);
  // The workspace does not change the arithmetic: identical results.
  EXPECT_EQ(long_own.x, long_run.x);
  EXPECT_EQ(short_own.x, short_run.x);

  // Too small a workspace is refused before any evaluation.
  const std::size_t needed = eom::taylor_workspace_size<K>(opt, jorba_zou);
  jorba_zou.workspace = std::span<double>(workspace).first(needed - 1);
  const auto refused = eom::taylor<K>(0, 0.05, x0, nullptr, p.data(), opt, jorba_zou, none);
  EXPECT_EQ(refused.status, eom::Status::invalid_argument);
  EXPECT_EQ(refused.evaluations, 0);
}

// eom::integrate, every method, over generated kernels (with every kernel, so no method is
// unavailable), with and without dense output; the Taylor methods with a workspace of the
// caller's through IntegrationOptions::taylor_workspace.
TEST(NoAllocation, IntegrateEveryMethod) {
  using K = double_pendulum::Kernels;
  static std::array<double, eom::taylor_workspace_capacity<K>> workspace;
  const auto p = double_pendulum::parameter_values;
  const eom::StateOf<2> x0{0.5, -0.3, 0, 0};  // a regular (not chaotic) swing
  const std::array<double, 3> times{0.25, 0.5, 1.0};
  constexpr std::array methods{eom::Method::rk4,         eom::Method::dopri5,
                               eom::Method::dop853,      eom::Method::radau5,
                               eom::Method::taylor,      eom::Method::taylor_paper,
                               eom::Method::variational};
  // The end state at t = 1 by DOP853 at rtol 1e-12, to check each run did its job.
  eom::IntegrationOptions exact;
  exact.method = eom::Method::dop853;
  exact.rtol = 1e-12, exact.atol = 1e-14;
  const auto reference = eom::integrate<K>(0, 1, x0, nullptr, p.data(), exact);
  ASSERT_EQ(reference.status, eom::Status::ok);

  for (const eom::Method method : methods)
    for (const bool with_dense : {false, true}) {
      eom::IntegrationOptions opt;
      opt.method = method;
      opt.step = eom::is_fixed_step(method) ? 1e-3 : 0;
      opt.taylor_workspace = workspace;
      if (with_dense) opt.output_times = times;
      eom::StateOf<2> last{};
      long outputs = 0;
      const long before = allocations.load();
      const auto observer = [&](double, const eom::StateOf<2>& x) { last = x, ++outputs; };
      const auto r = eom::integrate<K>(0, 1, x0, nullptr, p.data(), opt, observer);
      EXPECT_EQ(allocations.load() - before, 0)
          << eom::to_string(method) << ", dense output " << with_dense;
      EXPECT_EQ(r.status, eom::Status::ok) << eom::to_string(method);
      if (with_dense) {
        EXPECT_EQ(outputs, static_cast<long>(times.size()));
      }
      // The run did its job: rtol 1e-8 (adaptive methods; measured ≤ 2.1e-7 from the reference)
      // and RK4 at h = 1 ms (4.6e-11) within 1e-6; the 2nd-order variational method at h = 1 ms
      // (error O(h²) = 1e-6 times the solution's third derivatives; measured 5.3e-6) within 5e-5.
      const double bound = method == eom::Method::variational ? 5e-5 : 1e-6;
      for (int i = 0; i < 4; ++i) {
        EXPECT_NEAR(r.x[i], reference.x[i], bound) << eom::to_string(method) << " " << i;
        EXPECT_EQ(last[i], r.x[i]) << "the observer saw the end state";
      }
    }
}

// eom::integrate with events (record, reset, terminate), every method: nothing allocated either.
TEST(NoAllocation, IntegrateWithEventsEveryMethod) {
  using K = double_pendulum::Kernels;
  static std::array<double, eom::taylor_workspace_capacity<K>> workspace;
  const auto p = double_pendulum::parameter_values;
  const eom::StateOf<2> x0{0.5, -0.3, 0, 0};
  auto first = [](double, const double* q, const double*) { return q[0]; };
  auto second = [](double, const double* q, const double*) { return q[1] - 0.2; };
  auto kick = [](double, double*, double* qd) {
    qd[1] *= -1;
    return true;
  };
  const eom::Event events[]{{.g = first},
                            {.g = second, .direction = eom::EventDirection::rising,
                             .action = eom::EventAction::reset, .reset = kick}};
  std::array<eom::EventRecord<2>, 16> storage;
  for (const eom::Method method : {eom::Method::rk4, eom::Method::dopri5, eom::Method::dop853,
                                   eom::Method::radau5, eom::Method::taylor,
                                   eom::Method::taylor_paper, eom::Method::variational}) {
    eom::IntegrationOptions opt;
    opt.method = method;
    opt.step = eom::is_fixed_step(method) ? 1e-3 : 0;
    opt.taylor_workspace = workspace;
    eom::EventLog<2> log(storage);
    const long before = allocations.load();
    const auto r = eom::integrate<K>(0, 2, x0, nullptr, p.data(), opt, events, log);
    EXPECT_EQ(allocations.load() - before, 0) << eom::to_string(method);
    EXPECT_EQ(r.status, eom::Status::ok) << eom::to_string(method);
    EXPECT_GT(log.size(), 1u) << eom::to_string(method);
  }
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
