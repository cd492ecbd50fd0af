// forward_dynamics_batch against forward_dynamics: states per second on one
// core, for chain10 and closed_chain5, over a pool of 1024 random states (tests/support's
// sampler, fixed seed) already laid out for each kernel. Each batch benchmark reports `vs scalar`,
// its throughput over the scalar kernel's of the same build variant, measured in the same run:
//   bundled       the libraries of models/ (the default flags: baseline x86-64; sin and cos lane
//                 by lane through std::, so the batch results equal the scalar ones bitwise)
//   avx2          the same models generated again and compiled with -mavx2 (both kernels)
//   avx2_libmvec  ... and with EOM_BATCH_LIBMVEC: glibc's vector sin and cos (≤ 4 ulp; results
//                 within 1e-13 of the scalar kernel, no longer bitwise)
// The machine this runs on may be shared: read the figures as measured, not promised.
#include <array>
#include <chrono>
#include <map>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include <bundled_models.hpp>

#include <bench_chain10_avx2.hpp>
#include <bench_chain10_avx2_libmvec.hpp>
#include <bench_closed_chain5_avx2.hpp>
#include <bench_closed_chain5_avx2_libmvec.hpp>

namespace {

using namespace eom_cases;
constexpr int kPool = 1024;
std::map<std::string, double> scalar_rate;  // states/s of the scalar kernel, by label

template <class Case> struct Pool {
  static constexpr int nq = Case::Ref::nq, np = Case::Ref::np, nu = Case::Ref::nu;
  std::vector<Sample<Case>> states = random_samples<Case>(kPool, 16);
};

// The loop's wall time (the kernel dominates it: a state takes a microsecond or more).
template <class Body> double rate(benchmark::State& state, int per_iteration, Body body) {
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) body();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double r = static_cast<double>(state.iterations()) * per_iteration / seconds;
  state.counters["states/s"] = r;
  return r;
}

template <class Case, class K> void BM_Scalar(benchmark::State& state, const std::string& label) {
  const Pool<Case> pool;
  std::array<double, Case::Ref::nq> qdd{};
  int k = 0;
  scalar_rate[label] = rate(state, 1, [&] {
    const auto& s = pool.states[k];
    benchmark::DoNotOptimize(
        K::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), qdd.data()));
    benchmark::ClobberMemory();
    k = (k + 1) % kPool;
  });
}

template <class Case, class K> void BM_Batch(benchmark::State& state, const std::string& label) {
  constexpr int W = K::batch_lanes, nq = Case::Ref::nq, np = Case::Ref::np, nu = Case::Ref::nu;
  constexpr int nu1 = nu > 0 ? nu : 1, np1 = np > 0 ? np : 1;
  const Pool<Case> pool;
  // The pool in structure-of-arrays blocks of W states.
  constexpr int blocks = kPool / W;
  std::vector<double> t(kPool), q(kPool * nq), qd(kPool * nq), u(kPool * nu1), p(kPool * np1);
  for (int b = 0; b < blocks; ++b)
    for (int l = 0; l < W; ++l) {
      const auto& s = pool.states[b * W + l];
      t[b * W + l] = s.t;
      for (int i = 0; i < nq; ++i) {
        q[(b * nq + i) * W + l] = s.q[i];
        qd[(b * nq + i) * W + l] = s.qd[i];
      }
      for (int i = 0; i < nu; ++i) u[(b * nu1 + i) * W + l] = s.u[i];
      for (int i = 0; i < np; ++i) p[(b * np1 + i) * W + l] = s.p[i];
    }
  std::array<double, nq * W> qdd{};
  int b = 0;
  const double r = rate(state, W, [&] {
    benchmark::DoNotOptimize(K::forward_dynamics_batch(&t[b * W], &q[b * nq * W], &qd[b * nq * W],
                                                       &u[b * nu1 * W], &p[b * np1 * W],
                                                       qdd.data()));
    benchmark::ClobberMemory();
    b = (b + 1) % blocks;
  });
  if (scalar_rate.count(label)) state.counters["vs scalar"] = r / scalar_rate[label];
}

template <class Case, class K> void add(const std::string& label) {
  benchmark::RegisterBenchmark(("scalar/" + label).c_str(), BM_Scalar<Case, K>, label)
      ->MinTime(1.0);
  benchmark::RegisterBenchmark(("batch/" + label).c_str(), BM_Batch<Case, K>, label)
      ->MinTime(1.0);
}

}  // namespace

int main(int argc, char** argv) {
  add<Chain10Case, chain10::Kernels>("chain10/bundled");
  add<Chain10Case, bench_chain10_avx2::Kernels>("chain10/avx2");
  add<Chain10Case, bench_chain10_avx2_libmvec::Kernels>("chain10/avx2_libmvec");
  add<ClosedChain5Case, closed_chain5::Kernels>("closed_chain5/bundled");
  add<ClosedChain5Case, bench_closed_chain5_avx2::Kernels>("closed_chain5/avx2");
  add<ClosedChain5Case, bench_closed_chain5_avx2_libmvec::Kernels>(
      "closed_chain5/avx2_libmvec");
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
