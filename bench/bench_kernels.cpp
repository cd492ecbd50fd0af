// Every generated kernel of the bundled models against eom::Reference<Model> (run-time AD), one
// call per iteration over a pool of 64 random states. After the run it prints, from the same
// run, the speed-up of each kernel: Reference time / generated time (CPU time per call; with
// --benchmark_repetitions, the fastest repetition of each).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include <bundled_models.hpp>  // the cases: generated Kernels, Reference, sampling

#include <eom/reference.hpp>

namespace {

using namespace eom_cases;

constexpr std::size_t kPool = 64;  // a power of two: the index wraps with a mask

// One benchmark: `call.template operator()<K>(sample, out)` for K = generated Kernels or Reference.
template <class Case, class K, class Call> void run(benchmark::State& state, Call call) {
  const auto pool = random_samples<Case>(kPool, 7);
  // Room for the largest output: ∂q̈/∂q, ∂q̈/∂q̇ and ∂q̈/∂u of this model.
  constexpr int nq = Case::Ref::nq, nu = Case::Ref::nu;
  std::array<double, 2 * nq * nq + nq * nu + 1> out{};
  std::size_t i = 0;
  for (auto _ : state) {
    call.template operator()<K>(pool[i], out.data());
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
    i = (i + 1) & (kPool - 1);
  }
}

// Registers <model>/<kernel>/generated and <model>/<kernel>/reference.
template <class Case, class Call> void add(const char* kernel, Call call) {
  const std::string base = std::string(Case::name) + "/" + kernel;
  benchmark::RegisterBenchmark((base + "/generated").c_str(), [call](benchmark::State& s) {
    run<Case, typename Case::Gen>(s, call);
  })->Unit(benchmark::kNanosecond);
  benchmark::RegisterBenchmark((base + "/reference").c_str(), [call](benchmark::State& s) {
    run<Case, typename Case::Ref>(s, call);
  })->Unit(benchmark::kNanosecond);
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
  if constexpr (!requires { requires Case::reference_derivatives_need_big_stack; })
    add<Case>("forward_dynamics_derivatives", []<class K>(const S& s, double* o) {
      K::forward_dynamics_derivatives(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), o,
                                      o + nq * nq, o + 2 * nq * nq);
    });
  add<Case>("inverse_dynamics", []<class K>(const S& s, double* o) {
    K::inverse_dynamics(s.t, s.q.data(), s.qd.data(), s.qdd.data(), s.up(), s.p.data(), o);
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
  benchmark::RunSpecifiedBenchmarks(&collector);
  benchmark::Shutdown();
  print_ratios(collector.best);
  return 0;
}
