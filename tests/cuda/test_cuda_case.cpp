// eom/ensemble/cuda/case.hpp, the per-case code a GPU thread runs (eom::cuda::ensemble), compiled by the
// host compiler: bit for bit eom::ensemble's results (status, time, state, step and evaluation
// counts, every sample) for RK4 and dopri5, with shared and per-case parameters (the parameter
// cache prepared once or per case), held inputs, sample times, failing cases, a constrained model
// and a free joint. Compiled with -ffp-contract=off (both sides are in this file; the kernels they
// call are the same library).
#include <gtest/gtest.h>

#include <bit>
#include <chain10.hpp>
#include <closed_chain5.hpp>
#include <cmath>
#include <cstdint>
#include <cuda_branched.hpp>
#include <double_pendulum.hpp>
#include <limits>
#include <models/chain.hpp>
#include <models/spacecraft_free.hpp>
#include <spacecraft_free.hpp>
#include <vector>

#include "case_runner.hpp"

namespace {

template <std::size_t m> bool same_bits(const std::array<double, m>& a, const std::array<double, m>& b) {
  for (std::size_t i = 0; i < m; ++i)
    if (std::bit_cast<std::uint64_t>(a[i]) != std::bit_cast<std::uint64_t>(b[i])) return false;
  return true;
}

// Every case and sample of the host run of the GPU code against eom::ensemble; returns how many
// cases ended with each status (ok first), for the tests to check what they exercised.
template <eom::Dynamics K>
std::vector<int> expect_bitwise(const eom::EnsembleCasesFor<K>& cases, const eom::EnsembleOptions& opt) {
  const auto cpu = eom::ensemble<K>(cases, opt);
  const auto gpu_code = eom_cuda_test::host_cases<K>(cases, opt);
  EXPECT_EQ(cpu.status, eom::Status::ok);
  std::vector<int> statuses(16, 0);
  for (std::size_t c = 0; c < cases.x0.size(); ++c) {
    const auto& a = gpu_code.cases[c];
    const auto& b = cpu.cases[c];
    ++statuses[static_cast<int>(b.status)];
    EXPECT_EQ(a.status, b.status) << "case " << c;
    EXPECT_EQ(std::bit_cast<std::uint64_t>(a.t), std::bit_cast<std::uint64_t>(b.t)) << "case " << c;
    EXPECT_TRUE(same_bits(a.x, b.x)) << "case " << c;
    EXPECT_EQ(a.accepted, b.accepted) << "case " << c;
    EXPECT_EQ(a.rejected, b.rejected) << "case " << c;
    EXPECT_EQ(a.evaluations, b.evaluations) << "case " << c;
    for (std::size_t k = 0; k < cpu.sample_count; ++k)
      EXPECT_TRUE(same_bits(gpu_code.sample(c, k), cpu.sample(c, k))) << "case " << c << ", sample " << k;
  }
  return statuses;
}

eom::EnsembleOptions options(eom::Method method, double t1, std::span<const double> times) {
  eom::EnsembleOptions opt;
  opt.t0 = 0, opt.t1 = t1;
  opt.integration.method = method;
  opt.integration.step = method == eom::Method::rk4 ? 1e-3 : 0.0;
  opt.sample_times = times;
  opt.threads = 2;
  return opt;
}

// The deployment (tests/ensemble's: release rate and masses differ per case) and, from 6 cases
// on, two that fail: NaN in the state (refused) and a chain without mass (singular).
struct Deployment {
  using K = chain10::Kernels;
  std::vector<eom::StateOf<10>> x0;
  std::vector<double> p;
  explicit Deployment(std::size_t n) : x0(n), p(n * K::np) {
    for (std::size_t c = 0; c < n; ++c) {
      auto& x = x0[c];
      for (int i = 0; i < 10; ++i) x[i] = i % 2 == 0 ? -0.08726646259971647 : 3.2288591161895095;
      x[10] = -0.05 - 0.01 * static_cast<double>(c % 7);
      double* pc = p.data() + c * K::np;
      for (int i = 0; i < K::np; ++i) pc[i] = K::parameter_values[i];
      for (int i = 0; i < 10; ++i) pc[i] *= 1.0 + 0.05 * static_cast<double>((c + i) % 5);
    }
    if (n < 6) return;
    x0[3][12] = std::numeric_limits<double>::quiet_NaN();
    for (int i = 0; i < 10; ++i) p[5 * K::np + i] = 0.0, p[5 * K::np + 20 + i] = 0.0;
  }
  eom::EnsembleCases<10> cases() const { return {x0, p, {}}; }
};

const std::vector<double> sample_times{0.0, 0.05, 0.1, 0.1, 0.2371, 0.4, 0.5};

TEST(CudaCase, Rk4MatchesTheEnsembleBitwise) {
  const Deployment d(24);
  const auto opt = options(eom::Method::rk4, 0.5, sample_times);
  const auto statuses = expect_bitwise<chain10::Kernels>(d.cases(), opt);
  EXPECT_EQ(statuses[static_cast<int>(eom::Status::ok)], 22);
  EXPECT_EQ(statuses[static_cast<int>(eom::Status::invalid_argument)], 1);
  EXPECT_EQ(statuses[static_cast<int>(eom::Status::singular_dynamics)], 1);
}

TEST(CudaCase, Rk4WithoutSamplesAndWithAStepThatDoesNotDivideTheSpan) {
  const Deployment d(9);
  auto opt = options(eom::Method::rk4, 0.3, {});
  opt.integration.step = 7e-4;
  expect_bitwise<chain10::Kernels>(d.cases(), opt);
  opt.batch = false;
  expect_bitwise<chain10::Kernels>(d.cases(), opt);
}

TEST(CudaCase, Dopri5MatchesTheEnsembleBitwise) {
  const Deployment d(24);
  auto opt = options(eom::Method::dopri5, 0.5, sample_times);
  const auto statuses = expect_bitwise<chain10::Kernels>(d.cases(), opt);
  EXPECT_EQ(statuses[static_cast<int>(eom::Status::ok)], 22);
  opt.integration.rtol = 1e-11, opt.integration.atol = 1e-12;  // more steps, rejections
  expect_bitwise<chain10::Kernels>(d.cases(), opt);
  opt.integration.step = 1e-3;  // a given initial step
  expect_bitwise<chain10::Kernels>(d.cases(), opt);
}

TEST(CudaCase, StepLimitsAndUnderflowMatch) {
  const Deployment d(6);
  auto opt = options(eom::Method::dopri5, 0.5, sample_times);
  opt.integration.max_steps = 7;
  EXPECT_EQ(expect_bitwise<chain10::Kernels>(d.cases(), opt)[static_cast<int>(eom::Status::step_limit)], 4);
  opt = options(eom::Method::rk4, 0.5, sample_times);
  opt.integration.max_steps = 100;  // 500 steps needed: refused up front (the massless case too)
  EXPECT_EQ(expect_bitwise<chain10::Kernels>(d.cases(), opt)[static_cast<int>(eom::Status::step_limit)], 5);
}

TEST(CudaCase, SharedParametersUseTheCachePreparedOnce) {
  static_assert(eom::cuda::parameter_cache_of<chain10::Kernels> > 0);
  Deployment d(8);
  const std::vector<double> p(chain10::parameter_values.begin(), chain10::parameter_values.end());
  const eom::EnsembleCases<10> cases{d.x0, p, {}};
  expect_bitwise<chain10::Kernels>(cases, options(eom::Method::rk4, 0.5, sample_times));
  expect_bitwise<chain10::Kernels>(cases, options(eom::Method::dopri5, 0.5, sample_times));
}

TEST(CudaCase, HeldInputsPerCaseAndShared) {
  using K = cuda_branched::Kernels;
  static_assert(K::nu > 0);
  constexpr int m = K::nq + eom::nv_of<K>;
  std::vector<eom::StateFor<K>> x0(10);
  std::vector<double> u(x0.size() * K::nu);
  for (std::size_t c = 0; c < x0.size(); ++c) {
    for (int i = 0; i < m; ++i) x0[c][i] = 0.1 * std::sin(1.0 + static_cast<double>(c * m + i));
    for (int j = 0; j < K::nu; ++j) u[c * K::nu + j] = 0.5 * std::cos(static_cast<double>(c + 3 * j));
  }
  const std::vector<double> p(K::parameter_values.begin(), K::parameter_values.end());
  const std::vector<double> u_shared(u.begin(), u.begin() + K::nu);
  for (const auto method : {eom::Method::rk4, eom::Method::dopri5}) {
    expect_bitwise<K>({x0, p, u}, options(method, 0.5, sample_times));
    expect_bitwise<K>({x0, p, u_shared}, options(method, 0.5, sample_times));
  }
}

TEST(CudaCase, ConstrainedModelAndItsStartCheck) {
  using K = closed_chain5::Kernels;
  std::vector<eom::StateOf<5>> x0(5);
  for (auto& x : x0)
    for (int i = 0; i < 5; ++i) x[i] = eom::models::ClosedChain5::initial_q[i];
  x0[2][0] += 1e-3;  // off the constraints: refused
  const std::vector<double> p(K::parameter_values.begin(), K::parameter_values.end());
  for (const auto method : {eom::Method::rk4, eom::Method::dopri5}) {
    const auto statuses = expect_bitwise<K>({x0, p, {}}, options(method, 0.5, sample_times));
    EXPECT_EQ(statuses[static_cast<int>(eom::Status::inconsistent_initial_state)], 1);
  }
}

TEST(CudaCase, FreeJoint) {
  using K = spacecraft_free::Kernels;
  static_assert(eom::nv_of<K> + 1 == K::nq);
  std::vector<eom::StateFor<K>> x0(5);
  for (std::size_t c = 0; c < x0.size(); ++c) {
    auto& x = x0[c];
    x.fill(0.0);
    for (int i = 0; i < K::nq; ++i) x[i] = eom::models::SpacecraftFree::initial_q[i];
    x[K::nq + 3] = 0.02 * static_cast<double>(c);  // hub rates
    x[K::nq + 5] = -0.01;
    x[K::nq + 6] = 0.3;  // the first hinge's release rate
  }
  x0[1][4] = 1e-3;  // a quaternion of norm 1 + 5e-7: normalized at the start
  x0[4][3] = 1.01;  // off the unit sphere: refused
  const std::vector<double> p(K::parameter_values.begin(), K::parameter_values.end());
  for (const auto method : {eom::Method::rk4, eom::Method::dopri5}) {
    const auto statuses = expect_bitwise<K>({x0, p, {}}, options(method, 0.5, sample_times));
    EXPECT_EQ(statuses[static_cast<int>(eom::Status::invalid_argument)], 1);
  }
}

TEST(CudaCase, SmallModelWithoutParameterCache) {
  using K = double_pendulum::Kernels;
  std::vector<eom::StateFor<K>> x0(4);
  for (std::size_t c = 0; c < x0.size(); ++c) x0[c] = {1.0 + 0.1 * static_cast<double>(c), -0.5, 0.0, 0.3};
  const std::vector<double> p(K::parameter_values.begin(), K::parameter_values.end());
  for (const auto method : {eom::Method::rk4, eom::Method::dopri5})
    expect_bitwise<K>({x0, p, {}}, options(method, 1.0, sample_times));
}

}  // namespace
