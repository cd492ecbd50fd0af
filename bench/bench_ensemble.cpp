// Throughput of eom::ensemble on the paper's deployment (generated chain10 kernels, RK4 with
// h = 1 ms as in the demo, 32 cases of 2 s that differ in release rate and masses), on 1, 2 and
// 4 threads, one case at a time (batch 0) and through the batch kernel, 4 cases stepped together
// (batch 1; the results are the same). `cases/s` is the throughput; `speedup` is against the
// 1-thread, one-case-at-a-time run of the same process. The machine this runs on may be shared:
// read the figures as measured, not promised.
#include <chrono>
#include <cstdio>
#include <vector>

#include <benchmark/benchmark.h>

#include "ensemble_cases.hpp"

namespace {

using Chain = chain10::Kernels;
constexpr std::size_t cases = 32;
double serial_seconds_per_run = 0;

// Runs the ensemble of `cases` deployment cases with `opt` for the benchmark's iterations; the
// wall-clock seconds per run, and its cases/s counter set.
double time_ensemble(benchmark::State& state, const eom::EnsembleOptions& opt) {
  const auto d = eom_ensemble_cases::deployment(cases);
  std::vector<eom::IntegrationResult<Chain::nq>> results(cases);
  double seconds = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const auto status = eom::ensemble<Chain>(d.cases(), opt, std::span(results));
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    benchmark::DoNotOptimize(results.data());
    if (status != eom::Status::ok || results[0].status != eom::Status::ok) state.SkipWithError("failed");
  }
  const double per_run = seconds / static_cast<double>(state.iterations());
  state.counters["cases/s"] = benchmark::Counter(static_cast<double>(cases) / per_run);
  return per_run;
}

void BM_DeploymentEnsemble(benchmark::State& state) {
  eom::EnsembleOptions opt;
  opt.t0 = 0, opt.t1 = 2.0;
  opt.integration.method = eom::Method::rk4;
  opt.integration.step = 1e-3;
  opt.threads = static_cast<unsigned>(state.range(0));
  opt.batch = state.range(1) != 0;
  const double per_run = time_ensemble(state, opt);
  if (opt.threads == 1 && !opt.batch) serial_seconds_per_run = per_run;
  if (serial_seconds_per_run > 0) state.counters["speedup"] = serial_seconds_per_run / per_run;
}
BENCHMARK(BM_DeploymentEnsemble)
    ->ArgNames({"threads", "batch"})
    ->Args({1, 0})->Args({2, 0})->Args({4, 0})->Args({1, 1})->Args({2, 1})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

// The adaptive methods one case at a time (lockstep 0) and in lock-step, 4 cases sharing each step
// through the batch kernel (lockstep 1; within the tolerance, not bitwise), rtol = atol = 1e-8,
// one thread; `speedup` against the same method one case at a time, in the same process.
void BM_DeploymentLockstep(benchmark::State& state) {
  static double one_at_a_time = 0;
  eom::EnsembleOptions opt;
  opt.t0 = 0, opt.t1 = 2.0;
  opt.integration.method = state.range(0) == 5 ? eom::Method::dopri5 : eom::Method::dop853;
  opt.integration.rtol = opt.integration.atol = 1e-8;
  opt.lockstep = state.range(1) != 0;
  const double per_run = time_ensemble(state, opt);
  if (!opt.lockstep) one_at_a_time = per_run;
  if (opt.lockstep && one_at_a_time > 0) state.counters["speedup"] = one_at_a_time / per_run;
}
BENCHMARK(BM_DeploymentLockstep)
    ->ArgNames({"method", "lockstep"})
    ->Args({5, 0})->Args({5, 1})->Args({8, 0})->Args({8, 1})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);

}  // namespace

BENCHMARK_MAIN();
