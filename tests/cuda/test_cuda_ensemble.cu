// eom::cuda::ensemble (runtime/include/eom/ensemble/cuda/ensemble.hpp). Without a GPU at run time: the
// Status and Error it reports, nothing integrated. With one: the GPU's results against
// eom::ensemble's on the CPU (same cases, same kernels' host code), failing cases reported alike,
// chunks that change nothing, options the GPU lacks refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cuda_runtime.h>
#include <gpu_chain10.hpp>
#include <gpu_free.hpp>
#include <limits>
#include <models/spacecraft_free.hpp>
#include <vector>

#include <eom/ensemble/cuda/ensemble.hpp>

namespace {

using Chain = gpu_chain10::Kernels;

bool have_gpu() {
  int n = 0;
  const bool ok = cudaGetDeviceCount(&n) == cudaSuccess && n > 0;
  cudaGetLastError();
  return ok;
}

// The deployment (tests/ensemble's cases) and, from 6 cases on, a case with NaN (refused) and one
// without mass (singular dynamics).
struct Deployment {
  std::vector<eom::StateOf<10>> x0;
  std::vector<double> p;
  explicit Deployment(std::size_t n) : x0(n), p(n * Chain::np) {
    for (std::size_t c = 0; c < n; ++c) {
      auto& x = x0[c];
      for (int i = 0; i < 10; ++i) x[i] = i % 2 == 0 ? -0.08726646259971647 : 3.2288591161895095;
      x[10] = -0.05 - 0.01 * static_cast<double>(c % 7);
      double* pc = p.data() + c * Chain::np;
      for (int i = 0; i < Chain::np; ++i) pc[i] = Chain::parameter_values[i];
      for (int i = 0; i < 10; ++i) pc[i] *= 1.0 + 0.05 * static_cast<double>((c + i) % 5);
    }
    if (n < 6) return;
    x0[3][12] = std::numeric_limits<double>::quiet_NaN();
    for (int i = 0; i < 10; ++i) p[5 * Chain::np + i] = 0.0, p[5 * Chain::np + 20 + i] = 0.0;
  }
  eom::EnsembleCases<10> cases() const { return {x0, p, {}}; }
};

const std::vector<double> times{0.0, 0.05, 0.1, 0.2371, 0.4, 0.5};

eom::EnsembleOptions options(eom::Method method) {
  eom::EnsembleOptions opt;
  opt.t0 = 0, opt.t1 = 0.5;
  opt.integration.method = method;
  opt.integration.step = method == eom::Method::rk4 ? 1e-3 : 0.0;
  opt.sample_times = times;
  opt.threads = 0;
  return opt;
}

// max over states of ‖a − b‖∞ / ‖b‖∞ (finite states only; NaN must match NaN).
template <std::size_t m> double relative(const std::array<double, m>& a, const std::array<double, m>& b) {
  double d = 0, s = 0;
  for (std::size_t i = 0; i < m; ++i) {
    if (std::isnan(a[i]) != std::isnan(b[i])) return std::numeric_limits<double>::infinity();
    if (std::isnan(b[i])) continue;
    d = std::max(d, std::abs(a[i] - b[i]));
    s = std::max(s, std::abs(b[i]));
  }
  return s > 0 ? d / s : d;
}

template <class K>
double compare(const eom::cuda::EnsembleResultFor<K>& gpu, const eom::EnsembleResultFor<K>& cpu) {
  EXPECT_EQ(gpu.status, eom::Status::ok) << gpu.message;
  EXPECT_EQ(gpu.cases.size(), cpu.cases.size());
  double worst = 0;
  for (std::size_t c = 0; c < cpu.cases.size() && c < gpu.cases.size(); ++c) {
    EXPECT_EQ(gpu.cases[c].status, cpu.cases[c].status) << "case " << c;
    EXPECT_EQ(gpu.cases[c].t, cpu.cases[c].t) << "case " << c;
    worst = std::max(worst, relative(gpu.cases[c].x, cpu.cases[c].x));
    for (std::size_t k = 0; k < cpu.sample_count; ++k) worst = std::max(worst, relative(gpu.sample(c, k), cpu.sample(c, k)));
  }
  return worst;
}

TEST(CudaEnsemble, WithoutAGpuNothingRuns) {
  if (have_gpu()) GTEST_SKIP() << "a GPU is present";
  const Deployment d(10);
  const auto r = eom::cuda::ensemble<Chain>(d.cases(), options(eom::Method::rk4));
  EXPECT_EQ(r.status, eom::Status::method_unavailable);
  EXPECT_EQ(r.error, eom::cuda::Error::no_device);
  EXPECT_FALSE(r.message.empty());
  ASSERT_EQ(r.cases.size(), 10u);
  for (const auto& c : r.cases) EXPECT_EQ(c.status, eom::Status::method_unavailable);
  for (const auto& s : r.samples) EXPECT_TRUE(std::isnan(s[0]));
}

TEST(CudaEnsemble, BadInputAndUnsupportedOptionsAreRefusedBeforeTheDevice) {
  const Deployment d(4);
  auto opt = options(eom::Method::rk4);
  opt.integration.output_times = times;  // belongs in sample_times
  EXPECT_EQ(eom::cuda::ensemble<Chain>(d.cases(), opt).status, eom::Status::invalid_argument);
  opt = options(eom::Method::dop853);
  const auto r = eom::cuda::ensemble<Chain>(d.cases(), opt);
  EXPECT_EQ(r.status, eom::Status::method_unavailable);
  EXPECT_EQ(r.error, eom::cuda::Error::unsupported);
}

TEST(CudaEnsemble, MatchesTheCpu) {
  if (!have_gpu()) GTEST_SKIP() << "no GPU";
  const Deployment d(1000);
  for (const auto method : {eom::Method::rk4, eom::Method::dopri5}) {
    const auto opt = options(method);
    const auto gpu = eom::cuda::ensemble<Chain>(d.cases(), opt);
    const auto cpu = eom::ensemble<Chain>(d.cases(), opt);
    const double worst = compare<Chain>(gpu, cpu);
    EXPECT_LE(worst, 1e-10) << eom::to_string(method);
    EXPECT_EQ(gpu.cases[3].status, eom::Status::invalid_argument);
    EXPECT_EQ(gpu.cases[5].status, eom::Status::singular_dynamics);
    std::printf("%s on %s: max relative difference %.3g\n", eom::to_string(method), gpu.device.c_str(), worst);
  }
}

TEST(CudaEnsemble, ChunksChangeNothing) {
  if (!have_gpu()) GTEST_SKIP() << "no GPU";
  const Deployment d(700);
  const auto opt = options(eom::Method::dopri5);
  const auto whole = eom::cuda::ensemble<Chain>(d.cases(), opt);
  eom::cuda::DeviceOptions small;
  small.max_chunk = 64;
  small.block = 32;
  const auto chunked = eom::cuda::ensemble<Chain>(d.cases(), opt, small);
  EXPECT_EQ(whole.chunks, 1u);
  EXPECT_EQ(chunked.chunks, 11u);
  for (std::size_t c = 0; c < d.x0.size(); ++c) {
    EXPECT_EQ(whole.cases[c].status, chunked.cases[c].status);
    EXPECT_EQ(whole.cases[c].evaluations, chunked.cases[c].evaluations);
    for (int i = 0; i < 20; ++i) {
      const double a = whole.cases[c].x[i], b = chunked.cases[c].x[i];
      EXPECT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << "case " << c;
    }
  }
}

TEST(CudaEnsemble, SharedParametersAndAFreeJoint) {
  if (!have_gpu()) GTEST_SKIP() << "no GPU";
  const Deployment d(300);
  const std::vector<double> p(Chain::parameter_values.begin(), Chain::parameter_values.end());
  const eom::EnsembleCases<10> shared{d.x0, p, {}};
  for (const auto method : {eom::Method::rk4, eom::Method::dopri5}) {
    const auto opt = options(method);
    EXPECT_LE(compare<Chain>(eom::cuda::ensemble<Chain>(shared, opt), eom::ensemble<Chain>(shared, opt)), 1e-10);
  }
  using Free = gpu_free::Kernels;
  std::vector<eom::StateFor<Free>> x0(200);
  for (std::size_t c = 0; c < x0.size(); ++c) {
    auto& x = x0[c];
    x.fill(0.0);
    for (int i = 0; i < Free::nq; ++i) x[i] = eom::models::SpacecraftFree::initial_q[i];
    x[Free::nq + 3] = 0.001 * static_cast<double>(c);
    x[Free::nq + 6] = 0.3;
  }
  x0[7][3] = 2.0;  // not a unit quaternion: refused
  const std::vector<double> pf(Free::parameter_values.begin(), Free::parameter_values.end());
  for (const auto method : {eom::Method::rk4, eom::Method::dopri5}) {
    const auto opt = options(method);
    const auto gpu = eom::cuda::ensemble<Free>({x0, pf, {}}, opt);
    EXPECT_LE(compare<Free>(gpu, eom::ensemble<Free>({x0, pf, {}}, opt)), 1e-10);
    EXPECT_EQ(gpu.cases[7].status, eom::Status::invalid_argument);
  }
}

}  // namespace
