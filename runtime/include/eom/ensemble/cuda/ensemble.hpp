// Ensembles on an NVIDIA GPU: eom::cuda::ensemble<K> takes the cases and options of
// eom::ensemble (ensemble.hpp) and returns its results, every case integrated by one GPU thread.
// For CUDA sources (nvcc, C++20, --expt-relaxed-constexpr; target eom::cuda), with a model made by
// add_eom_model(... CUDA), whose kernels are device code too (docs/CONTRACT.md §3):
//
//   std::vector<eom::StateFor<K>> x0 = ...;                       // one per case
//   eom::EnsembleOptions opt;                                      // as for eom::ensemble
//   opt.t0 = 0, opt.t1 = 2;
//   opt.integration.method = eom::Method::rk4, opt.integration.step = 1e-3;
//   auto r = eom::cuda::ensemble<chain10::Kernels>({x0, p, {}}, opt);
//   if (r.status != eom::Status::ok) ... r.error, r.message ...   // no GPU, options it lacks
//   r.cases[c].status, r.cases[c].x, r.sample(c, k) ...           // as eom::ensemble's
//
// What runs on the GPU (anything else is Status::method_unavailable with Error::unsupported, so a
// caller can fall back to eom::ensemble): held inputs (EnsembleCases::u), Method::rk4 and
// Method::dopri5 (each thread its own step size), sample times, no stabilization (constrained
// models integrate their forward dynamics as they are; the check of the initial state runs on
// the host), free joints. Each case is what eom/ensemble/cuda/case.hpp computes: eom::integrate's
// arithmetic, so results agree with eom::ensemble's to the rounding of the device's sin, cos,
// sqrt and pow (bit for bit on the host; a chaotic case's divergence grows from there). A case
// that fails reports its own status; the others complete.
//
// Memory layout, structure of arrays: in device memory entry i of case c is at [i·n + c] for
// every per-case array (x0, p, u, the final x, the samples at [(k·m + i)·n + c]), with n the
// cases of the launch. Thread c handles case c, so when the 32 threads of a warp read entry i
// they read 32 consecutive doubles: one or two 128-byte transactions, where the natural layout
// (a case's m entries together, [c·m + i]) would touch 32 different lines per access and use an
// eighth of each. The states a thread works on (stages, dense output, the kernel's scratch)
// live in its local memory, which the hardware interleaves across the threads of a warp the
// same way. Shared parameters (K::np values for all) are read by every thread at the same
// address (one broadcast), and their parameter cache (K::forward_dynamics_prepare) is computed
// once on the host; per-case parameters are prepared by each thread into its own local array.
//
// Cases that exceed the GPU's memory go in chunks: as many cases per launch as fit in half of
// the device memory free at the start (DeviceOptions::max_chunk lowers that), the results of one
// chunk copied back before the next is uploaded. No GPU at run time (no driver, no device, or
// DeviceOptions::device out of range): Status::method_unavailable with Error::no_device and
// CUDA's message, nothing integrated. A CUDA failure on the way (out of memory, a launch that
// fails): Error::out_of_memory or Error::cuda, the cases not completed reported as
// method_unavailable.
#pragma once

#include <cuda_runtime.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "eom/ensemble/cuda/case.hpp"
#include "eom/ensemble/ensemble.hpp"

namespace eom::cuda {

enum class Error {
  none,
  no_device,      // no CUDA driver or device, or DeviceOptions::device out of range
  unsupported,    // options the GPU path lacks (method, stabilization); nothing run
  out_of_memory,  // not even a small chunk fits
  cuda,           // another CUDA failure (the message says which)
};

constexpr const char* to_string(Error e) {
  switch (e) {
    case Error::none: return "none";
    case Error::no_device: return "no CUDA device";
    case Error::unsupported: return "not supported on the GPU";
    case Error::out_of_memory: return "out of GPU memory";
    case Error::cuda: return "CUDA error";
  }
  return "unknown";
}

struct DeviceOptions {
  int device = 0;             // the GPU (cudaSetDevice)
  int block = 128;            // threads per block
  std::size_t max_chunk = 0;  // cases per launch at most (0: as many as fit in memory)
};

// eom::EnsembleResult and what the GPU run adds: why it did not run (error, message), the
// device's name, the launches, and the time on the device.
template <int nq, int nv = nq> struct EnsembleResult : eom::EnsembleResult<nq, nv> {
  Error error = Error::none;
  std::string message;         // CUDA's message, or what is not supported
  std::string device;          // the GPU's name
  std::size_t chunks = 0;      // launches
  double kernel_seconds = 0;   // in the integration kernels (CUDA events)
  double total_seconds = 0;    // the whole call, transfers and layout included
};

template <class K> using EnsembleResultFor = EnsembleResult<K::nq, nv_of<K>>;

namespace detail {

// One launch's arrays in device memory (structure of arrays, stride n).
struct Chunk {
  std::size_t n = 0;
  const double* x0 = nullptr;  // m × n
  const double* p = nullptr;   // np × n, or np shared (p_shared)
  const double* u = nullptr;   // nu × n, or nu shared (u_shared)
  bool p_shared = false, u_shared = false;
  const double* pc = nullptr;  // the parameter cache of shared p, or null
  const int* start = nullptr;  // the constrained start's status per case, or null (ok)
  double* x = nullptr;         // m × n: the state reached
  double* t = nullptr;         // n
  long long* counts = nullptr;  // 3 × n: accepted, rejected, evaluations
  int* status = nullptr;       // n
  double* samples = nullptr;   // (samples · m) × n
};

template <int m> struct SampleOut {
  double* samples;
  std::size_t n, c;
  __device__ void sample(int k, const double* x) const noexcept {
    for (int i = 0; i < m; ++i) samples[(static_cast<std::size_t>(k) * m + i) * n + c] = x[i];
  }
};

template <class K, CaseMethod method>
__global__ void ensemble_kernel(CaseSettings s, Chunk ch) {
  constexpr int m = K::nq + nv_of<K>, np = K::np, nu = K::nu;
  const std::size_t c = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (c >= ch.n) return;
  const std::size_t n = ch.n;
  double x[m];
  for (int i = 0; i < m; ++i) x[i] = ch.x0[i * n + c];
  double p[np > 0 ? np : 1], u[nu > 0 ? nu : 1];
  CaseInputs in;
  if constexpr (np > 0) {
    if (ch.p_shared) {
      in.p = ch.p;
    } else {
      for (int j = 0; j < np; ++j) p[j] = ch.p[j * n + c];
      in.p = p;
    }
  }
  if constexpr (nu > 0) {
    if (ch.u_shared) {
      in.u = ch.u;
    } else {
      for (int j = 0; j < nu; ++j) u[j] = ch.u[j * n + c];
      in.u = u;
    }
  }
  in.pc = ch.pc;
  if (ch.start != nullptr) in.start = static_cast<Status>(ch.start[c]);
  SampleOut<m> out{ch.samples, n, c};
  for (int k = 0; k < s.samples; ++k)  // NaN where the case stops before a sample time
    for (int i = 0; i < m; ++i)
      ch.samples[(static_cast<std::size_t>(k) * m + i) * n + c] = std::numeric_limits<double>::quiet_NaN();
  const CaseResult r = integrate_case<K, method>(s, in, x, out);
  for (int i = 0; i < m; ++i) ch.x[i * n + c] = x[i];
  ch.t[c] = r.t;
  ch.counts[c] = r.accepted;
  ch.counts[n + c] = r.rejected;
  ch.counts[2 * n + c] = r.evaluations;
  ch.status[c] = static_cast<int>(r.status);
}

// Device memory, freed on scope exit.
template <class T> struct DeviceArray {
  T* data = nullptr;
  cudaError_t allocate(std::size_t count) noexcept {
    return cudaMalloc(reinterpret_cast<void**>(&data), std::max<std::size_t>(count, 1) * sizeof(T));
  }
  ~DeviceArray() {
    if (data != nullptr) cudaFree(data);
  }
};

}  // namespace detail

// Into results and samples as eom::ensemble does (results[c], samples[c·S + k]).
template <Dynamics K>
EnsembleResultFor<K> ensemble(const EnsembleCasesFor<K>& cases, const EnsembleOptions& opt,
                              const DeviceOptions& device = {}) {
  using Clock = std::chrono::steady_clock;
  const auto began = Clock::now();
  constexpr int m = K::nq + nv_of<K>, np = K::np, nu = K::nu;
  constexpr int cache = parameter_cache_of<K>;
  using State = StateFor<K>;
  EnsembleResultFor<K> r;
  const std::size_t n = cases.x0.size(), ns = opt.sample_times.size();
  r.sample_count = ns;
  r.cases.resize(n);
  r.samples.resize(n * ns);
  const auto finish = [&](Status status, Error error, std::string message) {
    r.status = status, r.error = error, r.message = std::move(message);
    r.total_seconds = std::chrono::duration<double>(Clock::now() - began).count();
    return r;
  };
  // Nothing (more) integrated: cases from `first` on report it (time t0, state x0).
  const auto not_run = [&](std::size_t first, Error error, std::string message) {
    for (std::size_t c = first; c < n; ++c) {
      r.cases[c] = IntegrationResultFor<K>{};
      r.cases[c].status = Status::method_unavailable;
      r.cases[c].t = opt.t0;
      r.cases[c].x = cases.x0[c];
    }
    return finish(Status::method_unavailable, error, std::move(message));
  };
  if (!eom::detail::ensemble_input_ok<K>(cases, opt, false, n, n * ns))
    return finish(Status::invalid_argument, Error::none, "");
  for (State& s : r.samples) s.fill(std::numeric_limits<double>::quiet_NaN());
  const IntegrationOptions& io = opt.integration;
  if (io.method != Method::rk4 && io.method != Method::dopri5)
    return not_run(0, Error::unsupported,
                   std::string("eom::cuda::ensemble runs rk4 and dopri5, not ") + to_string(io.method));
  if (io.stabilization.method != Stabilization::Method::none)
    return not_run(0, Error::unsupported, "eom::cuda::ensemble runs without stabilization");
  if (n == 0) return finish(Status::ok, Error::none, "");

  // The device.
  int devices = 0;
  if (const cudaError_t e = cudaGetDeviceCount(&devices); e != cudaSuccess || devices == 0) {
    cudaGetLastError();
    return not_run(0, Error::no_device,
                   std::string("no CUDA device: ") + (e != cudaSuccess ? cudaGetErrorString(e) : "none found"));
  }
  if (device.device < 0 || device.device >= devices)
    return not_run(0, Error::no_device, "no CUDA device of that number");
  if (const cudaError_t e = cudaSetDevice(device.device); e != cudaSuccess)
    return not_run(0, Error::no_device, std::string("no CUDA device: ") + cudaGetErrorString(e));
  cudaDeviceProp prop{};
  if (cudaGetDeviceProperties(&prop, device.device) == cudaSuccess) r.device = prop.name;

  // What every chunk shares: the sample times, a shared p's parameter cache, shared u and p.
  const bool p_shared = np > 0 && cases.p.size() == static_cast<std::size_t>(np);
  const bool u_shared = nu > 0 && cases.u.size() == static_cast<std::size_t>(nu);
  detail::DeviceArray<double> d_times, d_pc, d_p_shared, d_u_shared;
  const auto fail = [&](cudaError_t e, std::size_t first) {
    return not_run(first, e == cudaErrorMemoryAllocation ? Error::out_of_memory : Error::cuda,
                   cudaGetErrorString(e));
  };
#define EOM_CUDA_TRY(call, first)                   \
  do {                                              \
    if (const cudaError_t e_ = (call); e_ != cudaSuccess) { \
      cudaGetLastError();                           \
      return fail(e_, first);                       \
    }                                               \
  } while (0)
  EOM_CUDA_TRY(d_times.allocate(ns), 0);
  if (ns > 0)
    EOM_CUDA_TRY(cudaMemcpy(d_times.data, opt.sample_times.data(), ns * sizeof(double),
                            cudaMemcpyHostToDevice), 0);
  if (p_shared) {
    EOM_CUDA_TRY(d_p_shared.allocate(np), 0);
    EOM_CUDA_TRY(cudaMemcpy(d_p_shared.data, cases.p.data(), np * sizeof(double), cudaMemcpyHostToDevice), 0);
    if constexpr (cache > 0) {
      std::vector<double> pc(cache);
      K::forward_dynamics_prepare(cases.p.data(), pc.data());
      EOM_CUDA_TRY(d_pc.allocate(cache), 0);
      EOM_CUDA_TRY(cudaMemcpy(d_pc.data, pc.data(), cache * sizeof(double), cudaMemcpyHostToDevice), 0);
    }
  }
  if (u_shared) {
    EOM_CUDA_TRY(d_u_shared.allocate(nu), 0);
    EOM_CUDA_TRY(cudaMemcpy(d_u_shared.data, cases.u.data(), nu * sizeof(double), cudaMemcpyHostToDevice), 0);
  }

  // Cases per launch: what fits in half of the free memory.
  const std::size_t per_case =
      sizeof(double) * (2 * m + (p_shared ? 0 : np) + (u_shared ? 0 : nu) + ns * m + 1) +
      sizeof(long long) * 3 + sizeof(int) * (K::nc > 0 ? 2 : 1);
  std::size_t free_bytes = 0, total_bytes = 0;
  EOM_CUDA_TRY(cudaMemGetInfo(&free_bytes, &total_bytes), 0);
  std::size_t chunk = std::max<std::size_t>(1, free_bytes / 2 / per_case);
  if (device.max_chunk > 0) chunk = std::min(chunk, device.max_chunk);
  chunk = std::min(chunk, n);

  detail::DeviceArray<double> d_x0, d_p, d_u, d_x, d_t, d_samples;
  detail::DeviceArray<long long> d_counts;
  detail::DeviceArray<int> d_status, d_start;
  EOM_CUDA_TRY(d_x0.allocate(chunk * m), 0);
  EOM_CUDA_TRY(d_x.allocate(chunk * m), 0);
  EOM_CUDA_TRY(d_t.allocate(chunk), 0);
  EOM_CUDA_TRY(d_counts.allocate(3 * chunk), 0);
  EOM_CUDA_TRY(d_status.allocate(chunk), 0);
  EOM_CUDA_TRY(d_samples.allocate(chunk * ns * m), 0);
  if (np > 0 && !p_shared) EOM_CUDA_TRY(d_p.allocate(chunk * np), 0);
  if (nu > 0 && !u_shared) EOM_CUDA_TRY(d_u.allocate(chunk * nu), 0);
  if (K::nc > 0) EOM_CUDA_TRY(d_start.allocate(chunk), 0);

  CaseSettings s;
  s.t0 = opt.t0, s.t1 = opt.t1;
  s.step = io.step, s.rtol = io.rtol, s.atol = io.atol, s.max_steps = io.max_steps;
  s.times = d_times.data;
  s.samples = static_cast<int>(ns);
  cudaEvent_t event_start = nullptr, event_stop = nullptr;
  cudaEventCreate(&event_start);
  cudaEventCreate(&event_stop);

  std::vector<double> h_in, h_out, h_samples;
  std::vector<long long> h_counts;
  std::vector<int> h_status, h_start;
  for (std::size_t first = 0; first < n; first += chunk) {
    const std::size_t count = std::min(chunk, n - first);
    // Upload, transposed into the structure of arrays (stride count; written in order).
    h_in.resize(count * m);
    for (int i = 0; i < m; ++i)
      for (std::size_t c = 0; c < count; ++c) h_in[i * count + c] = cases.x0[first + c][i];
    EOM_CUDA_TRY(cudaMemcpy(d_x0.data, h_in.data(), count * m * sizeof(double), cudaMemcpyHostToDevice), first);
    if (np > 0 && !p_shared) {
      h_in.resize(count * np);
      for (int j = 0; j < np; ++j)
        for (std::size_t c = 0; c < count; ++c) h_in[j * count + c] = cases.p[(first + c) * np + j];
      EOM_CUDA_TRY(cudaMemcpy(d_p.data, h_in.data(), count * np * sizeof(double), cudaMemcpyHostToDevice), first);
    }
    if (nu > 0 && !u_shared) {
      h_in.resize(count * nu);
      for (int j = 0; j < nu; ++j)
        for (std::size_t c = 0; c < count; ++c) h_in[j * count + c] = cases.u[(first + c) * nu + j];
      EOM_CUDA_TRY(cudaMemcpy(d_u.data, h_in.data(), count * nu * sizeof(double), cudaMemcpyHostToDevice), first);
    }
    if constexpr (K::nc > 0) {  // the constrained start (constraint kernels), on the host
      h_start.assign(count, 0);
      for (std::size_t c = 0; c < count; ++c) {
        State x = cases.x0[first + c];
        const double* p = np == 0 ? nullptr : cases.p.data() + (p_shared ? 0 : (first + c) * np);
        h_start[c] = static_cast<int>(constrained_start<K>(x, p, io.stabilization));
      }
      EOM_CUDA_TRY(cudaMemcpy(d_start.data, h_start.data(), count * sizeof(int), cudaMemcpyHostToDevice), first);
    }
    detail::Chunk ch;
    ch.n = count;
    ch.x0 = d_x0.data;
    ch.p = p_shared ? d_p_shared.data : d_p.data, ch.p_shared = p_shared;
    ch.u = u_shared ? d_u_shared.data : d_u.data, ch.u_shared = u_shared;
    ch.pc = d_pc.data;
    ch.start = K::nc > 0 ? d_start.data : nullptr;
    ch.x = d_x.data, ch.t = d_t.data, ch.counts = d_counts.data, ch.status = d_status.data;
    ch.samples = d_samples.data;
    const int block = device.block > 0 ? device.block : 128;
    const std::size_t blocks = (count + block - 1) / block;
    cudaEventRecord(event_start);
    if (io.method == Method::rk4)
      detail::ensemble_kernel<K, CaseMethod::rk4><<<static_cast<unsigned>(blocks), block>>>(s, ch);
    else
      detail::ensemble_kernel<K, CaseMethod::dopri5><<<static_cast<unsigned>(blocks), block>>>(s, ch);
    cudaEventRecord(event_stop);
    EOM_CUDA_TRY(cudaGetLastError(), first);
    EOM_CUDA_TRY(cudaEventSynchronize(event_stop), first);
    float ms = 0;
    cudaEventElapsedTime(&ms, event_start, event_stop);
    r.kernel_seconds += ms * 1e-3;
    ++r.chunks;
    // Download and scatter into the results.
    h_out.resize(count * m);
    h_counts.resize(3 * count);
    h_status.resize(count);
    std::vector<double> h_t(count);
    EOM_CUDA_TRY(cudaMemcpy(h_out.data(), d_x.data, count * m * sizeof(double), cudaMemcpyDeviceToHost), first);
    EOM_CUDA_TRY(cudaMemcpy(h_t.data(), d_t.data, count * sizeof(double), cudaMemcpyDeviceToHost), first);
    EOM_CUDA_TRY(cudaMemcpy(h_counts.data(), d_counts.data, 3 * count * sizeof(long long), cudaMemcpyDeviceToHost), first);
    EOM_CUDA_TRY(cudaMemcpy(h_status.data(), d_status.data, count * sizeof(int), cudaMemcpyDeviceToHost), first);
    for (std::size_t c = 0; c < count; ++c) {
      IntegrationResultFor<K>& out = r.cases[first + c];
      out.status = static_cast<Status>(h_status[c]);
      out.t = h_t[c];
      for (int i = 0; i < m; ++i) out.x[i] = h_out[i * count + c];
      out.accepted = static_cast<long>(h_counts[c]);
      out.rejected = static_cast<long>(h_counts[count + c]);
      out.evaluations = static_cast<long>(h_counts[2 * count + c]);
    }
    if (ns > 0) {
      h_samples.resize(count * ns * m);
      EOM_CUDA_TRY(cudaMemcpy(h_samples.data(), d_samples.data, count * ns * m * sizeof(double),
                              cudaMemcpyDeviceToHost), first);
      for (std::size_t c = 0; c < count; ++c) {
        for (std::size_t k = 0; k < ns; ++k) {
          State& sample = r.samples[(first + c) * ns + k];
          for (int i = 0; i < m; ++i) sample[i] = h_samples[(k * m + i) * count + c];
        }
      }
    }
  }
#undef EOM_CUDA_TRY
  cudaEventDestroy(event_start);
  cudaEventDestroy(event_stop);
  return finish(Status::ok, Error::none, "");
}

}  // namespace eom::cuda
