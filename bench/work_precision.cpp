// The work-precision study: every integrator, on the generated right-hand side of each problem,
// at a sweep of tolerances (or steps); the error reached against a double-double reference
// (eom/integration/high_precision.hpp) next to the wall time and the number of kernel evaluations. Peers a
// C++ user would otherwise pick (Boost.Odeint) run on the same generated kernels; a few methods
// also run on eom::Reference, so that the price of pure operator overloading shows on the same
// axes.
//
// Usage: eom_work_precision <output directory> [--quick] [--only <problem>]
// Writes <dir>/work_precision.csv (one row per run) and prints progress on stderr. The
// references come from bench/work_precision_reference.cpp.
// bench/plot_work_precision.py turns the CSV into the plots and tables of docs/work-precision/.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include <boost/numeric/odeint.hpp>
#include "work_precision.hpp"

#include <eom/integration/integrate.hpp>
#include <eom/reference/reference.hpp>

#include <chain10.hpp>
#include <closed_chain5.hpp>
#include <double_pendulum.hpp>
#include <spring_pendulum.hpp>

#include <models/chain.hpp>
#include <models/double_pendulum.hpp>
#include <models/spring_pendulum.hpp>

namespace {

namespace odeint = boost::numeric::odeint;
using Clock = std::chrono::steady_clock;

// One run's outcome, as written to the CSV.
struct Outcome {
  bool ok = false;
  std::string status = "ok";
  double error = 0;        // max |xᵢ − x_refᵢ| at the end time
  long evaluations = 0;    // right-hand side (forward_dynamics or Taylor) calls
  long steps = 0;
  double seconds = 0;      // wall time of one run (best of repeats)
};

// Wall time of run(): repeated until 50 ms have passed (at most 50 times), the fastest kept.
template <class F> double time_best(F&& run) {
  double best = 1e300, total = 0;
  for (int k = 0; k < 50 && total < 0.05; ++k) {
    const auto start = Clock::now();
    run();
    const double s = std::chrono::duration<double>(Clock::now() - start).count();
    best = std::min(best, s);
    total += s;
  }
  return best;
}

template <int nq> double max_error(const eom::StateOf<nq>& x, const eom::StateOf<nq>& ref) {
  double e = 0;
  for (int i = 0; i < 2 * nq; ++i) e = std::max(e, std::abs(x[i] - ref[i]));
  return std::isfinite(e) ? e : std::numeric_limits<double>::infinity();
}

// A problem: a model's generated kernels K, its Reference R, start, end time and parameters, the
// stabilization explicit methods use, and the double-double reference state at t1.
template <class K, class Model> struct Problem {
  static constexpr int nq = K::nq;
  std::string name;
  eom::StateOf<nq> x0{};
  double t1 = 0;
  std::array<double, K::np> p = K::parameter_values;
  eom::Stabilization stabilization{};
  eom::StateOf<nq> reference{};

  ReferenceModel reference_model{};

  void compute_reference() {
    const auto start = Clock::now();
    double diff = 0;
    const auto x = reference_state(reference_model, std::vector<double>(x0.begin(), x0.end()),
                                   std::vector<double>(p.begin(), p.end()), t1, &diff);
    if (x.size() != reference.size()) {
      std::fprintf(stderr, "eom_work_precision: no reference for %s\n", name.c_str());
      std::exit(1);
    }
    std::copy(x.begin(), x.end(), reference.begin());
    std::fprintf(stderr, "  reference %s: self-difference %.1e (%.1f s)\n", name.c_str(), diff,
                 std::chrono::duration<double>(Clock::now() - start).count());
  }
};

struct Row {
  std::string problem, method, kernels, setting;
  double parameter = 0;
  Outcome outcome;
};

class Study {
 public:
  Study(std::FILE* csv, bool quick) : csv_(csv), quick_(quick) {
    std::fprintf(csv_, "problem,method,kernels,setting,parameter,status,error,seconds,evaluations,steps\n");
  }

  std::vector<double> tolerances() const {
    std::vector<double> t;
    for (int k = 3; k <= 13; k += quick_ ? 2 : 1) t.push_back(std::pow(10.0, -k));
    return t;
  }
  std::vector<long> step_counts(long first, int doublings) const {
    std::vector<long> n;
    for (int k = 0; k < doublings; k += quick_ ? 2 : 1) n.push_back(first << k);
    return n;
  }

  void record(Row row) {
    ++done_;
    const auto& o = row.outcome;
    std::fprintf(stderr, "[%3d] %-16s %-22s %-9s %s=%-9.3g %-8s err %.2e  %.3e s  %ld evals\n", done_,
                 row.problem.c_str(), row.method.c_str(), row.kernels.c_str(), row.setting.c_str(),
                 row.parameter, o.status.c_str(), o.error, o.seconds, o.evaluations);
    std::fprintf(csv_, "%s,%s,%s,%s,%.6g,%s,%.6e,%.6e,%ld,%ld\n", row.problem.c_str(), row.method.c_str(),
                 row.kernels.c_str(), row.setting.c_str(), row.parameter, o.status.c_str(), o.error,
                 o.seconds, o.evaluations, o.steps);
    std::fflush(csv_);
  }

  // eom::integrate with one method over kernels KK (generated or Reference).
  template <class KK, class K, class Model>
  void eom_method(const Problem<K, Model>& pb, eom::Method method, const char* kernels) {
    const bool fixed = eom::is_fixed_step(method);
    std::vector<double> sweep;
    if (fixed)
      for (long n : step_counts(pb.t1 >= 10 ? 1000 : 250, 8)) sweep.push_back(static_cast<double>(n));
    else
      sweep = tolerances();
    for (double s : sweep) {
      eom::IntegrationOptions opt;
      opt.method = method;
      opt.stabilization = pb.stabilization;
      if (fixed)
        opt.step = pb.t1 / s;
      else
        opt.rtol = opt.atol = s;
      if (method == eom::Method::variational) opt.stabilization = {};  // it keeps constraints itself
      eom::IntegrationResult<K::nq> r;
      Outcome o;
      o.seconds = time_best([&] { r = eom::integrate<KK>(0.0, pb.t1, pb.x0, nullptr, pb.p.data(), opt); });
      o.ok = r.status == eom::Status::ok;
      o.status = o.ok ? "ok" : eom::to_string(r.status);
      o.error = o.ok ? max_error<K::nq>(r.x, pb.reference) : std::numeric_limits<double>::infinity();
      o.evaluations = r.evaluations;
      o.steps = r.accepted + r.rejected;
      record({pb.name, eom::to_string(method), kernels, fixed ? "steps" : "tol", s, o});
      // A slow reference-kernel sweep stops once a run takes over 2 s: the trend is clear.
      if (o.seconds > 2.0) break;
    }
  }

  // Boost.Odeint steppers on the same generated right-hand side (unconstrained problems).
  template <class K, class Model, class Stepper>
  void odeint_method(const Problem<K, Model>& pb, const char* name, Stepper make) {
    using State = eom::StateOf<K::nq>;
    for (double tol : tolerances()) {
      long evaluations = 0;
      bool failed = false;
      auto rhs = [&](const State& x, State& dx, double t) {
        ++evaluations;
        if (!eom::state_derivative<K>(t, x, nullptr, pb.p.data(), dx, pb.stabilization)) failed = true;
      };
      State x;
      std::size_t steps = 0;
      Outcome o;
      o.seconds = time_best([&] {
        x = pb.x0;
        evaluations = 0;
        steps = make(tol, rhs, x, pb.t1);
      });
      o.ok = !failed;
      o.status = failed ? "singular dynamics" : "ok";
      o.error = max_error<K::nq>(x, pb.reference);
      o.evaluations = evaluations;
      o.steps = static_cast<long>(steps);
      record({pb.name, name, "generated", "tol", tol, o});
    }
  }

 private:
  std::FILE* csv_;
  bool quick_;
  int done_ = 0;
};

// The Boost.Odeint peers, each with integrate_adaptive from 0 to t1 (ends exactly at t1).
template <class K, class Model> void odeint_peers(Study& study, const Problem<K, Model>& pb) {
  using State = eom::StateOf<K::nq>;
  study.odeint_method(pb, "odeint_dopri5", [](double tol, auto& rhs, State& x, double t1) {
    return odeint::integrate_adaptive(odeint::make_controlled(tol, tol, odeint::runge_kutta_dopri5<State>()),
                                      rhs, x, 0.0, t1, 1e-3);
  });
  study.odeint_method(pb, "odeint_fehlberg78", [](double tol, auto& rhs, State& x, double t1) {
    return odeint::integrate_adaptive(
        odeint::make_controlled(tol, tol, odeint::runge_kutta_fehlberg78<State>()), rhs, x, 0.0, t1, 1e-3);
  });
  study.odeint_method(pb, "odeint_bulirsch_stoer", [](double tol, auto& rhs, State& x, double t1) {
    return odeint::integrate_adaptive(odeint::bulirsch_stoer<State>(tol, tol), rhs, x, 0.0, t1, 1e-3);
  });
}

template <class K, class Model> void all_methods(Study& study, Problem<K, Model> pb, bool with_reference) {
  std::fprintf(stderr, "== %s (t1 = %g)\n", pb.name.c_str(), pb.t1);
  pb.compute_reference();
  for (auto m : {eom::Method::rk4, eom::Method::dopri5, eom::Method::dop853, eom::Method::taylor,
                 eom::Method::taylor_paper, eom::Method::radau5, eom::Method::variational})
    study.eom_method<K>(pb, m, "generated");
  if (with_reference)
    for (auto m : {eom::Method::rk4, eom::Method::dopri5})
      study.eom_method<eom::Reference<Model>>(pb, m, "reference");
  if constexpr (K::nc == 0) odeint_peers(study, pb);  // odeint has no projection step
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  std::string only;
  for (int i = 2; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0)
      quick = true;
    else if (std::strcmp(argv[i], "--only") == 0 && i + 1 < argc)
      only = argv[++i];
    else
      argc = 0;  // unknown option: print the usage
  }
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s <output directory> [--quick] [--only <problem>]\n", argv ? argv[0] : "");
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  std::filesystem::create_directories(dir);
  const auto path = dir / "work_precision.csv";
  std::FILE* csv = std::fopen(path.c_str(), "w");
  if (!csv) {
    std::fprintf(stderr, "eom_work_precision: cannot write %s\n", path.c_str());
    return 1;
  }
  Study study(csv, quick);
  // Runs one problem unless --only names another.
  auto run = [&](auto pb, bool with_reference) {
    if (only.empty() || pb.name == only) all_methods(study, pb, with_reference);
  };

  {
    Problem<spring_pendulum::Kernels, eom::models::SpringPendulum> pb;
    pb.name = "spring_pendulum";
    pb.reference_model = ReferenceModel::spring_pendulum;
    pb.x0 = {0.55, 0.0, 0.01, 2.5};
    pb.t1 = 10;
    run(pb, true);
  }
  for (double t1 : {5.0, 10.0}) {
    Problem<double_pendulum::Kernels, eom::models::DoublePendulum> pb;
    pb.name = t1 == 5 ? "double_pendulum_t5" : "double_pendulum_t10";
    pb.reference_model = ReferenceModel::double_pendulum;
    pb.x0 = {2.0, 2.5, 0.0, 0.0};
    pb.t1 = t1;
    run(pb, t1 == 5);
  }
  {
    // The deployment, over its first 2 s (the fast part of the unfolding).
    Problem<chain10::Kernels, eom::models::Chain<10>> pb;
    pb.name = "deployment";
    pb.reference_model = ReferenceModel::chain10;
    const double fold = 5.0 * std::numbers::pi / 180.0;
    for (int i = 0; i < 10; ++i) pb.x0[i] = i % 2 == 0 ? -fold : std::numbers::pi + fold;
    pb.x0[10] = -0.05;
    pb.t1 = 2;
    run(pb, false);
  }
  {
    Problem<closed_chain5::Kernels, eom::models::ClosedChain5> pb;
    pb.name = "closed_chain";
    pb.reference_model = ReferenceModel::closed_chain5;
    for (int i = 0; i < 5; ++i) pb.x0[i] = eom::models::ClosedChain5::initial_q[i];
    pb.t1 = 2;
    pb.stabilization.method = eom::Stabilization::Method::projection;
    run(pb, false);
  }
  {
    // Stiff: the spring pendulum with k = 1e6 N/m and a 1 g bob (spring frequency 3.2e4 rad/s
    // against a 4.4 rad/s swing), started on the slow manifold (tests/runtime/test_radau5.cpp
    // derives it) so that no fast oscillation is excited.
    Problem<spring_pendulum::Kernels, eom::models::SpringPendulum> pb;
    pb.name = "stiff_spring_pendulum";
    pb.reference_model = ReferenceModel::stiff_spring_pendulum;
    const double m = 1e-3, k = 1e6, r0 = 0.5, g = 9.81, swing = 2.5, e = m / k;
    pb.p = {m, k, r0, g};
    pb.x0 = {(r0 + e * g * (1 + 3 * e * swing * swing)) / (1 - e * swing * swing), 0.0, 0.0, swing};
    pb.t1 = 2;
    run(pb, false);
  }
  std::fclose(csv);
  std::fprintf(stderr, "wrote %s\n", path.c_str());
  return 0;
}
