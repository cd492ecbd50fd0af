// Integrators on the chaotic double pendulum (a1 = 2.0, a2 = 2.5 at rest, t = 0..5) over the
// generated kernels: the wall time each method needs to reach an error ≤ 1e-10 (max over the
// state) against the double-double Gragg–Bulirsch–Stoer reference.
//
// First every method is calibrated: RK4's step count and each adaptive method's tolerance
// (rtol = atol) are tightened until the error at t = 5 is ≤ 1e-10 (RK4: ×1.05 in steps, the
// adaptive ones: ×10^(−1/8) in tolerance, from loose to tight; the first setting that reaches it
// is used). Then each calibrated run is a Google Benchmark (CPU time per integration, the fastest
// repetition), and a table prints the errors, steps, evaluations, times and the ratio of the
// fastest Runge–Kutta time to Jorba–Zou's. The kernels themselves are timed too (forward
// dynamics and Taylor coefficients by order), to show what a Taylor step costs.
// Run with --benchmark_repetitions=N for the fastest of N (not with report_aggregates_only: the
// table reads the individual repetitions).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include <double_pendulum.hpp>  // the generated kernels

#include <eom/integration/dopri5.hpp>
#include <eom/integration/rk4.hpp>
#include <eom/integration/taylor.hpp>
#if __has_include(<eom/integration/dop853.hpp>)
#include <eom/integration/dop853.hpp>
#define EOM_HAVE_DOP853 1
#endif

// The double-double reference state at t (bench_integrators_reference.cpp, compiled without
// floating-point contraction: qd's double-double arithmetic needs exact products and sums).
std::array<double, 4> double_pendulum_reference(const std::array<double, 4>& x0, double t);

namespace {

using K = double_pendulum::Kernels;
using State = eom::StateOf<2>;
using Scheme = eom::TaylorOptions::Scheme;
constexpr double t_end = 5.0, target = 1e-10;
constexpr State x0{2.0, 2.5, 0.0, 0.0};
const auto parameters = K::parameter_values;

struct Outcome {
  bool ok = false;
  State x{};
  long steps = 0, evaluations = 0;
};

// One method at one setting (RK4: the step count; the others: the tolerance).
struct Method {
  std::string name;
  bool fixed_step = false;
  std::function<Outcome(double)> run;
  // calibrated
  double setting = 0, error = 0;
  Outcome outcome;
  bool calibrated = false;
};

auto none = [](double, const State&) {};

std::vector<Method> methods() {
  std::vector<Method> m;
  auto add = [&m](std::string name, bool fixed_step, std::function<Outcome(double)> run) {
    Method method;
    method.name = std::move(name);
    method.fixed_step = fixed_step;
    method.run = std::move(run);
    m.push_back(std::move(method));
  };
  add("rk4", true, [](double steps) {
                 const auto r = eom::rk4<K>(0, t_end, static_cast<long>(steps), x0, nullptr,
                                            parameters.data(), none);
                 return Outcome{r.status == eom::Status::ok, r.x, r.steps, 4 * r.steps};
               });
  auto adaptive = [](auto integrate) {
    return [integrate](double tol) {
      eom::AdaptiveOptions opt;
      opt.rtol = opt.atol = tol;
      const auto r = integrate(opt);
      return Outcome{r.status == eom::Status::ok, r.x, r.accepted + r.rejected, r.evaluations};
    };
  };
  add("dopri5", false, adaptive([](const eom::AdaptiveOptions& opt) {
                 return eom::dopri5<K>(0, t_end, x0, nullptr, parameters.data(), opt, none);
               }));
#ifdef EOM_HAVE_DOP853
  add("dop853", false, adaptive([](const eom::AdaptiveOptions& opt) {
                 return eom::dop853<K>(0, t_end, x0, nullptr, parameters.data(), opt, none);
               }));
#endif
  add("taylor_paper", false, adaptive([](const eom::AdaptiveOptions& opt) {
                 return eom::taylor<K>(0, t_end, x0, nullptr, parameters.data(), opt,
                                       {Scheme::paper, 0}, none);
               }));
  add("taylor_jorba_zou", false, adaptive([](const eom::AdaptiveOptions& opt) {
                 return eom::taylor<K>(0, t_end, x0, nullptr, parameters.data(), opt,
                                       {Scheme::jorba_zou, 0}, none);
               }));
  // The Jorba–Zou step rule at given orders (not the tolerance's): the order that is cheapest
  // for this kernel's cost per order.
  for (int order : {8, 10, 12, 16, 20})
    add("taylor_order_" + std::to_string(order), false, adaptive([order](const eom::AdaptiveOptions& opt) {
          return eom::taylor<K>(0, t_end, x0, nullptr, parameters.data(), opt,
                                {Scheme::jorba_zou, order}, none);
        }));
  return m;
}

double max_error(const State& a, const State& b) {
  double e = 0;
  for (int i = 0; i < 4; ++i) e = std::max(e, std::abs(a[i] - b[i]));
  return e;
}

void calibrate(Method& method, const State& ref) {
  double setting = method.fixed_step ? 1000 : 1e-6;
  for (int attempt = 0; attempt < 200; ++attempt) {
    const Outcome o = method.run(setting);
    const double e = o.ok ? max_error(o.x, ref) : INFINITY;
    if (e <= target) {
      method.setting = setting, method.error = e, method.outcome = o, method.calibrated = true;
      return;
    }
    if (method.fixed_step)
      setting = std::ceil(setting * 1.05);
    else
      setting *= std::pow(10.0, -1.0 / 8);
    if (method.fixed_step ? setting > 1e7 : setting < 1e-16) break;
  }
}

// The console output as usual, plus each benchmark's fastest CPU time, for the table.
class Collector : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> best;  // name -> seconds
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      if (r.run_type != Run::RT_Iteration || r.error_occurred) continue;
      const double s = r.GetAdjustedCPUTime() / benchmark::GetTimeUnitMultiplier(r.time_unit);
      auto [it, fresh] = best.emplace(r.benchmark_name(), s);
      if (!fresh) it->second = std::min(it->second, s);
    }
  }
};

// Kernel costs: forward dynamics, and Taylor coefficients at several orders (with the
// workspace the integrator gives them).
void register_kernels() {
  benchmark::RegisterBenchmark("kernel/forward_dynamics", [](benchmark::State& s) {
    State x = x0;
    x[2] = 0.3, x[3] = -0.4;
    std::array<double, 2> qdd;
    for (auto _ : s) {
      benchmark::DoNotOptimize(K::forward_dynamics(0, x.data(), x.data() + 2, nullptr, parameters.data(), qdd.data()));
      benchmark::ClobberMemory();
    }
  })->Unit(benchmark::kNanosecond);
  for (int order : {1, 2, 5, 10, 15, 20, 25, 30}) {
    const std::string name = "kernel/taylor_coefficients/" + std::to_string(order);
    benchmark::RegisterBenchmark(name.c_str(), [order](benchmark::State& s) {
      State x = x0;
      x[2] = 0.3, x[3] = -0.4;
      std::vector<double> qk(2 * (order + 1)), qdk(2 * (order + 1));
      std::vector<double> work(static_cast<std::size_t>(K::taylor_workspace) * (order + 1));
      for (auto _ : s) {
        benchmark::DoNotOptimize(K::taylor_coefficients(order, 0, x.data(), x.data() + 2, nullptr,
                                                        parameters.data(), qk.data(), qdk.data(),
                                                        work.data()));
        benchmark::ClobberMemory();
      }
    })->Unit(benchmark::kNanosecond);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const State ref = double_pendulum_reference(x0, t_end);
  std::vector<Method> all = methods();
  for (Method& m : all) {
    calibrate(m, ref);
    if (!m.calibrated) {
      std::printf("%s: no setting reached %.0e\n", m.name.c_str(), target);
      continue;
    }
    Method* mp = &m;
    const std::string name = m.name + (m.fixed_step ? "/steps:" : "/tol:") +
                             (m.fixed_step ? std::to_string(static_cast<long>(m.setting))
                                           : [&] {
                                               char b[32];
                                               std::snprintf(b, sizeof b, "%.2e", m.setting);
                                               return std::string(b);
                                             }());
    benchmark::RegisterBenchmark(name.c_str(), [mp](benchmark::State& s) {
      for (auto _ : s) {
        const Outcome o = mp->run(mp->setting);
        benchmark::DoNotOptimize(o.x.data());
      }
    })->Unit(benchmark::kMillisecond);
  }
  register_kernels();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  Collector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);
  benchmark::Shutdown();

  std::printf("\nDouble pendulum to t = %.0f, error <= %.0e against the double-double reference "
              "(generated kernels)\n", t_end, target);
  std::printf("%-18s %12s %10s %8s %11s %10s\n", "method", "setting", "error", "steps",
              "evaluations", "time ms");
  double best_rk = INFINITY, jorba_zou = INFINITY;
  std::string best_rk_name;
  for (const Method& m : all) {
    if (!m.calibrated) continue;
    double seconds = INFINITY;
    for (const auto& [name, s] : collector.best)
      if (name.starts_with(m.name + "/")) seconds = s;
    std::printf("%-18s %12.3g %10.2e %8ld %11ld %10.3f\n", m.name.c_str(), m.setting, m.error,
                m.outcome.steps, m.outcome.evaluations, 1e3 * seconds);
    const bool runge_kutta = m.name == "rk4" || m.name == "dopri5" || m.name == "dop853";
    if (runge_kutta && seconds < best_rk) best_rk = seconds, best_rk_name = m.name;
    if (m.name == "taylor_jorba_zou") {
      jorba_zou = seconds;
      std::printf("%-18s (order %d from the tolerance)\n", "",
                  eom::detail::jorba_zou_order(m.setting, K::taylor_max_order));
    }
  }
  if (std::isfinite(best_rk) && std::isfinite(jorba_zou))
    std::printf("Jorba-Zou Taylor vs the fastest Runge-Kutta (%s): %.2fx faster\n",
                best_rk_name.c_str(), best_rk / jorba_zou);
  return 0;
}
