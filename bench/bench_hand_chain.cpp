// The hand-derived floor: forward dynamics of eom::models::UndampedChain<N>
// (m = l = 1, I = 1/12, g = 9.81), generated against hand-derived (bench/hand_chain.hpp), in one
// binary with the same flags (-O3 -march=native; the generated libraries are compiled with them).
//
//   hand_chain/<N>/generated_free    the default: p passed at each call
//   hand_chain/<N>/generated_fixed   every parameter in FIXED_PARAMETERS (constants in the code)
//   hand_chain/<N>/generated_*_libmvec  the same two compiled with EOM_LIBMVEC (the angles' sin
//                                    and cos from glibc's vector math library)
//   hand_chain/<N>/hand              hand-derived, the parameter-only products a_jk and −g bⱼ
//                                    prepared once per parameter set (outside the timing)
//   hand_chain/<N>/hand_per_call     hand-derived, those products computed at every call too
//   hand_chain/<N>/hand_rows         hand-derived and prepared like hand, solved by the in-place
//                                    row-contiguous Cholesky (forward_dynamics_rows): the floor
//
// Each iteration evaluates the same 64 random states (θ uniform in [−π, π], θ̇ in [−2, 2], fixed
// seed); ns per state = CPU time per iteration / 64. Every call goes through a function the
// compiler cannot inline into the loop, the hand-derived ones included. Before timing, the seven
// are compared on the 64 states (max |Δq̈| / max |q̈|); the run aborts above 1e-10, and the
// largest difference is reported as the counter max_rel_diff. The counter operations is the
// hand-derived code's count (hand_chain.hpp); the generated one is in the emitted source.
// N = 2, 5, 10; also 20 and 50 when built with EOM_BENCH_HAND_CHAINS (bench/hand_chain.py).
// With --paired instead: per N, generated_fixed against hand_rows and against generated_free in
// alternating rounds (bench/paired_timing.hpp: the median of per-round ratios, robust to load).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <random>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <benchmark/benchmark.h>

#include <hand_chain.hpp>
#include <paired_timing.hpp>
#include <models/chain.hpp>

#include <hand_chain10_fixed.hpp>
#include <hand_chain10_free.hpp>
#include <hand_chain10_fixed_libmvec.hpp>
#include <hand_chain10_free_libmvec.hpp>
#include <hand_chain2_fixed.hpp>
#include <hand_chain2_free.hpp>
#include <hand_chain2_fixed_libmvec.hpp>
#include <hand_chain2_free_libmvec.hpp>
#include <hand_chain5_fixed.hpp>
#include <hand_chain5_free.hpp>
#include <hand_chain5_fixed_libmvec.hpp>
#include <hand_chain5_free_libmvec.hpp>
#if EOM_BENCH_HAND_CHAINS
#include <hand_chain20_fixed.hpp>
#include <hand_chain20_free.hpp>
#include <hand_chain20_fixed_libmvec.hpp>
#include <hand_chain20_free_libmvec.hpp>
#include <hand_chain50_fixed.hpp>
#include <hand_chain50_free.hpp>
#include <hand_chain50_fixed_libmvec.hpp>
#include <hand_chain50_free_libmvec.hpp>
#endif

namespace {

constexpr int kStates = 64;
std::vector<std::function<void()>> paired_runs;  // --paired

template <int N> struct Pool {
  std::array<std::array<double, N>, kStates> q, qd, qdd;
  Pool() {
    std::mt19937_64 rng(20261124 + N);
    std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi), rate(-2, 2);
    for (int s = 0; s < kStates; ++s)
      for (int i = 0; i < N; ++i) q[s][i] = angle(rng), qd[s][i] = rate(rng);
  }
};

// The hand-derived code behind a call boundary, like the generated kernels in their libraries.
template <int N>
[[gnu::noinline]] void hand_prepared(const double* q, const double* qd,
                                     const hand_chain::Coefficients<N>& k, double* qdd) {
  hand_chain::forward_dynamics<N>(q, qd, k, qdd);
}
template <int N>
[[gnu::noinline]] void hand_rows(const double* q, const double* qd,
                                 const hand_chain::Coefficients<N>& k, double* qdd) {
  hand_chain::forward_dynamics_rows<N>(q, qd, k, qdd);
}
template <int N>
[[gnu::noinline]] void hand_per_call(const double* q, const double* qd, const double* p,
                                     double* qdd) {
  hand_chain::forward_dynamics<N>(q, qd, p, qdd);
}

// A generated forward_dynamics over the pool (the fixed forms take no parameters: np = 0).
template <class K, int N> void generated(Pool<N>& x) {
  const double* p = K::np > 0 ? eom::models::UndampedChain<N>::parameter_values.data() : nullptr;
  for (int s = 0; s < kStates; ++s)
    K::forward_dynamics(0.0, x.q[s].data(), x.qd[s].data(), nullptr, p, x.qdd[s].data());
}

template <int N> double difference(const Pool<N>& a, const Pool<N>& b) {
  double diff = 0, size = 0;
  for (int s = 0; s < kStates; ++s)
    for (int i = 0; i < N; ++i) {
      diff = std::max(diff, std::abs(a.qdd[s][i] - b.qdd[s][i]));
      size = std::max(size, std::abs(b.qdd[s][i]));
    }
  return std::isfinite(diff) ? diff / size : INFINITY;
}

template <int N, class Free, class Fixed, class FreeV, class FixedV> void register_chain() {
  using Model = eom::models::UndampedChain<N>;
  static_assert(Free::np == 4 * N + 1 && Fixed::np == 0 && FreeV::np == Free::np && FixedV::np == 0);
  static const Pool<N> pool;
  static const auto& p = Model::parameter_values;
  static hand_chain::Coefficients<N> k;
  hand_chain::prepare<N>(p.data(), k);

  // The seven routes, each over the whole pool.
  const auto generated_free = generated<Free, N>;
  const auto generated_fixed = generated<Fixed, N>;
  const auto free_libmvec = generated<FreeV, N>;
  const auto fixed_libmvec = generated<FixedV, N>;
  const auto hand = [](Pool<N>& x) {
    for (int s = 0; s < kStates; ++s)
      hand_prepared<N>(x.q[s].data(), x.qd[s].data(), k, x.qdd[s].data());
  };
  const auto rows = [](Pool<N>& x) {
    for (int s = 0; s < kStates; ++s)
      hand_rows<N>(x.q[s].data(), x.qd[s].data(), k, x.qdd[s].data());
  };
  const auto per_call = [](Pool<N>& x) {
    for (int s = 0; s < kStates; ++s)
      hand_per_call<N>(x.q[s].data(), x.qd[s].data(), p.data(), x.qdd[s].data());
  };

  // Equal work: all seven give the same q̈ (tests/hand_chain checks it more widely for N ≤ 10).
  Pool<N> reference = pool, other = pool;
  generated_free(reference);
  double worst = 0;
  for (const auto& route : {+generated_fixed, +free_libmvec, +fixed_libmvec, +hand, +rows, +per_call}) {
    route(other);
    worst = std::max(worst, difference(other, reference));
  }
  if (!(worst <= 1e-10)) {
    std::fprintf(stderr, "bench_hand_chain: N = %d: the routes differ by %.1e\n", N, worst);
    std::exit(1);
  }

  const auto add = [worst](const char* route, auto run, long operations) {
    const std::string name = "hand_chain/" + std::to_string(N) + "/" + route;
    benchmark::RegisterBenchmark(name.c_str(), [run, operations, worst](benchmark::State& state) {
      Pool<N> x = pool;
      for (auto _ : state) {
        run(x);
        benchmark::ClobberMemory();
      }
      state.SetItemsProcessed(state.iterations() * kStates);
      state.counters["max_rel_diff"] = worst;
      if (operations > 0) state.counters["operations"] = static_cast<double>(operations);
    });
  };
  add("generated_free", +generated_free, 0);
  add("generated_fixed", +generated_fixed, 0);
  add("generated_free_libmvec", +free_libmvec, 0);
  add("generated_fixed_libmvec", +fixed_libmvec, 0);
  add("hand", +hand, hand_chain::operations_prepared(N));
  add("hand_rows", +rows, 0);
  paired_runs.push_back([] {
    static Pool<N> x = pool;
    const auto one = [](auto kernels) {
      return [](int i) {
        const int s = i % kStates;
        const double* p = decltype(kernels)::np > 0 ? Model::parameter_values.data() : nullptr;
        decltype(kernels)::forward_dynamics(0.0, x.q[s].data(), x.qd[s].data(), nullptr, p,
                                            x.qdd[s].data());
        eombench::sink = x.qdd[s][0];
      };
    };
    const auto hand_one = [](int i) {
      const int s = i % kStates;
      hand_rows<N>(x.q[s].data(), x.qd[s].data(), k, x.qdd[s].data());
      eombench::sink = x.qdd[s][0];
    };
    const std::string n = "N = " + std::to_string(N) + ": ";
    eombench::compare((n + "generated_fixed / hand_rows").c_str(), one(Fixed{}), hand_one);
    eombench::compare((n + "generated_fixed / generated_free").c_str(), one(Fixed{}), one(Free{}));
  });
  add("hand_per_call", +per_call,
      hand_chain::operations_prepared(N) + hand_chain::operations_prepare(N));
}

}  // namespace

int main(int argc, char** argv) {
  register_chain<2, hand_chain2_free::Kernels, hand_chain2_fixed::Kernels,
                 hand_chain2_free_libmvec::Kernels, hand_chain2_fixed_libmvec::Kernels>();
  register_chain<5, hand_chain5_free::Kernels, hand_chain5_fixed::Kernels,
                 hand_chain5_free_libmvec::Kernels, hand_chain5_fixed_libmvec::Kernels>();
  register_chain<10, hand_chain10_free::Kernels, hand_chain10_fixed::Kernels,
                 hand_chain10_free_libmvec::Kernels, hand_chain10_fixed_libmvec::Kernels>();
#if EOM_BENCH_HAND_CHAINS
  register_chain<20, hand_chain20_free::Kernels, hand_chain20_fixed::Kernels,
                 hand_chain20_free_libmvec::Kernels, hand_chain20_fixed_libmvec::Kernels>();
  register_chain<50, hand_chain50_free::Kernels, hand_chain50_fixed::Kernels,
                 hand_chain50_free_libmvec::Kernels, hand_chain50_fixed_libmvec::Kernels>();
#endif
  if (argc > 1 && std::string_view(argv[1]) == "--paired") {
    for (const auto& run : paired_runs) run();
    return 0;
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
