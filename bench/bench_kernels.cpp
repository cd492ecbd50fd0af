// Every generated kernel of the bundled models against eom::Reference<Model> (run-time AD), one
// call per iteration over a pool of 64 random states (taylor_coefficients at order kTaylorOrder),
// the whole run on a thread with a 256 MB stack (for the Reference). After the run it prints, from
// the same run, the speed-up of each kernel: Reference time / generated time (CPU time per call;
// with --benchmark_repetitions, the fastest repetition of each).
//
// And the spread of each generated kernel's time, <model>/<kernel>/generated/per_call: min,
// median, 99th percentile and max ns per call over many individually timed samples (counters
// min_ns, median_ns, p99_ns, max_ns; see "Per-call timing" below for the method and its limits).
// Only those: --benchmark_filter=per_call; bench/determinism.sh runs them and writes
// docs/benchmarks/determinism.md.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <x86intrin.h>
#endif

#include <benchmark/benchmark.h>

#include <bundled_models.hpp>  // the cases: generated Kernels, Reference, sampling

#include <eom/reference/reference.hpp>

#include "thread_stack.hpp"  // run_with_stack (tests/support)

namespace {

using namespace eom_cases;

constexpr std::size_t kPool = 64;  // a power of two: the index wraps with a mask

// The order of the timed taylor_coefficients calls: what an integrator at tolerance 1e-16 uses
// (the optimal order is about -ln(eps)/2 + 1 = 19, Jorba & Zou 2005).
constexpr int kTaylorOrder = 20;

// Room for the largest output: ∂q̈/∂q, ∂q̈/∂q̇ and ∂q̈/∂u of this model, or the Taylor
// coefficients of q and q̇ with the generated kernel's workspace.
template <class Case> std::vector<double> output_room() {
  constexpr int nq = Case::Ref::nq, nu = Case::Ref::nu;
  constexpr int taylor = (2 * nq + Case::Gen::taylor_workspace) * (kTaylorOrder + 1);
  return std::vector<double>(std::max(2 * nq * nq + nq * nu + 1, taylor));
}

// One benchmark: `call.template operator()<K>(sample, out)` for K = generated Kernels or Reference.
template <class Case, class K, class Call> void run(benchmark::State& state, Call call) {
  const auto pool = random_samples<Case>(kPool, 7);
  std::vector<double> out = output_room<Case>();
  std::size_t i = 0;
  for (auto _ : state) {
    call.template operator()<K>(pool[i], out.data());
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
    i = (i + 1) & (kPool - 1);
  }
}

// ---- Per-call timing: how deterministic is a kernel's time? ----
//
// Method. Each benchmark iteration is one sample: a batch of B consecutive calls (each on the
// next state of the pool, so the states vary as in a control loop), timed by the CPU's time-stamp
// counter (rdtsc fenced by lfence on both sides, so the calls cannot move across the reads; on
// other CPUs std::chrono::steady_clock). Per call = (ticks − timer overhead) · ns per tick / B.
//  * B = 1 for kernels of 250 ns and more: every call is timed on its own. Below that the timer's
//    overhead and resolution would be of the kernel's size, so B calls make one sample of at
//    least ~250 ns and the figures are per-call means over B consecutive calls: the spread
//    *between* those B calls is not resolved (the counter `batch` says B).
//  * Timer overhead: the median of 10001 empty timed regions, subtracted from every sample (the
//    counter `timer_ns`). Timer resolution (counter `resolution_ns`): the greatest common
//    divisor of those empty regions' durations. Bare metal counts single TSC ticks (< 1 ns); a
//    virtual machine may advance the TSC in coarser steps (measured 26 ticks = 10 ns on the
//    machine of docs/benchmarks/determinism.md), so a sample is quantized to resolution / B.
//  * TSC ticks to ns: calibrated once against steady_clock over 50 ms. The TSC runs at a constant
//    rate (constant_tsc, nonstop_tsc in /proc/cpuinfo), not the core clock: a core slowed by
//    frequency scaling shows as a longer time, as it should.
//  * 1000 calls first (caches, branch predictors warm; they also size B), then kSamples samples.
// Limits. These are wall-clock times on a shared, non-isolated machine: the max and, less so, the
// p99 include interrupts, preemption and the other hyperthread's load, which say nothing about
// the kernel. The kernels themselves are straight-line code (no data-dependent loops; libm's
// sin/cos and the linear solve of forward_dynamics vary a little with the data), so min ≈ median
// is the kernel's own figure; a real-time claim needs the same run on an isolated core
// (isolcpus, SCHED_FIFO, fixed frequency), where max approaches p99.
constexpr long kSamples = 100000;
constexpr double kMinSampleNs = 250;

#if defined(__x86_64__) || defined(__i386__)
inline std::uint64_t ticks() noexcept {
  _mm_lfence();
  const std::uint64_t t = __rdtsc();
  _mm_lfence();
  return t;
}
#else
inline std::uint64_t ticks() noexcept {
  return static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
}
#endif

// ns per tick of ticks(), measured once against steady_clock over 50 ms (spinning).
double ns_per_tick() {
  static const double value = [] {
    using clock = std::chrono::steady_clock;
    const auto c0 = clock::now();
    const std::uint64_t t0 = ticks();
    while (clock::now() - c0 < std::chrono::milliseconds(50)) {
    }
    const auto c1 = clock::now();
    const std::uint64_t t1 = ticks();
    return std::chrono::duration<double, std::nano>(c1 - c0).count() / static_cast<double>(t1 - t0);
  }();
  return value;
}

// What every sample carries on top of the calls (the median duration of an empty timed region)
// and the timer's step (the gcd of those durations), in ticks.
struct TimerFacts {
  double overhead = 0, resolution = 0;
};
TimerFacts timer_facts() {
  static const TimerFacts value = [] {
    std::vector<std::uint64_t> d(10001);
    std::uint64_t step = 0;
    for (auto& v : d) {
      const std::uint64_t t0 = ticks();
      const std::uint64_t t1 = ticks();
      v = t1 - t0;
      step = std::gcd(step, v);
    }
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    return TimerFacts{static_cast<double>(d[d.size() / 2]), static_cast<double>(step)};
  }();
  return value;
}

template <class Case, class Call> void run_per_call(benchmark::State& state, Call call) {
  using K = typename Case::Gen;
  const auto pool = random_samples<Case>(kPool, 7);
  std::vector<double> out = output_room<Case>();
  std::size_t i = 0;
  auto one_call = [&] {
    call.template operator()<K>(pool[i], out.data());
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
    i = (i + 1) & (kPool - 1);
  };
  const double tick_ns = ns_per_tick();
  const TimerFacts timer = timer_facts();
  // Warm up: 100 groups of 10 calls, and size the batch from the median group (an interrupt
  // during the warm-up must not shrink the batch).
  std::array<double, 100> group_ns;
  for (double& g : group_ns) {
    const std::uint64_t t0 = ticks();
    for (int k = 0; k < 10; ++k) one_call();
    const std::uint64_t t1 = ticks();
    g = (static_cast<double>(t1 - t0) - timer.overhead) * tick_ns / 10;
  }
  std::nth_element(group_ns.begin(), group_ns.begin() + 50, group_ns.end());
  const double typical_ns = std::max(group_ns[50], 0.1);
  const int batch = static_cast<int>(std::clamp(std::ceil(kMinSampleNs / typical_ns), 1.0, 1000.0));

  std::vector<double> ns;  // per call, one entry per sample
  ns.reserve(static_cast<std::size_t>(state.max_iterations));
  for (auto _ : state) {
    const std::uint64_t t0 = ticks();
    for (int b = 0; b < batch; ++b) one_call();
    const std::uint64_t t1 = ticks();
    ns.push_back((static_cast<double>(t1 - t0) - timer.overhead) * tick_ns / batch);
  }
  std::sort(ns.begin(), ns.end());
  const auto at = [&](double fraction) {  // the sample at this quantile (nearest rank)
    const double n = static_cast<double>(ns.size());
    const auto rank = static_cast<std::size_t>(std::ceil(fraction * n));
    return ns[std::clamp<std::size_t>(rank, 1, ns.size()) - 1];
  };
  state.counters["min_ns"] = ns.front();
  state.counters["median_ns"] = at(0.5);
  state.counters["p99_ns"] = at(0.99);
  state.counters["max_ns"] = ns.back();
  state.counters["batch"] = batch;
  state.counters["timer_ns"] = timer.overhead * tick_ns;
  state.counters["resolution_ns"] = timer.resolution * tick_ns;
}

// Registers <model>/<kernel>/generated, <model>/<kernel>/reference and
// <model>/<kernel>/generated/per_call.
template <class Case, class Call> void add(const char* kernel, Call call) {
  const std::string base = std::string(Case::name) + "/" + kernel;
  benchmark::RegisterBenchmark((base + "/generated").c_str(), [call](benchmark::State& s) {
    run<Case, typename Case::Gen>(s, call);
  })->Unit(benchmark::kNanosecond);
  benchmark::RegisterBenchmark((base + "/reference").c_str(), [call](benchmark::State& s) {
    run<Case, typename Case::Ref>(s, call);
  })->Unit(benchmark::kNanosecond);
  benchmark::RegisterBenchmark((base + "/generated/per_call").c_str(), [call](benchmark::State& s) {
    run_per_call<Case>(s, call);
  })->Unit(benchmark::kNanosecond)->Iterations(kSamples);
}

template <class Case> void add_all() {
  using S = Sample<Case>;
  constexpr int nq = S::nq;
  add<Case>("kinetic_energy", []<class K>(const S& s, double* o) {
    o[0] = K::kinetic_energy(s.q.data(), s.qd.data(), s.p.data());
  });
  add<Case>("potential_energy", []<class K>(const S& s, double* o) {
    o[0] = K::potential_energy(s.q.data(), s.p.data());
  });
  add<Case>("mass_matrix",
            []<class K>(const S& s, double* o) { K::mass_matrix(s.q.data(), s.p.data(), o); });
  add<Case>("mass_matrix_dot", []<class K>(const S& s, double* o) {
    K::mass_matrix_dot(s.q.data(), s.qd.data(), s.p.data(), o);
  });
  add<Case>("coriolis", []<class K>(const S& s, double* o) {
    K::coriolis(s.q.data(), s.qd.data(), s.p.data(), o);
  });
  add<Case>("potential_gradient", []<class K>(const S& s, double* o) {
    K::potential_gradient(s.q.data(), s.p.data(), o);
  });
  if constexpr (Case::Ref::nc > 0) {
    add<Case>("constraint_jacobian", []<class K>(const S& s, double* o) {
      K::constraint_jacobian(s.q.data(), s.p.data(), o);
    });
    add<Case>("constraint_bias", []<class K>(const S& s, double* o) {
      K::constraint_bias(s.q.data(), s.qd.data(), s.p.data(), o);
    });
  }
  add<Case>("forward_dynamics", []<class K>(const S& s, double* o) {
    K::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), o);
  });
  add<Case>("forward_dynamics_derivatives", []<class K>(const S& s, double* o) {
    K::forward_dynamics_derivatives(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), o, o + nq * nq,
                                    o + 2 * nq * nq);
  });
  add<Case>("inverse_dynamics", []<class K>(const S& s, double* o) {
    K::inverse_dynamics(s.t, s.q.data(), s.qd.data(), s.qdd.data(), s.up(), s.p.data(), o);
  });
  // Coefficients 0..kTaylorOrder of q and q̇ (the Reference by its Taylor numbers, eom/numeric/jet.hpp).
  add<Case>("taylor_coefficients", []<class K>(const S& s, double* o) {
    constexpr int n = nq * (kTaylorOrder + 1);
    K::taylor_coefficients(kTaylorOrder, s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), o, o + n, o + 2 * n);
  });
}

// The console output as usual, plus each benchmark's fastest CPU time per call, for the ratios.
class Collector : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> best;  // "<model>/<kernel>/<generated|reference>" -> ns
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      if (r.run_type != Run::RT_Iteration || r.error_occurred) continue;
      // per_call (named .../per_call/iterations:N) times batches, reported by its counters.
      if (r.benchmark_name().find("/per_call") != std::string::npos) continue;
      const double ns = r.GetAdjustedCPUTime();  // every benchmark here reports in ns
      auto [it, fresh] = best.emplace(r.benchmark_name(), ns);
      if (!fresh) it->second = std::min(it->second, ns);
    }
  }
};

void print_ratios(const std::map<std::string, double>& best) {
  std::printf("\n%-48s %12s %12s %9s\n", "kernel", "reference ns", "generated ns", "speed-up");
  for (const auto& [name, gen] : best) {
    const std::string suffix = "/generated";
    if (!name.ends_with(suffix)) continue;
    const std::string kernel = name.substr(0, name.size() - suffix.size());
    const auto ref = best.find(kernel + "/reference");
    if (ref == best.end()) continue;
    std::printf("%-48s %12.1f %12.1f %8.1fx\n", kernel.c_str(), ref->second, gen,
                ref->second / gen);
  }
  std::printf("(a generated kernel is an out-of-line call, the Reference is inlined into the "
              "loop: for the smallest kernels the call itself dominates)\n");
}

}  // namespace

int main(int argc, char** argv) {
  add_all<SpringPendulumCase>();
  add_all<CartesianPendulumCase>();
  add_all<DoublePendulumCase>();
  add_all<Chain10Case>();
  add_all<ClosedChain5Case>();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  Collector collector;
  // On a thread with a big stack: the Reference keeps its AD and Taylor numbers on the stack, and
  // chain10's derivatives and Taylor coefficients need more than the main thread's 8 MB.
  if (!run_with_stack(std::size_t{256} << 20, [&] { benchmark::RunSpecifiedBenchmarks(&collector); })) {
    std::fprintf(stderr, "eom_bench_kernels: could not start a thread with a 256 MB stack\n");
    return 1;
  }
  benchmark::Shutdown();
  print_ratios(collector.best);
  return 0;
}
