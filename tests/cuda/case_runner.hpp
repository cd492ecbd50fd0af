// What eom::cuda::ensemble does with each case, run on the host: the same inputs (the shared
// parameter cache prepared once, or each case's own), the constrained start checked on the host,
// eom/ensemble/cuda/case.hpp's integrate_case, samples NaN where a case stops first. tests/cuda compares
// it with eom::ensemble bit for bit; gpu_check.cu with the GPU.
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include <eom/ensemble/cuda/case.hpp>
#include <eom/ensemble/ensemble.hpp>

namespace eom_cuda_test {

template <class K> struct HostSamples {
  eom::StateFor<K>* samples;
  void sample(int k, const double* x) const noexcept {
    for (int i = 0; i < K::nq + eom::nv_of<K>; ++i) samples[k][i] = x[i];
  }
};

// eom::cuda::ensemble's cases on the host (rk4 or dopri5, held inputs, no stabilization).
template <eom::Dynamics K>
eom::EnsembleResultFor<K> host_cases(const eom::EnsembleCasesFor<K>& cases, const eom::EnsembleOptions& opt) {
  constexpr int m = K::nq + eom::nv_of<K>, np = K::np, nu = K::nu;
  constexpr int cache = eom::cuda::parameter_cache_of<K>;
  const std::size_t n = cases.x0.size(), ns = opt.sample_times.size();
  eom::EnsembleResultFor<K> r;
  r.sample_count = ns;
  r.cases.resize(n);
  r.samples.resize(n * ns);
  for (auto& s : r.samples) s.fill(std::numeric_limits<double>::quiet_NaN());
  const eom::IntegrationOptions& io = opt.integration;
  eom::cuda::CaseSettings s;
  s.t0 = opt.t0, s.t1 = opt.t1;
  s.step = io.step, s.rtol = io.rtol, s.atol = io.atol, s.max_steps = io.max_steps;
  s.times = opt.sample_times.data();
  s.samples = static_cast<int>(ns);
  const auto method = io.method == eom::Method::rk4 ? eom::cuda::CaseMethod::rk4 : eom::cuda::CaseMethod::dopri5;
  const bool p_shared = np > 0 && cases.p.size() == static_cast<std::size_t>(np);
  const bool u_shared = nu > 0 && cases.u.size() == static_cast<std::size_t>(nu);
  std::vector<double> shared_pc(cache > 0 ? cache : 1);
  if constexpr (cache > 0)
    if (p_shared) K::forward_dynamics_prepare(cases.p.data(), shared_pc.data());
  for (std::size_t c = 0; c < n; ++c) {
    eom::cuda::CaseInputs in;
    in.p = np == 0 ? nullptr : cases.p.data() + (p_shared ? 0 : c * np);
    in.u = nu == 0 ? nullptr : cases.u.data() + (u_shared ? 0 : c * nu);
    in.pc = cache > 0 && p_shared ? shared_pc.data() : nullptr;
    if constexpr (K::nc > 0) {
      eom::StateFor<K> x = cases.x0[c];
      in.start = eom::constrained_start<K>(x, in.p, io.stabilization);
    }
    double x[m];
    for (int i = 0; i < m; ++i) x[i] = cases.x0[c][i];
    HostSamples<K> out{r.samples.data() + c * ns};
    const eom::cuda::CaseResult cr =
        method == eom::cuda::CaseMethod::rk4
            ? eom::cuda::integrate_case<K, eom::cuda::CaseMethod::rk4>(s, in, x, out)
            : eom::cuda::integrate_case<K, eom::cuda::CaseMethod::dopri5>(s, in, x, out);
    auto& result = r.cases[c];
    result.status = cr.status;
    result.t = cr.t;
    for (int i = 0; i < m; ++i) result.x[i] = x[i];
    result.accepted = cr.accepted, result.rejected = cr.rejected, result.evaluations = cr.evaluations;
  }
  return r;
}

}  // namespace eom_cuda_test
