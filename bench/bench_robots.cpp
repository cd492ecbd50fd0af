// The robot benchmark: robots imported from URDF, the generated kernels against
// the recursive algorithms a rigid-body library runs (Featherstone's CRBA, RNEA and ABA, as in
// Pinocchio or RBDL: tests/support/recursive_dynamics.hpp, built from the same URDF file) and
// against eom::Reference (run-time AD on the model header the URDF import wrote).
//
//   <robot>/<kernel>/<route>     route = generated | recursive | reference
//
// Robots: the Franka Emika Panda and the UR5 (models/robots), and, when built with
// EOM_BENCH_ROBOT_CHAINS, the planar chains of N = 2, 5, 10, 20, 30 slender links
// (bench/robots/chain<N>.urdf, written by bench/robots/make_chains.py).
//
// Kernels and their recursive counterparts:
//   mass_matrix                   CRBA
//   forward_dynamics              ABA (with the joint damping Q = u − d⊙q̇, as the generated kernel)
//   inverse_dynamics              RNEA (τ = M q̈ + c + ∂V/∂q; the generated kernel also subtracts
//                                 Q = u − d⊙q̇: n multiply-adds more)
//   forward_dynamics_derivatives  forward differences of the ABA over q and q̇: 2n + 1 ABA calls
//                                 (the baseline). The generated kernel returns ∂q̈/∂u = M⁻¹
//                                 as well, which the baseline does not compute.
//
// Every route runs on the same pool of 64 random states (one call per iteration, cycling), with
// the URDF's parameter values. Before any timing, every route is checked against the others on all
// 64 states (max-abs difference / max(1, max-abs reference)); the run aborts when the generated
// kernel and the recursive algorithm or eom::Reference differ by more than 1e-8, or the forward
// differences from the exact derivatives by more than 1e-4 (their truncation and rounding errors:
// 1e-7 to 1e-5).
//
// After the run it prints, per robot and kernel, the CPU ns per call of each route (the median
// over --benchmark_repetitions, else the single run) and the ratios generated / recursive and
// generated / Reference. bench/robots.sh runs it and writes docs/benchmarks/robots.md.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include <panda.hpp>
#include <panda_model.hpp>
#include <ur5.hpp>
#include <ur5_model.hpp>
#if EOM_BENCH_ROBOT_CHAINS
#include <robot_chain10.hpp>
#include <robot_chain10_model.hpp>
#include <robot_chain2.hpp>
#include <robot_chain20.hpp>
#include <robot_chain20_model.hpp>
#include <robot_chain2_model.hpp>
#include <robot_chain30.hpp>
#include <robot_chain30_model.hpp>
#include <robot_chain5.hpp>
#include <robot_chain5_model.hpp>
#endif

#include <eom/reference/reference.hpp>
#include <eomgen/urdf.hpp>
#include <recursive_dynamics.hpp>
#include <thread_stack.hpp>

namespace {

constexpr std::size_t kPool = 64;  // a power of two: the index wraps with a mask
constexpr double kTolerance = 1e-8;
constexpr double kFiniteDifferenceTolerance = 1e-4;

using Recursive = eomtest::RecursiveDynamics<double>;

template <int n> struct State { std::array<double, n> q, qd, u, qdd; };

template <int n> std::vector<State<n>> random_states(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> angle(-3.0, 3.0), rate(-2.0, 2.0), torque(-10.0, 10.0);
  std::vector<State<n>> pool(kPool);
  for (auto& s : pool)
    for (int i = 0; i < n; ++i)
      s.q[i] = angle(rng), s.qd[i] = rate(rng), s.u[i] = torque(rng), s.qdd[i] = rate(rng);
  return pool;
}

// ∂q̈/∂q and ∂q̈/∂q̇ (n×n, column-major) by forward differences of the ABA: 2n + 1 calls. Steps
// √ε·max(1, |x|), rounded so that x + h − x = h exactly. No allocation (the scratch is given).
template <int n> struct DifferenceScratch { std::array<double, n> x, f0, f; };
template <int n> void aba_differences(Recursive& rd, const State<n>& s, DifferenceScratch<n>& w,
                                      double* dq, double* dqd) {
  static const double root_eps = std::sqrt(std::numeric_limits<double>::epsilon());
  rd.forward_dynamics(s.q, s.qd, s.u, w.f0);
  for (int which = 0; which < 2; ++which) {
    const std::array<double, n>& base = which == 0 ? s.q : s.qd;
    double* out = which == 0 ? dq : dqd;
    w.x = base;
    for (int j = 0; j < n; ++j) {
      const double xh = base[j] + root_eps * std::max(1.0, std::abs(base[j]));
      const double h = xh - base[j];
      w.x[j] = xh;
      if (which == 0)
        rd.forward_dynamics(w.x, s.qd, s.u, w.f);
      else
        rd.forward_dynamics(s.q, w.x, s.u, w.f);
      w.x[j] = base[j];
      for (int i = 0; i < n; ++i) out[i + n * j] = (w.f[i] - w.f0[i]) / h;
    }
  }
}

// The largest chain whose derivatives eom::Reference computes here: its nested AD numbers on the
// stack need more than 1 GB at 20 links and grow about as n³, so about 3.4 times that at 30,
// near the 4 GB stack main() gives them (not tried; there the generated derivatives are checked
// against the ABA's differences only).
constexpr int reference_derivatives_max = 20;

// Whether the generated set has forward_dynamics_derivatives (add_eom_model KERNELS). By a call,
// not by taking its address: a kernel with a workspace overload has two.
template <class Gen> constexpr bool has_derivatives = requires(const double* x, double* y) {
  Gen::forward_dynamics_derivatives(0.0, x, x, x, x, y, y, y);
};

// ---- agreement, checked before timing --------------------------------------------------------

double relative_difference(const double* got, const double* expected, int size) {
  double diff = 0, scale = 1;
  for (int i = 0; i < size; ++i) {
    diff = std::max(diff, std::abs(got[i] - expected[i]));
    scale = std::max(scale, std::abs(expected[i]));
  }
  return std::isfinite(diff) ? diff / scale : std::numeric_limits<double>::infinity();
}

struct Agreement {
  const char* robot;
  std::map<std::string, double> worst;  // "<kernel>: <a> vs <b>" -> worst relative difference
  void add(const std::string& what, double value) { worst[what] = std::max(worst[what], value); }
  void report_or_abort() const {
    bool ok = true;
    for (const auto& [what, value] : worst) {
      const double limit =
          what.find("differences") != std::string::npos ? kFiniteDifferenceTolerance : kTolerance;
      std::printf("agreement %-8s %-62s %.1e%s\n", robot, what.c_str(), value,
                  value <= limit ? "" : "   ** TOO LARGE **");
      ok = ok && value <= limit;
    }
    if (!ok) {
      std::fprintf(stderr, "bench_robots: %s: the routes disagree; nothing is timed\n", robot);
      std::abort();
    }
  }
};

template <class Gen, class Ref, int n> void check_agreement(const char* robot, Recursive& rd,
                                                            const std::vector<State<n>>& pool,
                                                            const double* p) {
  Agreement a{robot, {}};
  std::vector<double> g(3 * n * n), r(3 * n * n), x(2 * n * n);
  [[maybe_unused]] DifferenceScratch<n> w;
  for (const State<n>& s : pool) {
    Gen::mass_matrix(s.q.data(), p, g.data());
    rd.mass_matrix(s.q, std::span(r.data(), n * n));
    a.add("mass_matrix: generated vs CRBA", relative_difference(g.data(), r.data(), n * n));
    Ref::mass_matrix(s.q.data(), p, r.data());
    a.add("mass_matrix: generated vs Reference", relative_difference(g.data(), r.data(), n * n));

    if (!Gen::forward_dynamics(0.0, s.q.data(), s.qd.data(), s.u.data(), p, g.data()))
      a.add("forward_dynamics: generated failed", std::numeric_limits<double>::infinity());
    rd.forward_dynamics(s.q, s.qd, s.u, std::span(r.data(), n));
    a.add("forward_dynamics: generated vs ABA", relative_difference(g.data(), r.data(), n));
    Ref::forward_dynamics(0.0, s.q.data(), s.qd.data(), s.u.data(), p, r.data());
    a.add("forward_dynamics: generated vs Reference", relative_difference(g.data(), r.data(), n));

    Gen::inverse_dynamics(0.0, s.q.data(), s.qd.data(), s.qdd.data(), s.u.data(), p, g.data());
    rd.inverse_dynamics(s.q, s.qd, s.qdd, std::span(r.data(), n));
    for (int i = 0; i < n; ++i) r[i] -= s.u[i] - rd.damping()[i] * s.qd[i];  // − Q
    a.add("inverse_dynamics: generated vs RNEA - Q", relative_difference(g.data(), r.data(), n));
    Ref::inverse_dynamics(0.0, s.q.data(), s.qd.data(), s.qdd.data(), s.u.data(), p, r.data());
    a.add("inverse_dynamics: generated vs Reference", relative_difference(g.data(), r.data(), n));

    if constexpr (has_derivatives<Gen>) {
      double* gq = g.data();
      double* gqd = gq + n * n;
      double* gu = gqd + n * n;
      if (!Gen::forward_dynamics_derivatives(0.0, s.q.data(), s.qd.data(), s.u.data(), p, gq, gqd,
                                             gu))
        a.add("forward_dynamics_derivatives: generated failed",
              std::numeric_limits<double>::infinity());
      if constexpr (n <= reference_derivatives_max) {
        Ref::forward_dynamics_derivatives(0.0, s.q.data(), s.qd.data(), s.u.data(), p, r.data(),
                                          r.data() + n * n, r.data() + 2 * n * n);
        a.add("forward_dynamics_derivatives: generated vs Reference (q, qd, u)",
              relative_difference(g.data(), r.data(), 3 * n * n));
      }
      aba_differences<n>(rd, s, w, x.data(), x.data() + n * n);
      a.add("forward_dynamics_derivatives: ABA differences vs generated (q, qd)",
            relative_difference(x.data(), g.data(), 2 * n * n));
    }
  }
  a.report_or_abort();
}

// ---- timing ------------------------------------------------------------------------------------

template <int n, class Call>
void time_calls(benchmark::State& bs, const std::vector<State<n>>& pool, Call call) {
  std::size_t i = 0;
  for (auto _ : bs) {
    call(pool[i]);
    benchmark::ClobberMemory();
    i = (i + 1) & (kPool - 1);
  }
}

template <int n, class Call>
void add(const std::string& name, std::shared_ptr<const std::vector<State<n>>> pool, Call call) {
  benchmark::RegisterBenchmark(name.c_str(), [pool, call](benchmark::State& bs) mutable {
    time_calls<n>(bs, *pool, call);
  })->Unit(benchmark::kNanosecond);
}

template <class Gen, class Ref, int n>
void add_derivatives(const std::string& base, std::shared_ptr<Recursive> rd,
                     std::shared_ptr<const std::vector<State<n>>> pool,
                     std::shared_ptr<const std::array<double, Gen::np>> p);

// Gen: the generated Kernels; Model: the URDF import's model class (for eom::Reference).
template <class Gen, class Model> void add_robot(const char* robot, const std::string& urdf_file) {
  using Ref = eom::Reference<Model>;
  constexpr int n = Gen::nq;
  static_assert(Ref::nq == n && Gen::nu == n && Ref::np == Gen::np);
  if (Gen::parameter_values != Ref::parameter_values) {
    std::fprintf(stderr, "bench_robots: %s: generated and Reference parameters differ\n", robot);
    std::abort();
  }
  // The recursive model is built from the file (its own parameters: the URDF's numbers, which
  // the generated parameter_values also are; check_agreement confirms it).
  auto rd = std::make_shared<Recursive>(eom::urdf::read(urdf_file));
  if (rd->nq() != n) {
    std::fprintf(stderr, "bench_robots: %s: %d coordinates in the file, %d generated\n", robot,
                 rd->nq(), n);
    std::abort();
  }
  auto pool = std::make_shared<const std::vector<State<n>>>(random_states<n>(7));
  auto p = std::make_shared<const std::array<double, Gen::np>>(Gen::parameter_values);
  check_agreement<Gen, Ref, n>(robot, *rd, *pool, p->data());

  using S = State<n>;
  const std::string base = robot;
  // mass_matrix
  add<n>(base + "/mass_matrix/generated", pool,
         [p, M = std::array<double, n * n>{}](const S& s) mutable {
           Gen::mass_matrix(s.q.data(), p->data(), M.data());
           benchmark::DoNotOptimize(M.data());
         });
  add<n>(base + "/mass_matrix/recursive", pool,
         [rd, M = std::array<double, n * n>{}](const S& s) mutable {
           rd->mass_matrix(s.q, M);
           benchmark::DoNotOptimize(M.data());
         });
  add<n>(base + "/mass_matrix/reference", pool,
         [p, M = std::array<double, n * n>{}](const S& s) mutable {
           Ref::mass_matrix(s.q.data(), p->data(), M.data());
           benchmark::DoNotOptimize(M.data());
         });
  // forward_dynamics
  add<n>(base + "/forward_dynamics/generated", pool,
         [p, a = std::array<double, n>{}](const S& s) mutable {
           benchmark::DoNotOptimize(Gen::forward_dynamics(0.0, s.q.data(), s.qd.data(), s.u.data(),
                                                          p->data(), a.data()));
           benchmark::DoNotOptimize(a.data());
         });
  add<n>(base + "/forward_dynamics/recursive", pool,
         [rd, a = std::array<double, n>{}](const S& s) mutable {
           rd->forward_dynamics(s.q, s.qd, s.u, a);
           benchmark::DoNotOptimize(a.data());
         });
  add<n>(base + "/forward_dynamics/reference", pool,
         [p, a = std::array<double, n>{}](const S& s) mutable {
           benchmark::DoNotOptimize(Ref::forward_dynamics(0.0, s.q.data(), s.qd.data(), s.u.data(),
                                                          p->data(), a.data()));
           benchmark::DoNotOptimize(a.data());
         });
  // inverse_dynamics
  add<n>(base + "/inverse_dynamics/generated", pool,
         [p, t = std::array<double, n>{}](const S& s) mutable {
           Gen::inverse_dynamics(0.0, s.q.data(), s.qd.data(), s.qdd.data(), s.u.data(), p->data(),
                                 t.data());
           benchmark::DoNotOptimize(t.data());
         });
  add<n>(base + "/inverse_dynamics/recursive", pool,
         [rd, t = std::array<double, n>{}](const S& s) mutable {
           rd->inverse_dynamics(s.q, s.qd, s.qdd, t);
           benchmark::DoNotOptimize(t.data());
         });
  add<n>(base + "/inverse_dynamics/reference", pool,
         [p, t = std::array<double, n>{}](const S& s) mutable {
           Ref::inverse_dynamics(0.0, s.q.data(), s.qd.data(), s.qdd.data(), s.u.data(), p->data(),
                                 t.data());
           benchmark::DoNotOptimize(t.data());
         });
  if constexpr (has_derivatives<Gen>) add_derivatives<Gen, Ref, n>(base, rd, pool, p);
}

template <class Gen, class Ref, int n>
void add_derivatives(const std::string& base, std::shared_ptr<Recursive> rd,
                     std::shared_ptr<const std::vector<State<n>>> pool,
                     std::shared_ptr<const std::array<double, Gen::np>> p) {
  using S = State<n>;
  using D = std::array<double, 3 * n * n>;
  add<n>(base + "/forward_dynamics_derivatives/generated", pool, [p, d = D{}](const S& s) mutable {
    benchmark::DoNotOptimize(
        Gen::forward_dynamics_derivatives(0.0, s.q.data(), s.qd.data(), s.u.data(), p->data(),
                                          d.data(), d.data() + n * n, d.data() + 2 * n * n));
    benchmark::DoNotOptimize(d.data());
  });
  add<n>(base + "/forward_dynamics_derivatives/recursive", pool,
         [rd, d = D{}, w = DifferenceScratch<n>{}](const S& s) mutable {
           aba_differences<n>(*rd, s, w, d.data(), d.data() + n * n);
           benchmark::DoNotOptimize(d.data());
         });
  if constexpr (n <= reference_derivatives_max)
    add<n>(base + "/forward_dynamics_derivatives/reference", pool, [p, d = D{}](const S& s) mutable {
      benchmark::DoNotOptimize(
          Ref::forward_dynamics_derivatives(0.0, s.q.data(), s.qd.data(), s.u.data(), p->data(),
                                            d.data(), d.data() + n * n, d.data() + 2 * n * n));
      benchmark::DoNotOptimize(d.data());
    });
}

// ---- the summary ---------------------------------------------------------------------------

// The console output as usual, plus each benchmark's CPU ns per call: the median aggregate when
// the run has repetitions, else the one run.
class Collector : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> median, single;
  std::vector<std::string> order;
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      if (r.error_occurred) continue;
      const std::string name = r.run_name.str();
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name == "median")
        median[name] = r.GetAdjustedCPUTime();
      if (r.run_type == Run::RT_Iteration && !single.count(name))
        single[name] = r.GetAdjustedCPUTime();
      if (std::find(order.begin(), order.end(), name) == order.end()) order.push_back(name);
    }
  }
  double ns(const std::string& name) const {
    if (auto it = median.find(name); it != median.end()) return it->second;
    if (auto it = single.find(name); it != single.end()) return it->second;
    return std::numeric_limits<double>::quiet_NaN();
  }
};

void print_summary(const Collector& c) {
  std::printf("\n%-42s %12s %12s %12s %9s %9s\n", "robot/kernel", "generated", "recursive",
              "Reference", "gen/rec", "gen/ref");
  for (const std::string& name : c.order) {
    const std::string suffix = "/generated";
    if (!name.ends_with(suffix)) continue;
    const std::string kernel = name.substr(0, name.size() - suffix.size());
    const double g = c.ns(name), r = c.ns(kernel + "/recursive"), f = c.ns(kernel + "/reference");
    std::printf("%-42s %12.1f %12.1f %12.1f %9.3f %9.3f\n", kernel.c_str(), g, r, f, g / r, g / f);
  }
  std::printf(
      "(CPU ns per call; %s; recursive: CRBA, ABA, RNEA, and 2n+1 ABA calls for the "
      "derivatives)\n",
      c.median.empty() ? "one run" : "median of the repetitions");
}

}  // namespace

int main(int argc, char** argv) {
  int rc = 0;
  // eom::Reference keeps its AD numbers on the stack: its derivatives of the 20-link chain need
  // more than 1 GB (the main thread has 8 MB). Everything runs on one thread with room for them
  // (address space: pages are only used as touched).
  const bool started = run_with_stack(std::size_t{1} << 32, [&] {
    // the derivative targets are measured on both arms: their kernel sets must have them
    static_assert(has_derivatives<panda::Kernels> && has_derivatives<ur5::Kernels>);
    add_robot<panda::Kernels, eom::urdf_models::panda>("panda", EOM_ROBOTS_DIR "/panda.urdf");
    add_robot<ur5::Kernels, eom::urdf_models::ur5>("ur5", EOM_ROBOTS_DIR "/ur5.urdf");
#if EOM_BENCH_ROBOT_CHAINS
    add_robot<robot_chain2::Kernels, eom::urdf_models::robot_chain2>(
        "chain2", EOM_BENCH_ROBOTS_DIR "/chain2.urdf");
    add_robot<robot_chain5::Kernels, eom::urdf_models::robot_chain5>(
        "chain5", EOM_BENCH_ROBOTS_DIR "/chain5.urdf");
    add_robot<robot_chain10::Kernels, eom::urdf_models::robot_chain10>(
        "chain10", EOM_BENCH_ROBOTS_DIR "/chain10.urdf");
    add_robot<robot_chain20::Kernels, eom::urdf_models::robot_chain20>(
        "chain20", EOM_BENCH_ROBOTS_DIR "/chain20.urdf");
    add_robot<robot_chain30::Kernels, eom::urdf_models::robot_chain30>(
        "chain30", EOM_BENCH_ROBOTS_DIR "/chain30.urdf");
#endif
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) {
      rc = 1;
      return;
    }
    Collector collector;
    benchmark::RunSpecifiedBenchmarks(&collector);
    benchmark::Shutdown();
    print_summary(collector);
  });
  if (!started) {
    std::fprintf(stderr, "bench_robots: cannot start a thread with a 1 GiB stack\n");
    return 1;
  }
  return rc;
}
