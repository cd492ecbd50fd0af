// The GPU check scripts/gpu_check.sh runs (docs/benchmarks/gpu.md): on the machine's NVIDIA GPU
// and all its CPU cores, in one process,
//   1. the device and the build;
//   2. forward_dynamics on the GPU against the host at 10^5 random states (chain10, the Panda);
//   3. eom::cuda::ensemble against eom::ensemble on the same cases: chain10's deployment (RK4 at
//      h = 1 ms, dopri5 at rtol = atol = 1e-8, 2 s, sampled every 0.1 s, with a refused and a
//      singular case) and the Panda's damped free fall from random states (2 s): statuses, the
//      largest relative difference of final states and of samples (‖a − b‖∞ / ‖b‖∞ per state);
//      chunked launches against one launch (bitwise);
//   4. throughput, 1k to 1M cases: cases/s on the GPU (the whole call: transposition, transfers,
//      kernel; and the kernel alone) and on the CPU (eom::ensemble on every hardware thread, with
//      batch lanes where the model has them), and their ratio.
// chain10 runs twice: each case its own parameters (the deployment's masses), and all cases the
// nominal ones (each thread then reads one parameter cache prepared on the host).
// Options: --quick (sizes to 16k, fewer CPU cases), --max-cases N, --cpu-cases N, --sizes N,M,...
// --throughput-only (no kernel check, no CPU runs), --markdown FILE (the tables, also printed).
#include <cuda_runtime.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <gpu_chain10.hpp>
#include <gpu_panda.hpp>

#include <eom/ensemble/cuda/ensemble.hpp>
#include <eom/ensemble/ensemble.hpp>

namespace {

using Chain = gpu_chain10::Kernels;
using Panda = gpu_panda::Kernels;
using Clock = std::chrono::steady_clock;

std::string markdown;
void emit(const char* format, ...) __attribute__((format(printf, 1, 2)));
void emit(const char* format, ...) {
  char line[1024];
  va_list args;
  va_start(args, format);
  std::vsnprintf(line, sizeof line, format, args);
  va_end(args);
  std::fputs(line, stdout);
  std::fflush(stdout);
  markdown += line;
}

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

template <class K> struct Cases {
  std::vector<eom::StateFor<K>> x0;
  std::vector<double> p, u;
  eom::EnsembleCasesFor<K> view() const { return {x0, p, u}; }
};

// chain10's deployment (tests/ensemble's cases: release rate and masses per case, or with shared,
// the nominal parameters for all); case 3 has a NaN (refused), case 5 no mass (singular), when
// failing and there are that many.
Cases<Chain> deployment(std::size_t n, bool failing, bool shared = false) {
  Cases<Chain> d;
  d.x0.resize(n);
  d.p.resize(n * Chain::np);
  for (std::size_t c = 0; c < n; ++c) {
    auto& x = d.x0[c];
    for (int i = 0; i < 10; ++i) x[i] = i % 2 == 0 ? -0.08726646259971647 : 3.2288591161895095;
    x[10] = -0.05 - 0.01 * static_cast<double>(c % 7);
    double* p = d.p.data() + c * Chain::np;
    for (int i = 0; i < Chain::np; ++i) p[i] = Chain::parameter_values[i];
    for (int i = 0; i < 10; ++i) p[i] *= 1.0 + 0.05 * static_cast<double>((c + i) % 5);
  }
  if (failing && n > 5) {
    d.x0[3][12] = std::numeric_limits<double>::quiet_NaN();
    for (int i = 0; i < 10; ++i) d.p[5 * Chain::np + i] = 0.0, d.p[5 * Chain::np + 20 + i] = 0.0;
  }
  if (shared) d.p.assign(Chain::parameter_values.begin(), Chain::parameter_values.end());
  return d;
}

// The Panda falling limp (u = 0, its joints' damping) from random states: q uniform in ±1 rad
// about zero, v in ±0.5 rad/s, from a fixed seed; the file's parameters for all.
Cases<Panda> panda_fall(std::size_t n) {
  Cases<Panda> d;
  d.x0.resize(n);
  std::mt19937_64 rng(20261127);
  const auto uniform = [&rng](double a) { return a * (std::ldexp(static_cast<double>(rng() >> 11), -52) - 1.0); };
  for (auto& x : d.x0) {
    for (int i = 0; i < Panda::nq; ++i) x[i] = uniform(1.0);
    for (int i = 0; i < Panda::nq; ++i) x[Panda::nq + i] = uniform(0.5);
  }
  d.p.assign(Panda::parameter_values.begin(), Panda::parameter_values.end());
  d.u.assign(Panda::nu, 0.0);
  return d;
}

eom::EnsembleOptions options(eom::Method method, std::span<const double> times) {
  eom::EnsembleOptions opt;
  opt.t0 = 0, opt.t1 = 2.0;
  opt.integration.method = method;
  if (method == eom::Method::rk4)
    opt.integration.step = 1e-3;
  else
    opt.integration.rtol = opt.integration.atol = 1e-8;
  opt.sample_times = times;
  opt.threads = 0;  // every hardware thread
  return opt;
}

// ‖a − b‖∞ / ‖b‖∞ (NaN where only one is NaN: reported as infinite).
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

// ---- 2. the kernel at random states ----

template <class K>
__global__ void forward_dynamics_kernel(std::size_t n, const double* q, const double* v, const double* u,
                                        const double* p, const double* pc, double* qdd, int* ok) {
  const std::size_t c = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (c >= n) return;
  constexpr int nq = K::nq;
  double qc[nq], vc[nq], a[nq];
  for (int i = 0; i < nq; ++i) qc[i] = q[i * n + c], vc[i] = v[i * n + c];
  bool good;
  if constexpr (eom::cuda::parameter_cache_of<K> > 0)
    good = K::forward_dynamics(0.0, qc, vc, u, p, a, pc);
  else
    good = K::forward_dynamics(0.0, qc, vc, u, p, a);
  for (int i = 0; i < nq; ++i) qdd[i * n + c] = a[i];
  ok[c] = good;
}

template <class K> void kernel_check(const char* name, std::size_t n) {
  constexpr int nq = K::nq;
  std::mt19937_64 rng(42);
  const auto uniform = [&rng](double a) { return a * (std::ldexp(static_cast<double>(rng() >> 11), -52) - 1.0); };
  std::vector<double> q(n * nq), v(n * nq), qdd(n * nq);
  for (auto& x : q) x = uniform(3.0);
  for (auto& x : v) x = uniform(2.0);
  std::vector<double> p(K::parameter_values.begin(), K::parameter_values.end()), u(K::nu > 0 ? K::nu : 1, 0.0);
  std::vector<double> pc(std::max(1, eom::cuda::parameter_cache_of<K>));
  if constexpr (eom::cuda::parameter_cache_of<K> > 0) K::forward_dynamics_prepare(p.data(), pc.data());
  double *dq, *dv, *du, *dp, *dpc, *dqdd;
  int* dok;
  cudaMalloc(&dq, q.size() * 8), cudaMalloc(&dv, v.size() * 8), cudaMalloc(&du, u.size() * 8);
  cudaMalloc(&dp, p.size() * 8 + 8), cudaMalloc(&dpc, pc.size() * 8), cudaMalloc(&dqdd, qdd.size() * 8);
  cudaMalloc(&dok, n * sizeof(int));
  cudaMemcpy(dq, q.data(), q.size() * 8, cudaMemcpyHostToDevice);
  cudaMemcpy(dv, v.data(), v.size() * 8, cudaMemcpyHostToDevice);
  cudaMemcpy(du, u.data(), u.size() * 8, cudaMemcpyHostToDevice);
  cudaMemcpy(dp, p.data(), p.size() * 8, cudaMemcpyHostToDevice);
  cudaMemcpy(dpc, pc.data(), pc.size() * 8, cudaMemcpyHostToDevice);
  forward_dynamics_kernel<K><<<static_cast<unsigned>((n + 127) / 128), 128>>>(n, dq, dv, du, dp, dpc, dqdd, dok);
  const cudaError_t e = cudaDeviceSynchronize();
  std::vector<int> ok(n);
  cudaMemcpy(qdd.data(), dqdd, qdd.size() * 8, cudaMemcpyDeviceToHost);
  cudaMemcpy(ok.data(), dok, n * sizeof(int), cudaMemcpyDeviceToHost);
  cudaFree(dq), cudaFree(dv), cudaFree(du), cudaFree(dp), cudaFree(dpc), cudaFree(dqdd), cudaFree(dok);
  double worst = 0, worst_elementwise = 0;
  std::size_t disagree = 0;
  for (std::size_t c = 0; c < n; ++c) {
    double qc[nq], vc[nq], a[nq], d = 0, s = 0;
    for (int i = 0; i < nq; ++i) qc[i] = q[i * n + c], vc[i] = v[i * n + c];
    const bool good = K::forward_dynamics(0.0, qc, vc, u.data(), p.data(), a);
    if (good != (ok[c] != 0)) {
      ++disagree;
      continue;
    }
    for (int i = 0; i < nq; ++i) {
      const double g = qdd[i * n + c];
      d = std::max(d, std::abs(g - a[i]));
      s = std::max(s, std::abs(a[i]));
      worst_elementwise = std::max(worst_elementwise, std::abs(g - a[i]) / std::max(std::abs(a[i]), 1e-300));
    }
    worst = std::max(worst, s > 0 ? d / s : d);
  }
  emit("| %s | %zu | %.2e | %.2e | %zu | %s |\n", name, n, worst, worst_elementwise, disagree,
       e == cudaSuccess ? "ok" : cudaGetErrorString(e));
}

// ---- 3. agreement ----

struct Timing {
  double cpu_cases_per_second = 0;
};

template <class K>
Timing agreement(const char* name, const Cases<K>& cases, eom::Method method, std::span<const double> times) {
  const auto opt = options(method, times);
  auto t = Clock::now();
  const auto cpu = eom::ensemble<K>(cases.view(), opt);
  const double cpu_seconds = seconds_since(t);
  const auto gpu = eom::cuda::ensemble<K>(cases.view(), opt);
  if (gpu.status != eom::Status::ok) {
    emit("| %s | %s | GPU run failed: %s (%s) | | | | |\n", name, eom::to_string(method), gpu.message.c_str(),
         eom::cuda::to_string(gpu.error));
    return {};
  }
  double final_worst = 0, sample_worst = 0;
  std::size_t mismatched = 0, failed = 0;
  for (std::size_t c = 0; c < cases.x0.size(); ++c) {
    if (gpu.cases[c].status != cpu.cases[c].status) {
      ++mismatched;
      continue;
    }
    if (cpu.cases[c].status != eom::Status::ok) ++failed;
    final_worst = std::max(final_worst, relative(gpu.cases[c].x, cpu.cases[c].x));
    for (std::size_t k = 0; k < cpu.sample_count; ++k)
      sample_worst = std::max(sample_worst, relative(gpu.sample(c, k), cpu.sample(c, k)));
  }
  // The same cases in chunks of a tenth: bitwise the single launch.
  eom::cuda::DeviceOptions chunked;
  chunked.max_chunk = std::max<std::size_t>(1, cases.x0.size() / 10);
  const auto again = eom::cuda::ensemble<K>(cases.view(), opt, chunked);
  bool identical = again.status == eom::Status::ok;
  for (std::size_t c = 0; identical && c < cases.x0.size(); ++c) {
    identical = again.cases[c].status == gpu.cases[c].status && again.cases[c].evaluations == gpu.cases[c].evaluations;
    for (std::size_t i = 0; i < gpu.cases[c].x.size(); ++i)
      identical = identical && std::memcmp(&again.cases[c].x[i], &gpu.cases[c].x[i], sizeof(double)) == 0;
  }
  emit("| %s | %s | %zu | %zu | %zu | %.2e | %.2e | %zu chunks: %s |\n", name, eom::to_string(method),
       cases.x0.size(), failed, mismatched, final_worst, sample_worst, again.chunks,
       identical ? "identical" : "DIFFERENT");
  return {static_cast<double>(cases.x0.size()) / cpu_seconds};
}

// ---- 4. throughput ----

template <class K, class Make>
void throughput(const char* name, eom::Method method, Make&& make, const std::vector<std::size_t>& sizes,
                double cpu_cases_per_second) {
  const auto opt = options(method, {});
  for (std::size_t n : sizes) {
    const auto cases = make(n);
    const auto t = Clock::now();
    const auto r = eom::cuda::ensemble<K>(cases.view(), opt);
    const double wall = seconds_since(t);
    if (r.status != eom::Status::ok) {
      emit("| %s | %s | %zu | failed: %s | | | |\n", name, eom::to_string(method), n, r.message.c_str());
      return;
    }
    const double rate = static_cast<double>(n) / wall;
    if (cpu_cases_per_second > 0)
      emit("| %s | %s | %zu | %.0f | %.0f | %.0f | %.1fx |\n", name, eom::to_string(method), n, rate,
           static_cast<double>(n) / r.kernel_seconds, cpu_cases_per_second, rate / cpu_cases_per_second);
    else
      emit("| %s | %s | %zu | %.0f | %.0f | | |\n", name, eom::to_string(method), n, rate,
           static_cast<double>(n) / r.kernel_seconds);
  }
}

template <class K> void kernel_attributes(const char* name) {
  cudaFuncAttributes a{}, b{};
  if (cudaFuncGetAttributes(&a, eom::cuda::detail::ensemble_kernel<K, eom::cuda::CaseMethod::rk4>) == cudaSuccess &&
      cudaFuncGetAttributes(&b, eom::cuda::detail::ensemble_kernel<K, eom::cuda::CaseMethod::dopri5>) == cudaSuccess)
    emit("- %s's ensemble kernels: RK4 %d registers and %zu bytes of local memory per thread, dopri5 %d and %zu\n",
         name, a.numRegs, a.localSizeBytes, b.numRegs, b.localSizeBytes);
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false, throughput_only = false;
  std::size_t max_cases = std::size_t{1} << 20, cpu_cases = 8192;
  std::vector<std::size_t> sizes;
  const char* markdown_file = nullptr;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") quick = true, max_cases = 16384, cpu_cases = 2048;
    else if (a == "--max-cases" && i + 1 < argc) max_cases = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--cpu-cases" && i + 1 < argc) cpu_cases = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--markdown" && i + 1 < argc) markdown_file = argv[++i];
    else if (a == "--throughput-only") throughput_only = true;
    else if (a == "--sizes" && i + 1 < argc)
      for (char* at = argv[++i]; *at != 0;) {
        sizes.push_back(std::strtoull(at, &at, 10));
        if (*at == ',') ++at;
      }
    else {
      std::fprintf(stderr, "usage: gpu_check [--quick] [--max-cases N] [--cpu-cases N] [--sizes N,M,...] "
                           "[--throughput-only] [--markdown FILE]\n");
      return 2;
    }
  }
  // 1. The device and the build.
  int devices = 0, driver = 0, runtime = 0;
  if (cudaGetDeviceCount(&devices) != cudaSuccess || devices == 0) {
    std::printf("gpu_check: no CUDA device\n");
    return 1;
  }
  cudaDeviceProp prop{};
  cudaGetDeviceProperties(&prop, 0);
  cudaDriverGetVersion(&driver);
  cudaRuntimeGetVersion(&runtime);
  emit("## Device and build\n\n- GPU: %s, compute capability %d.%d, %d multiprocessors, %.1f GiB\n", prop.name,
       prop.major, prop.minor, prop.multiProcessorCount, static_cast<double>(prop.totalGlobalMem) / (1 << 30));
  emit("- CUDA driver %d.%d, runtime %d.%d; nvcc %d.%d; host compiler %s\n", driver / 1000, driver % 1000 / 10,
       runtime / 1000, runtime % 1000 / 10, __CUDACC_VER_MAJOR__, __CUDACC_VER_MINOR__, __VERSION__);
  emit("- CPU: %u hardware threads (eom::ensemble's baseline uses them all)\n", std::thread::hardware_concurrency());
  emit("- chain10: nq = %d, np = %d, parameter cache %d doubles; Panda: nq = %d, np = %d, nu = %d, cache %d\n",
       Chain::nq, Chain::np, eom::cuda::parameter_cache_of<Chain>, Panda::nq, Panda::np, Panda::nu,
       eom::cuda::parameter_cache_of<Panda>);
  kernel_attributes<Chain>("chain10");
  kernel_attributes<Panda>("Panda");
  {  // warm-up: context creation, module load
    const auto w = deployment(256, false);
    eom::cuda::ensemble<Chain>(w.view(), options(eom::Method::rk4, {}));
  }

  // 2. The kernel.
  Timing chain_rk4, chain_shared, chain_dp5, panda_rk4, panda_dp5;
  if (!throughput_only) {
    emit("\n## forward_dynamics on the GPU against the host, random states\n\n"
         "| model | states | max ‖Δ‖∞/‖q̈‖∞ | max elementwise | success differs | CUDA |\n|---|---|---|---|---|---|\n");
    kernel_check<Chain>("chain10", 100000);
    kernel_check<Panda>("Panda", 100000);

    // 3. Agreement.
    std::vector<double> times;
    for (int k = 0; k <= 20; ++k) times.push_back(0.1 * k);
    emit("\n## GPU against CPU, same cases (2 s; samples every 0.1 s)\n\n"
         "| model | method | cases | failing (both) | status differs | final: max rel. | samples: max rel. | chunked |\n"
         "|---|---|---|---|---|---|---|---|\n");
    chain_rk4 = agreement<Chain>("chain10 deployment", deployment(cpu_cases, true), eom::Method::rk4, times);
    chain_shared = agreement<Chain>("chain10, shared p", deployment(cpu_cases, true, true), eom::Method::rk4, times);
    chain_dp5 = agreement<Chain>("chain10 deployment", deployment(cpu_cases / 2, true), eom::Method::dopri5, times);
    panda_rk4 = agreement<Panda>("Panda free fall", panda_fall(cpu_cases / 2), eom::Method::rk4, times);
    panda_dp5 = agreement<Panda>("Panda free fall", panda_fall(cpu_cases / 4), eom::Method::dopri5, times);
  }

  // 4. Throughput.
  if (sizes.empty()) {
    for (std::size_t n = 1024; n <= max_cases; n *= 4) sizes.push_back(n);
    if (sizes.empty() || sizes.back() != max_cases) sizes.push_back(max_cases);
    if (quick) sizes = {1024, 16384};
  }
  emit("\n## Throughput (2 s of motion per case; RK4 h = 1 ms; dopri5 rtol = atol = 1e-8)\n\n"
       "GPU cases/s: the whole call (transposition, transfers, kernel) and the kernel alone; CPU: "
       "eom::ensemble on all %u hardware threads (chain10 RK4 with batch lanes), from the agreement runs.\n\n"
       "| model | method | cases | GPU cases/s | GPU kernel cases/s | CPU cases/s | GPU / CPU |\n"
       "|---|---|---|---|---|---|---|\n",
       std::thread::hardware_concurrency());
  throughput<Chain>("chain10", eom::Method::rk4, [](std::size_t n) { return deployment(n, false); }, sizes,
                    chain_rk4.cpu_cases_per_second);
  throughput<Chain>("chain10, shared p", eom::Method::rk4, [](std::size_t n) { return deployment(n, false, true); },
                    sizes, chain_shared.cpu_cases_per_second);
  throughput<Chain>("chain10", eom::Method::dopri5, [](std::size_t n) { return deployment(n, false); }, sizes,
                    chain_dp5.cpu_cases_per_second);
  throughput<Panda>("Panda", eom::Method::rk4, panda_fall, sizes, panda_rk4.cpu_cases_per_second);
  throughput<Panda>("Panda", eom::Method::dopri5, panda_fall, sizes, panda_dp5.cpu_cases_per_second);
  if (markdown_file != nullptr) {
    if (FILE* f = std::fopen(markdown_file, "w")) {
      std::fputs(markdown.c_str(), f);
      std::fclose(f);
    }
  }
  return 0;
}
