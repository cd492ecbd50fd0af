// eom_bench_osc: one operational-space control step for the Franka Emika Panda's flange
// (examples/panda_osc/panda_osc.hpp, Khatib's law on a 6-D task) and its parts, side by side in
// one binary, every kernel compiled with the benchmark's flags (the model's generated source is
// compiled into it, as in eom_bench_robots):
//
//   osc/step                          the controller's torque(): every part below
//   osc/mass_matrix                   M (7×7)
//   osc/coriolis+potential_gradient   c + ∂V/∂q, the two kernels
//   osc/frame_placement               the flange's x, R
//   osc/frame_jacobian                its J (6×7, world axes)
//   osc/frame_acceleration_bias       its J̇ v
//   osc/task_space_solve              the controller's solve(): Cholesky of M, Z = L⁻¹Jᵀ,
//                                     Λ⁻¹ = ZᵀZ and its Cholesky, F, the null-space term, τ
//   osc/inverse_dynamics(q,v,0)       c + ∂V/∂q + d⊙q̇ in one call (the RNEA form the generator
//                                     keeps for inverse_dynamics)
//   osc/step_with_inverse_dynamics    the same step with c + ∂V/∂q + d⊙q̇ from that call instead
//                                     of coriolis + potential_gradient (+ d⊙q̇ by hand)
//
// The target is one full step under 2 µs. Every benchmark cycles through the same pool
// of 64 states (the ready pose plus up to ±0.4 rad per joint, rates up to ±1 rad/s, setpoints on
// the example's circle), with the URDF's parameter values. Before timing, the two routes to
// c + ∂V/∂q + d⊙q̇ must agree within 1e-10 (relative to the largest entry) and the two steps'
// torques likewise, or the run aborts. Run: build/bench/eom_bench_osc [--benchmark_repetitions=N]
// (the summary takes the median of the repetitions, else the single run).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include <bench_osc_panda.hpp>

#include "panda_osc.hpp"

namespace {

using K = bench_osc_panda::Kernels;
using Controller = panda_osc::OperationalSpace<K>;
constexpr int n = panda_osc::n;
constexpr int kPool = 64;
constexpr int flange = Controller::flange;

struct State {
  panda_osc::Vector q, qd;
  panda_osc::Setpoint ref;
  panda_osc::Terms terms;  // the kernels' terms at (q, qd), for the solve alone
};

struct Bench {
  std::vector<State> pool;
  std::array<double, K::np> p = K::parameter_values;
  Controller controller{panda_osc::Gains{}, K::parameter_values};
  // The same law, c + ∂V/∂q + d⊙q̇ taken from inverse_dynamics (which includes d⊙q̇): the solve
  // adds no damping of its own.
  Controller controller_id{panda_osc::Gains{}, K::parameter_values,
                           panda_osc::Variant{.compensate_damping = false}};
  panda_osc::Vector damping{};

  Bench() {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> offset(-0.4, 0.4), rate(-1, 1), time(0, 7);
    panda_osc::Vec3 x0;
    panda_osc::Rot R0;
    controller.placement(panda_osc::ready.data(), x0, R0);
    const auto circle = panda_osc::circle_from(x0, R0);
    pool.resize(kPool);
    for (State& s : pool) {
      for (int i = 0; i < n; ++i) s.q[i] = panda_osc::ready[i] + offset(rng), s.qd[i] = rate(rng);
      s.ref = circle.at(time(rng));
      controller.evaluate(s.q.data(), s.qd.data(), s.terms);
    }
    for (int i = 0; i < n; ++i)
      damping[i] = p[panda_osc::parameter_index<K>("panda_joint" + std::to_string(i + 1) + "_damping")];
  }

  // One step with c + ∂V/∂q + d⊙q̇ = inverse_dynamics(q, q̇, 0) at u = 0.
  bool step_with_inverse_dynamics(const State& s, double* tau) const noexcept {
    static constexpr std::array<double, n> zero{};
    panda_osc::Terms k;
    K::mass_matrix(s.q.data(), p.data(), k.M.data());
    K::inverse_dynamics(0.0, s.q.data(), s.qd.data(), zero.data(), zero.data(), p.data(), k.h.data());
    K::frame_placement(flange, s.q.data(), p.data(), k.x.data(), k.R.data());
    K::frame_jacobian(flange, s.q.data(), p.data(), k.J.data());
    K::frame_acceleration_bias(flange, s.q.data(), s.qd.data(), p.data(), k.a.data());
    return controller_id.solve(s.q.data(), s.qd.data(), s.ref, k, tau);
  }

  // Aborts unless the two routes agree on every state of the pool.
  void check() const {
    double worst_h = 0, worst_tau = 0;
    for (const State& s : pool) {
      std::array<double, n> c, g, h, tau, tau_id;
      static constexpr std::array<double, n> zero{};
      K::coriolis(s.q.data(), s.qd.data(), p.data(), c.data());
      K::potential_gradient(s.q.data(), p.data(), g.data());
      K::inverse_dynamics(0.0, s.q.data(), s.qd.data(), zero.data(), zero.data(), p.data(), h.data());
      if (!controller.torque(s.q.data(), s.qd.data(), s.ref, tau.data()) ||
          !step_with_inverse_dynamics(s, tau_id.data())) {
        std::fprintf(stderr, "bench_osc: the task-space solve failed on a pool state\n");
        std::abort();
      }
      double scale_h = 1, scale_tau = 1, dh = 0, dtau = 0;
      for (int i = 0; i < n; ++i) {
        scale_h = std::max(scale_h, std::abs(h[i]));
        scale_tau = std::max(scale_tau, std::abs(tau[i]));
        dh = std::max(dh, std::abs(c[i] + g[i] + damping[i] * s.qd[i] - h[i]));
        dtau = std::max(dtau, std::abs(tau[i] - tau_id[i]));
      }
      worst_h = std::max(worst_h, dh / scale_h);
      worst_tau = std::max(worst_tau, dtau / scale_tau);
    }
    std::printf("bench_osc: c + dV/dq + d*qd vs inverse_dynamics(q, qd, 0): %.1e; step torques: %.1e "
                "(relative, max over %d states)\n", worst_h, worst_tau, kPool);
    if (!(worst_h <= 1e-10 && worst_tau <= 1e-10)) {
      std::fprintf(stderr, "bench_osc: the two routes disagree beyond 1e-10\n");
      std::abort();
    }
  }
};

template <class Call> void add(const char* name, const Bench* b, Call call) {
  benchmark::RegisterBenchmark(name, [b, call](benchmark::State& bs) {
    std::size_t i = 0;
    for (auto _ : bs) {
      call(b->pool[i]);
      benchmark::ClobberMemory();
      i = (i + 1) & (kPool - 1);
    }
  })->Unit(benchmark::kNanosecond);
}

class Collector : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> median, single;
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      if (r.error_occurred) continue;
      const std::string name = r.run_name.str();
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name == "median")
        median[name] = r.GetAdjustedCPUTime();
      if (r.run_type == Run::RT_Iteration && !single.count(name)) single[name] = r.GetAdjustedCPUTime();
    }
  }
  double ns(const std::string& name) const {
    if (auto it = median.find(name); it != median.end()) return it->second;
    if (auto it = single.find(name); it != single.end()) return it->second;
    return std::numeric_limits<double>::quiet_NaN();
  }
};

}  // namespace

int main(int argc, char** argv) {
  static const Bench b;
  b.check();
  const double* p = b.p.data();
  static std::array<double, n * n> M;
  static std::array<double, n> c, g, tau;
  static std::array<double, 6 * n> J;
  static std::array<double, 6> a;
  static std::array<double, 3> x;
  static std::array<double, 9> R;
  static constexpr std::array<double, n> zero{};
  add("osc/step", &b, [](const State& s) {
    b.controller.torque(s.q.data(), s.qd.data(), s.ref, tau.data());
    benchmark::DoNotOptimize(tau);
  });
  add("osc/mass_matrix", &b, [p](const State& s) {
    K::mass_matrix(s.q.data(), p, M.data());
    benchmark::DoNotOptimize(M);
  });
  add("osc/coriolis+potential_gradient", &b, [p](const State& s) {
    K::coriolis(s.q.data(), s.qd.data(), p, c.data());
    K::potential_gradient(s.q.data(), p, g.data());
    benchmark::DoNotOptimize(c);
    benchmark::DoNotOptimize(g);
  });
  add("osc/frame_placement", &b, [p](const State& s) {
    K::frame_placement(flange, s.q.data(), p, x.data(), R.data());
    benchmark::DoNotOptimize(x);
    benchmark::DoNotOptimize(R);
  });
  add("osc/frame_jacobian", &b, [p](const State& s) {
    K::frame_jacobian(flange, s.q.data(), p, J.data());
    benchmark::DoNotOptimize(J);
  });
  add("osc/frame_acceleration_bias", &b, [p](const State& s) {
    K::frame_acceleration_bias(flange, s.q.data(), s.qd.data(), p, a.data());
    benchmark::DoNotOptimize(a);
  });
  add("osc/task_space_solve", &b, [](const State& s) {
    b.controller.solve(s.q.data(), s.qd.data(), s.ref, s.terms, tau.data());
    benchmark::DoNotOptimize(tau);
  });
  add("osc/inverse_dynamics(q,v,0)", &b, [p](const State& s) {
    K::inverse_dynamics(0.0, s.q.data(), s.qd.data(), zero.data(), zero.data(), p, c.data());
    benchmark::DoNotOptimize(c);
  });
  add("osc/step_with_inverse_dynamics", &b, [](const State& s) {
    b.step_with_inverse_dynamics(s, tau.data());
    benchmark::DoNotOptimize(tau);
  });

  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  Collector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);
  benchmark::Shutdown();

  auto ns = [&](const char* name) { return collector.ns(std::string("osc/") + name); };
  const double parts = ns("mass_matrix") + ns("coriolis+potential_gradient") + ns("frame_placement") +
                       ns("frame_jacobian") + ns("frame_acceleration_bias") + ns("task_space_solve");
  const double parts_id = parts - ns("coriolis+potential_gradient") + ns("inverse_dynamics(q,v,0)");
  std::printf("\nOSC control step of the Panda (CPU ns per call, %s):\n",
              collector.median.empty() ? "one run" : "median of the repetitions");
  for (const char* part : {"mass_matrix", "coriolis+potential_gradient", "frame_placement",
                           "frame_jacobian", "frame_acceleration_bias", "task_space_solve"})
    std::printf("  %-34s %9.1f\n", part, ns(part));
  std::printf("  %-34s %9.1f   (sum of the parts %.1f)\n", "step", ns("step"), parts);
  std::printf("  %-34s %9.1f   (sum of its parts %.1f; inverse_dynamics(q,v,0) %.1f)\n",
              "step_with_inverse_dynamics", ns("step_with_inverse_dynamics"), parts_id,
              ns("inverse_dynamics(q,v,0)"));
  std::printf("  target: one step under 2000 ns: step %s, step_with_inverse_dynamics %s\n",
              ns("step") < 2000 ? "met" : "NOT met",
              ns("step_with_inverse_dynamics") < 2000 ? "met" : "NOT met");
  return 0;
}
