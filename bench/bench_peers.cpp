// The generated kernels against the peers a user would pick, for mass_matrix, coriolis
// and forward_dynamics of the bundled models and of the chain Chain<N>, N = 2, 5, 10, 20, 50:
//   generated   eomgen's kernels (out-of-line calls into the generated .cpp)
//   reference   eom::Reference<Model>: pure operator-overloading AD, inlined
//   adolc       ADOL-C: the model taped once, kernels by its drivers (bench/adolc_peer.hpp)
//   sympy       SymPy: LagrangesMethod + cse + ccode (bench/sympy_models.py), q̈ by the same
//               numerical solve as the reference (eom::linalg::solve_constrained)
// The ADOL-C and SymPy routes are compiled in when CMake found them (bench/peers.cmake).
//
// Before timing anything, every route is checked against the generated kernels on 16 random
// states (parameters too): M, c and q̈ must agree to kAgreement relative to the largest entry,
// or the benchmark refuses to run — a comparison of different mechanics would be meaningless.
// The measured differences go into the JSON output's context ("agreement/<case>/<route>").
//
// Each benchmark is one call per iteration over a pool of 64 random states; the name is
// <case>/<kernel>/<route>. bench/run_peers.sh runs this and writes docs/benchmarks/kernels.md.
#include <pthread.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include <benchmark/benchmark.h>

#include <bench_chain2.hpp>
#include <bench_chain20.hpp>
#include <bench_chain5.hpp>
#include <bench_chain50.hpp>
#include <bundled_models.hpp>  // the bundled models' generated Kernels, References, samplers

#include <eom/numeric/linalg.hpp>
#include <eom/reference/reference.hpp>

#if EOM_BENCH_ADOLC
#include "adolc_peer.hpp"
#endif

namespace {

using namespace eom_cases;

// ---- the SymPy route, where bench/peers.cmake generated it -------------------------------------

template <class Model> struct SympyOf {
  using type = void;
};

}  // namespace

#define EOM_SYMPY_FOR(MODEL, NS)                          \
  namespace {                                             \
  template <> struct SympyOf<MODEL> {                     \
    using type = NS::Functions;                           \
  };                                                      \
  }
#if EOM_BENCH_SYMPY_SPRING_PENDULUM
#include <sympy_spring_pendulum.hpp>
EOM_SYMPY_FOR(eom::models::SpringPendulum, sympy_spring_pendulum)
#endif
#if EOM_BENCH_SYMPY_CARTESIAN_PENDULUM
#include <sympy_cartesian_pendulum.hpp>
EOM_SYMPY_FOR(eom::models::CartesianPendulum, sympy_cartesian_pendulum)
#endif
#if EOM_BENCH_SYMPY_DOUBLE_PENDULUM
#include <sympy_double_pendulum.hpp>
EOM_SYMPY_FOR(eom::models::DoublePendulum, sympy_double_pendulum)
#endif
#if EOM_BENCH_SYMPY_CLOSED_CHAIN5
#include <sympy_closed_chain5.hpp>
EOM_SYMPY_FOR(eom::models::ClosedChain5, sympy_closed_chain5)
#endif
#if EOM_BENCH_SYMPY_CHAIN2
#include <sympy_chain2.hpp>
EOM_SYMPY_FOR(eom::models::Chain<2>, sympy_chain2)
#endif
#if EOM_BENCH_SYMPY_CHAIN5
#include <sympy_chain5.hpp>
EOM_SYMPY_FOR(eom::models::Chain<5>, sympy_chain5)
#endif
#if EOM_BENCH_SYMPY_CHAIN10
#include <sympy_chain10.hpp>
EOM_SYMPY_FOR(eom::models::Chain<10>, sympy_chain10)
#endif
#if EOM_BENCH_SYMPY_CHAIN20
#include <sympy_chain20.hpp>
EOM_SYMPY_FOR(eom::models::Chain<20>, sympy_chain20)
#endif
#if EOM_BENCH_SYMPY_CHAIN50
#include <sympy_chain50.hpp>
EOM_SYMPY_FOR(eom::models::Chain<50>, sympy_chain50)
#endif
#undef EOM_SYMPY_FOR

namespace {

// SymPy's functions behind the kernel signatures: q̈ from its M, forcing (and C, γ) by the
// reference's numerical solve.
template <class F> struct SympyRoute {
  static constexpr int nq = F::nq, nc = F::nc;
  static void mass_matrix(const double* q, const double* p, double* M) noexcept {
    F::mass_matrix(q, p, M);
  }
  static void coriolis(const double* q, const double* qd, const double* p, double* c) noexcept {
    F::coriolis(q, qd, p, c);
  }
  static bool forward_dynamics(double t, const double* q, const double* qd, const double*,
                               const double* p, double* qdd) noexcept {
    std::array<double, nq * nq> M;
    std::array<double, nq> f;
    std::array<double, nc * nq> C;
    std::array<double, nc> gamma;
    if constexpr (nc > 0)
      F::dynamics_terms(t, q, qd, p, M.data(), f.data(), C.data(), gamma.data());
    else
      F::dynamics_terms(t, q, qd, p, M.data(), f.data());
    if (eom::linalg::solve_constrained<double, nq, nc>(M, f, C, gamma, qdd)) return true;
    std::fill(qdd, qdd + nq, std::numeric_limits<double>::quiet_NaN());
    return false;
  }
};

// ---- the ADOL-C route ------------------------------------------------------------------------

#if EOM_BENCH_ADOLC
constexpr bool kHaveAdolc = true;
short next_tag = 1;  // three tapes per model

// One peer per case, taped (on first use) at a random state of its own seed.
template <class Case> eom_bench::AdolcPeer<typename Case::Ref::model_type>& adolc_peer() {
  static eom_bench::AdolcPeer<typename Case::Ref::model_type> peer = [] {
    const auto at = random_samples<Case>(1, 99).front();
    const short tag = next_tag;
    next_tag += 3;
    return eom_bench::AdolcPeer<typename Case::Ref::model_type>(tag, at.q.data(),
                                                                at.qd.data(), at.p.data());
  }();
  return peer;
}
template <class Case> struct AdolcRoute {
  static void mass_matrix(const double* q, const double* p, double* M) noexcept {
    adolc_peer<Case>().mass_matrix(q, p, M);
  }
  static void coriolis(const double* q, const double* qd, const double* p, double* c) noexcept {
    adolc_peer<Case>().coriolis(q, qd, p, c);
  }
  static bool forward_dynamics(double t, const double* q, const double* qd, const double* u,
                               const double* p, double* qdd) noexcept {
    return adolc_peer<Case>().forward_dynamics(t, q, qd, u, p, qdd);
  }
};
#else
constexpr bool kHaveAdolc = false;
template <class Case> struct AdolcRoute;
#endif

// ---- the chains that are not bundled ---------------------------------------------------------

template <int N, class Generated> struct ChainCase {
  using Gen = Generated;
  using Ref = eom::Reference<eom::models::Chain<N>>;
  static void sample_q(std::mt19937_64& rng, double* q) {
    std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
    for (int i = 0; i < N; ++i) q[i] = angle(rng);
  }
};

// ---- checks ----------------------------------------------------------------------------------

// Every route must reproduce the generated M, c and q̈ to this fraction of the largest entry.
// Different evaluation orders of the same exact expressions differ by a few ulps times the
// growth in the sums (and, for q̈, times the condition of M); 1e-12 leaves room for that and
// nothing else: a wrong sign, term or parameter shows up at 1e-3 or more.
constexpr double kAgreement = 1e-12;

struct Agreement {
  double M = 0, c = 0, qdd = 0;
};

double relative_difference(const double* x, const double* reference, int n) {
  double diff = 0, scale = 0;
  for (int i = 0; i < n; ++i) {
    diff = std::max(diff, std::abs(x[i] - reference[i]));
    scale = std::max(scale, std::abs(reference[i]));
  }
  return std::isfinite(diff) ? diff / std::max(scale, 1e-300) : INFINITY;
}

template <class Case, class Route> Agreement agreement() {
  constexpr int nq = Case::Ref::nq;
  Agreement worst;
  for (const auto& s : random_samples<Case>(16, 11)) {
    std::array<double, nq * nq> M, M0;
    std::array<double, nq> c, c0, a, a0;
    Case::Gen::mass_matrix(s.q.data(), s.p.data(), M0.data());
    Case::Gen::coriolis(s.q.data(), s.qd.data(), s.p.data(), c0.data());
    Case::Gen::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), a0.data());
    Route::mass_matrix(s.q.data(), s.p.data(), M.data());
    Route::coriolis(s.q.data(), s.qd.data(), s.p.data(), c.data());
    Route::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), a.data());
    worst.M = std::max(worst.M, relative_difference(M.data(), M0.data(), nq * nq));
    worst.c = std::max(worst.c, relative_difference(c.data(), c0.data(), nq));
    worst.qdd = std::max(worst.qdd, relative_difference(a.data(), a0.data(), nq));
  }
  return worst;
}

bool all_agree = true;

template <class Case, class Route> void check(const std::string& name, const char* route) {
  const Agreement a = agreement<Case, Route>();
  char text[160];
  std::snprintf(text, sizeof text, "M %.1e, c %.1e, qdd %.1e", a.M, a.c, a.qdd);
  benchmark::AddCustomContext("agreement/" + name + "/" + route, text);
  const bool ok = a.M <= kAgreement && a.c <= kAgreement && a.qdd <= kAgreement;
  std::fprintf(stderr, "bench_peers: %-20s %-9s vs generated: %s (max relative difference)%s\n",
               name.c_str(), route, text, ok ? "" : "  <-- DISAGREES");
  all_agree = all_agree && ok;
}

// ---- registration ----------------------------------------------------------------------------

constexpr std::size_t kPool = 64;  // a power of two: the index wraps with a mask

template <class Case, class Route, class Call>
void add(const std::string& name, const char* kernel, const char* route, Call call) {
  benchmark::RegisterBenchmark((name + "/" + kernel + "/" + route).c_str(),
                               [call](benchmark::State& state) {
    const auto pool = random_samples<Case>(kPool, 7);
    constexpr int nq = Case::Ref::nq;
    std::array<double, nq * nq> out{};
    std::size_t i = 0;
    for (auto _ : state) {
      call.template operator()<Route>(pool[i], out.data());
      benchmark::DoNotOptimize(out.data());
      benchmark::ClobberMemory();
      i = (i + 1) & (kPool - 1);
    }
  })->Unit(benchmark::kNanosecond);
}

template <class Case, class Route> void add_route(const std::string& name, const char* route) {
  using S = Sample<Case>;
  add<Case, Route>(name, "mass_matrix", route, []<class K>(const S& s, double* o) {
    K::mass_matrix(s.q.data(), s.p.data(), o);
  });
  add<Case, Route>(name, "coriolis", route, []<class K>(const S& s, double* o) {
    K::coriolis(s.q.data(), s.qd.data(), s.p.data(), o);
  });
  add<Case, Route>(name, "forward_dynamics", route, []<class K>(const S& s, double* o) {
    K::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), o);
  });
}

template <class Case> void add_case(const std::string& name) {
  using Model = typename Case::Ref::model_type;
  using Sympy = typename SympyOf<Model>::type;
  std::fprintf(stderr, "bench_peers: %s: checking the routes\n", name.c_str());
  check<Case, typename Case::Ref>(name, "reference");
  add_route<Case, typename Case::Gen>(name, "generated");
  add_route<Case, typename Case::Ref>(name, "reference");
  if constexpr (kHaveAdolc) {
    check<Case, AdolcRoute<Case>>(name, "adolc");
    add_route<Case, AdolcRoute<Case>>(name, "adolc");
#if EOM_BENCH_ADOLC
    const auto& peer = adolc_peer<Case>();
    benchmark::AddCustomContext("adolc_tape_operations/" + name,
                                "T " + std::to_string(peer.operations(0)) + ", L " +
                                    std::to_string(peer.operations(1)));
#endif
  }
  if constexpr (!std::is_void_v<Sympy>) {
    check<Case, SympyRoute<Sympy>>(name, "sympy");
    add_route<Case, SympyRoute<Sympy>>(name, "sympy");
  }
}

// Progress on stderr (case, kernel, route, elapsed), the usual table on stdout.
class Progress : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
    for (const Run& r : runs)
      if (r.run_type == Run::RT_Iteration)
        std::fprintf(stderr, "bench_peers: [%6.0f s] %-40s %12.1f ns\n", elapsed,
                     r.benchmark_name().c_str(), r.GetAdjustedCPUTime());
  }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point start_ = Clock::now();
};

struct Arguments {
  int argc;
  char** argv;
  int rc = 0;
};

void* run(void* raw) {
  auto& args = *static_cast<Arguments*>(raw);
  benchmark::Initialize(&args.argc, args.argv);
  if (benchmark::ReportUnrecognizedArguments(args.argc, args.argv)) {
    args.rc = 1;
    return nullptr;
  }
  benchmark::AddCustomContext("routes", std::string("generated reference") +
                                            (kHaveAdolc ? " adolc" : "") +
                                            " sympy(where generated)");
  add_case<SpringPendulumCase>("spring_pendulum");
  add_case<CartesianPendulumCase>("cartesian_pendulum");
  add_case<DoublePendulumCase>("double_pendulum");
  add_case<ClosedChain5Case>("closed_chain5");
  add_case<ChainCase<2, bench_chain2::Kernels>>("chain2");
  add_case<ChainCase<5, bench_chain5::Kernels>>("chain5");
  add_case<Chain10Case>("chain10");  // the bundled chain10 is Chain<10>
  add_case<ChainCase<20, bench_chain20::Kernels>>("chain20");
  add_case<ChainCase<50, bench_chain50::Kernels>>("chain50");
  if (!all_agree) {
    std::fprintf(stderr, "bench_peers: a route disagrees with the generated kernels (above); "
                         "its timings would compare different computations, so none are run\n");
    args.rc = 1;
    return nullptr;
  }
  Progress reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return nullptr;
}

}  // namespace

int main(int argc, char** argv) {
  // eom::Reference<Chain<50>> keeps its Hessian numbers (2·50 variables) on the stack: about
  // 100 MB, far above the main thread's 8 MB. Everything runs on one thread with room for it.
  Arguments args{argc, argv};
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, std::size_t{1} << 30);
  pthread_t thread;
  if (pthread_create(&thread, &attr, run, &args) != 0) {
    std::fprintf(stderr, "bench_peers: cannot start a thread with a 1 GiB stack\n");
    return 1;
  }
  pthread_join(thread, nullptr);
  pthread_attr_destroy(&attr);
  return args.rc;
}
