// Ensembles: many cases (initial state, parameters, inputs) of one model integrated with any
// method of eom::integrate, on one thread or on a pool of std::jthreads.
//
//   std::vector<eom::StateOf<K::nq>> x0 = ...;                // one per case
//   std::vector<double> p = ...;                               // K::np per case, or K::np shared
//   eom::EnsembleOptions opt;
//   opt.t0 = 0, opt.t1 = 10, opt.threads = 4;                  // 0: one per hardware thread
//   opt.integration.method = eom::Method::dop853;
//   opt.sample_times = times;                                  // optional dense samples
//   auto r = eom::ensemble<K>({x0, p, {}}, opt);
//   if (r.status != eom::Status::ok) ...                       // the ensemble itself is bad input
//   r.cases[c].status, r.cases[c].x, r.sample(c, k) ...        // per case, by case index
//
// Inputs are either held (EnsembleCases::u, K::nu per case or shared) or given by a callback
// (ensemble_with_inputs): inputs(case_index, t, x, u) fills u[0..nu) at t0 and, with
// opt.input_period > 0, again every input_period (zero-order hold, as a sampled controller). The
// callback runs concurrently for different cases and must not change shared state.
//
// Determinism: every case is independent (its own state, its own workspace, its results written
// by case index only), and the integrators use no global or static mutable state, so the results
// are bitwise the same for any number of threads and any order in which the threads take cases.
// Cases are handed out dynamically by an atomic counter (cases differ in cost); which thread ran
// a case does not matter. A case that fails (singular dynamics, step limit, bad initial state)
// reports its Status in its result; the other cases still complete.
//
// Bad input of the ensemble itself (sizes of x0, p, u or of the caller's result spans that do
// not match, sample times not ascending inside [t0, t1], output_times set in the integration
// options instead of sample_times, a negative input period) gives Status::invalid_argument and
// integrates nothing; no exceptions are thrown. An empty ensemble (no cases) is Status::ok with
// no results. Allocation happens only outside the per-step path: the returned vectors, one Taylor
// workspace per thread, the threads themselves.
//
// Why std::jthread and not oneTBB: the work is a flat loop of independent, coarse (milliseconds)
// tasks, which an atomic counter balances as well as a work-stealing scheduler; std::jthread keeps
// the runtime header-only with no dependency beyond the standard library (the runtime is used in
// controllers and consumer projects that should not need TBB), and joins on scope exit.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <thread>
#include <vector>

#include "eom/integrate.hpp"

namespace eom {

// The cases: x0 gives their number; p holds K::np values per case (case c at p[c·np]) or K::np
// values shared by all; u likewise with K::nu (ignored when an input callback is given). Empty p
// or u is right only when np or nu is 0.
template <int nq> struct EnsembleCases {
  std::span<const StateOf<nq>> x0{};
  std::span<const double> p{};
  std::span<const double> u{};
};

struct EnsembleOptions {
  double t0 = 0, t1 = 0;
  IntegrationOptions integration{};  // method, tolerances, step; output_times must stay empty
  // States recorded at these times (ascending, inside [t0, t1]) for every case, by dense output;
  // NaN where a case stopped before reaching them.
  std::span<const double> sample_times{};
  unsigned threads = 1;  // threads that integrate (the caller's included); 0: hardware threads
  double input_period = 0;  // with an input callback: inputs recomputed every period; 0: at t0 only
};

template <int nq> struct EnsembleResult {
  Status status = Status::ok;  // invalid_argument: the ensemble was bad input, nothing was run
  std::vector<IntegrationResult<nq>> cases;  // by case index: status, time and state reached
  std::vector<StateOf<nq>> samples;          // case-major: cases × sample_times
  std::size_t sample_count = 0;              // sample times per case
  const StateOf<nq>& sample(std::size_t c, std::size_t k) const { return samples[c * sample_count + k]; }
  std::size_t failed() const {
    return static_cast<std::size_t>(std::count_if(
        cases.begin(), cases.end(), [](const auto& r) { return r.status != Status::ok; }));
  }
};

namespace detail {

// Runs work() on `threads` threads (the caller's one of them) and joins them. If a thread cannot
// be started, the others (at least the caller) do its share: work() must take its tasks from a
// shared counter.
template <class Work> void run_on_threads(unsigned threads, Work& work) noexcept {
  std::vector<std::jthread> pool;
#if defined(__cpp_exceptions)
  try {
    pool.reserve(threads > 1 ? threads - 1 : 0);
    for (unsigned i = 1; i < threads; ++i) pool.emplace_back([&work] { work(); });
  } catch (...) {  // no memory or no more threads: fewer threads, same results
  }
#else
  pool.reserve(threads > 1 ? threads - 1 : 0);
  for (unsigned i = 1; i < threads; ++i) pool.emplace_back([&work] { work(); });
#endif
  work();
}  // the jthreads join here; their writes are visible to the caller after the join

inline unsigned thread_count(unsigned requested, std::size_t cases) noexcept {
  unsigned n = requested != 0 ? requested : std::max(1u, std::thread::hardware_concurrency());
  return static_cast<unsigned>(std::min<std::size_t>(n, std::max<std::size_t>(cases, 1)));
}

// Stands for the held inputs (EnsembleCases::u) where a callback would go.
struct HeldInputs {
  static constexpr bool held = true;
};

// True when the ensemble's description and the caller's result spans fit together.
template <Dynamics K>
bool ensemble_input_ok(const EnsembleCases<K::nq>& cases, const EnsembleOptions& opt,
                       bool input_callback, std::size_t results, std::size_t samples) noexcept {
  const std::size_t n = cases.x0.size(), np = K::np, nu = K::nu, ns = opt.sample_times.size();
  const auto fits = [n](std::size_t size, std::size_t per_case) {
    return per_case == 0 ? size == 0 : size == per_case || size == n * per_case;
  };
  bool ok = fits(cases.p.size(), np) && (input_callback || fits(cases.u.size(), nu)) &&
            results == n && samples == n * ns && opt.integration.output_times.empty() &&
            std::isfinite(opt.input_period) && opt.input_period >= 0;
  double previous = opt.t0;
  for (double t : opt.sample_times) {
    ok = ok && std::isfinite(t) && t >= previous && t <= opt.t1;
    previous = t;
  }
  return ok;
}

template <Dynamics K> std::size_t taylor_workspace_doubles(const IntegrationOptions& opt) noexcept {
  if constexpr (TaylorDynamics<K>) {
    if (opt.method == Method::taylor || opt.method == Method::taylor_paper)
      return taylor_workspace_capacity<K>;
  }
  (void)opt;
  return 0;
}

// One case: [t0, t1] in one call of integrate (held inputs, or the callback's inputs at t0), or
// in input periods with the callback's inputs held over each.
template <Dynamics K, class Inputs>
void run_case(std::size_t c, const EnsembleCases<K::nq>& cases, const EnsembleOptions& opt,
              IntegrationOptions integration, Inputs& inputs, IntegrationResult<K::nq>& result,
              std::span<StateOf<K::nq>> samples) noexcept {
  constexpr int nq = K::nq;
  constexpr std::size_t np = K::np, nu = K::nu;
  using State = StateOf<nq>;
  for (auto& s : samples) s.fill(std::numeric_limits<double>::quiet_NaN());
  const double* p = np == 0 ? nullptr : cases.p.data() + (cases.p.size() == np ? 0 : c * np);

  if constexpr (requires { Inputs::held; }) {
    (void)inputs;
    const double* u = nu == 0 ? nullptr : cases.u.data() + (cases.u.size() == nu ? 0 : c * nu);
    integration.output_times = opt.sample_times;
    std::size_t j = 0;
    result = integrate<K>(opt.t0, opt.t1, cases.x0[c], u, p, integration,
                          [&](double, const State& y) {
                            if (j < samples.size()) samples[j++] = y;
                          });
  } else {
    std::array<double, (nu > 0 ? nu : 1)> u{};
    const double* up = nu == 0 ? nullptr : u.data();
    const std::span<const double> times = opt.sample_times;
    const double period = opt.input_period;
    double t = opt.t0;
    State x = cases.x0[c];
    IntegrationResult<nq> total;
    total.t = t, total.x = x;
    std::size_t k = 0;  // next sample time
    // The number of input periods (the last may be shorter); one when no period is given.
    double segments = period > 0 ? std::ceil((opt.t1 - opt.t0) / period * (1 - 1e-12)) : 1;
    if (!(segments >= 1 && segments < 9e15)) segments = 1;  // bad span: integrate reports it
    const long count = static_cast<long>(segments);
    for (long s = 0; s < count; ++s) {
      const bool last = s + 1 == count;
      const double tb = last ? opt.t1 : std::min(opt.t1, opt.t0 + static_cast<double>(s + 1) * period);
      inputs(c, t, static_cast<const State&>(x), std::span<double>(u.data(), nu));
      // The sample times of this period: [t, tb), and tb itself in the last one.
      std::size_t end = k;
      while (end < times.size() && (times[end] < tb || (last && times[end] <= tb))) ++end;
      integration.output_times = times.subspan(k, end - k);
      std::size_t j = k;
      const auto r = integrate<K>(t, tb, x, up, p, integration, [&](double, const State& y) {
        if (j < end) samples[j++] = y;
      });
      k = end;
      total.status = r.status, total.t = r.t, total.x = r.x;
      total.accepted += r.accepted, total.rejected += r.rejected, total.evaluations += r.evaluations;
      if (r.status != Status::ok) break;
      t = tb, x = r.x;
    }
    result = total;
  }
}

// Cases [first, last) on `threads` threads, results and samples indexed from `first`.
template <Dynamics K, class Inputs>
void run_cases(std::size_t first, std::size_t last, const EnsembleCases<K::nq>& cases,
               const EnsembleOptions& opt, Inputs& inputs,
               std::span<IntegrationResult<K::nq>> results,
               std::span<StateOf<K::nq>> samples) noexcept {
  const std::size_t ns = opt.sample_times.size();
  std::atomic<std::size_t> next{first};
  auto work = [&] {
    IntegrationOptions integration = opt.integration;
    std::vector<double> workspace(taylor_workspace_doubles<K>(integration));  // this thread's own
    integration.taylor_workspace = workspace;
    for (std::size_t c; (c = next.fetch_add(1, std::memory_order_relaxed)) < last;)
      run_case<K>(c, cases, opt, integration, inputs, results[c - first],
                  samples.subspan((c - first) * ns, ns));
  };
  run_on_threads(thread_count(opt.threads, last - first), work);
}

}  // namespace detail

// Into the caller's storage: results[c] for case c, samples[c·S + k] at sample_times[k] (S sample
// times). Status::invalid_argument when the sizes do not fit (see above), else ok; each case's own
// status is in its result.
template <Dynamics K>
Status ensemble(const EnsembleCases<K::nq>& cases, const EnsembleOptions& opt,
                std::span<IntegrationResult<K::nq>> results,
                std::span<StateOf<K::nq>> samples = {}) noexcept {
  if (!detail::ensemble_input_ok<K>(cases, opt, false, results.size(), samples.size()))
    return Status::invalid_argument;
  detail::HeldInputs held;
  detail::run_cases<K>(0, cases.x0.size(), cases, opt, held, results, samples);
  return Status::ok;
}

// Inputs from a callback: inputs(std::size_t case_index, double t, const StateOf<nq>& x,
// std::span<double> u) at t0 and every opt.input_period.
template <Dynamics K, class Inputs>
Status ensemble_with_inputs(const EnsembleCases<K::nq>& cases, const EnsembleOptions& opt,
                            Inputs&& inputs, std::span<IntegrationResult<K::nq>> results,
                            std::span<StateOf<K::nq>> samples = {}) noexcept {
  if (!detail::ensemble_input_ok<K>(cases, opt, true, results.size(), samples.size()))
    return Status::invalid_argument;
  detail::run_cases<K>(0, cases.x0.size(), cases, opt, inputs, results, samples);
  return Status::ok;
}

// The same, results returned (allocated here, before any integration).
template <Dynamics K>
EnsembleResult<K::nq> ensemble(const EnsembleCases<K::nq>& cases, const EnsembleOptions& opt) {
  EnsembleResult<K::nq> r;
  r.sample_count = opt.sample_times.size();
  r.cases.resize(cases.x0.size());
  r.samples.resize(cases.x0.size() * r.sample_count);
  r.status = ensemble<K>(cases, opt, std::span(r.cases), std::span(r.samples));
  return r;
}

template <Dynamics K, class Inputs>
EnsembleResult<K::nq> ensemble_with_inputs(const EnsembleCases<K::nq>& cases,
                                           const EnsembleOptions& opt, Inputs&& inputs) {
  EnsembleResult<K::nq> r;
  r.sample_count = opt.sample_times.size();
  r.cases.resize(cases.x0.size());
  r.samples.resize(cases.x0.size() * r.sample_count);
  r.status = ensemble_with_inputs<K>(cases, opt, inputs, std::span(r.cases), std::span(r.samples));
  return r;
}

}  // namespace eom
