// Ensembles: many cases (initial state, parameters, inputs) of one model integrated with any
// method of eom::integrate, on one thread or on a pool of std::jthreads.
//
//   std::vector<eom::StateFor<K>> x0 = ...;                    // one per case
//   std::vector<double> p = ...;                               // K::np per case, or K::np shared
//   eom::EnsembleOptions opt;
//   opt.t0 = 0, opt.t1 = 10, opt.threads = 4;                  // 0: one per hardware thread
//   opt.integration.method = eom::Method::dop853;
//   opt.sample_times = times;                                  // optional dense samples
//   auto r = eom::ensemble<K>({x0, p, {}}, opt);
//   if (r.status != eom::Status::ok) ...                       // the ensemble itself is bad input
//   r.cases[c].status, r.cases[c].x, r.sample(c, k) ...        // per case, by case index
//
// A model with a free joint (eom/model/free_joint.hpp) has states of nq + nv numbers:
// EnsembleCasesFor<K> and EnsembleResultFor<K> name its types (EnsembleCases<K::nq> etc. are
// those of a model without one). A case whose quaternion is off the unit sphere reports
// Status::invalid_argument, as eom::integrate does.
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
// Batch: with a model that has forward_dynamics_batch, RK4 with held inputs and no stabilization,
// the cases go in groups of K::batch_lanes consecutive indices, each group
// stepped together through the batch kernel (opt.batch = false turns this off). That kernel equals
// forward_dynamics bitwise lane by lane, the stepping repeats rk4_step's arithmetic and each case
// keeps eom::integrate's own dense output for its samples, so a case ends, and is sampled, bitwise
// where eom::integrate takes it (with quaternions too: q̇ = G(q) v and their normalization after
// each step lane by lane, as rk4_step does). A case that eom::integrate would refuse, or that
// fails on the way (singular dynamics, a non-finite state), is run again alone by eom::integrate,
// which reports it exactly as without batching. (Compiled with FMA contraction, the vector and the
// scalar code may contract differently: then results agree to rounding, not bitwise.)
//
// Lock-step (opt.lockstep, dopri5 or dop853, held inputs, no stabilization, a batch kernel): the
// cases go in the same groups, each group integrated as ONE system of batch_lanes·nq coordinates
// (with quaternions, held lane by lane: LockstepLanes) whose forward dynamics is one call of the
// batch kernel, so the lanes share every step. The
// trade-off: one kernel call per stage for all lanes (faster), but the step is the one the whole
// group needs, so a lane takes the steps of its hardest neighbour and its result differs from its
// own run's within the tolerance, not bitwise (it is still the same for any thread count). The
// tolerances are divided by √batch_lanes, so each lane's own error norm stays ≤ 1 whenever the
// group's is. The step counts reported are the group's. A group that fails is run again case by
// case, which reports each case exactly as without lock-step (a quaternion off the unit sphere
// among them included).
//
// Why std::jthread and not oneTBB: the work is a flat loop of independent, coarse (milliseconds)
// tasks, which an atomic counter balances as well as a work-stealing scheduler; std::jthread keeps
// the runtime header-only with no dependency beyond the standard library (the runtime is used in
// controllers and consumer projects that should not need TBB), and joins on scope exit.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <span>
#include <thread>
#include <vector>

#include "eom/integration/integrate.hpp"
#include "eom/numeric/threads.hpp"

namespace eom {

// The cases: x0 gives their number; p holds K::np values per case (case c at p[c·np]) or K::np
// values shared by all; u likewise with K::nu (ignored when an input callback is given). Empty p
// or u is right only when np or nu is 0.
template <int nq, int nv = nq> struct EnsembleCases {
  std::span<const StateOf<nq, nv>> x0{};
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
  // With a model that has forward_dynamics_batch (eom::HasForwardDynamicsBatch), fixed-step RK4
  // with held inputs and no stabilization steps K::batch_lanes cases at a time through it (see
  // "Batch" above). The results are the same either way.
  bool batch = true;
  // dopri5 and dop853, under the same conditions: the lanes of a group share the step (see
  // "Lock-step" above; results within the tolerance of the one-case runs, not bitwise).
  bool lockstep = false;
};

template <int nq, int nv = nq> struct EnsembleResult {
  Status status = Status::ok;  // invalid_argument: the ensemble was bad input, nothing was run
  std::vector<IntegrationResult<nq, nv>> cases;  // by case index: status, time and state reached
  std::vector<StateOf<nq, nv>> samples;          // case-major: cases × sample_times
  std::size_t sample_count = 0;                  // sample times per case
  const StateOf<nq, nv>& sample(std::size_t c, std::size_t k) const {
    return samples[c * sample_count + k];
  }
  std::size_t failed() const {
    return static_cast<std::size_t>(std::count_if(
        cases.begin(), cases.end(), [](const auto& r) { return r.status != Status::ok; }));
  }
};

template <class K> using EnsembleCasesFor = EnsembleCases<K::nq, nv_of<K>>;
template <class K> using EnsembleResultFor = EnsembleResult<K::nq, nv_of<K>>;

namespace detail {

// The batch and lock-step paths: a batch kernel (a model with quaternions included: batch RK4
// repeats rk4_step's q̇ = G(q) v and normalization lane by lane; LockstepLanes keeps each lane's
// quaternions four consecutive coordinates).
template <class K>
concept BatchModel = HasForwardDynamicsBatch<K>;

// Stands for the held inputs (EnsembleCases::u) where a callback would go.
struct HeldInputs {
  static constexpr bool held = true;
};

// True when the ensemble's description and the caller's result spans fit together.
template <Dynamics K>
bool ensemble_input_ok(const EnsembleCasesFor<K>& cases, const EnsembleOptions& opt,
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
void run_case(std::size_t c, const EnsembleCasesFor<K>& cases, const EnsembleOptions& opt,
              IntegrationOptions integration, Inputs& inputs, IntegrationResultFor<K>& result,
              std::span<StateFor<K>> samples) noexcept {
  constexpr std::size_t np = K::np, nu = K::nu;
  using State = StateFor<K>;
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
    IntegrationResultFor<K> total;
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
      total.failure = r.failure, total.failure_velocity = r.failure_velocity;
      if (r.status != Status::ok) break;
      t = tb, x = r.x;
    }
    result = total;
  }
}

// Cases [first, last) on `threads` threads, results and samples indexed from `first`.
template <Dynamics K, class Inputs>
void run_cases(std::size_t first, std::size_t last, const EnsembleCasesFor<K>& cases,
               const EnsembleOptions& opt, Inputs& inputs,
               std::span<IntegrationResultFor<K>> results,
               std::span<StateFor<K>> samples) noexcept {
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

template <Dynamics K>
bool batch_applies(const EnsembleOptions& opt) noexcept {
  if constexpr (BatchModel<K>)
    return opt.batch && opt.integration.method == Method::rk4 &&
           opt.integration.stabilization.method == Stabilization::Method::none;
  (void)opt;
  return false;
}

// Whether eom::integrate would start RK4 on case c (its own checks and rk4's), given held u, p.
template <Dynamics K>
bool rk4_starts(const EnsembleOptions& opt, const StateFor<K>& x0, const double* p) noexcept {
  const IntegrationOptions& io = opt.integration;
  AdaptiveOptions adaptive;  // as eom::integrate validates a fixed-step method
  adaptive.rtol = io.rtol;
  adaptive.atol = io.atol;
  adaptive.initial_step = io.step;
  adaptive.max_steps = io.max_steps;
  const long steps = fixed_step_count(opt.t0, opt.t1, io.step);
  if (!adaptive_input_ok<K>(opt.t0, opt.t1, x0, adaptive) || steps == 0 || steps > io.max_steps)
    return false;
  StateFor<K> x = x0;
  return constrained_start<K>(x, p, io.stabilization) == Status::ok;
}

// Cases [first, first + W) (those below `last`) by batch RK4; a case it cannot finish goes to
// run_case alone. Lanes are independent, so a lane without a case of its own repeats another's.
// What eom::integrate's observer does with a case's states in the ensemble: the samples, in order.
template <class State> struct SampleSink {
  std::span<State> out;
  std::size_t next = 0;
  void operator()(double, const State& x) noexcept {
    if (next < out.size()) out[next++] = x;
  }
};

// results and samples begin at case `base` (0: the whole ensemble's; an MPI rank's own share).
template <Dynamics K>
void run_batch_group(std::size_t first, std::size_t last, const EnsembleCasesFor<K>& cases,
                     const EnsembleOptions& opt, const IntegrationOptions& integration,
                     std::span<IntegrationResultFor<K>> results,
                     std::span<StateFor<K>> samples, std::size_t base = 0) noexcept {
  static_assert(BatchModel<K>);
  constexpr int n = K::nq, nv = nv_of<K>, m = n + nv, W = K::batch_lanes;
  constexpr std::size_t np = K::np, nu = K::nu;
  using State = StateFor<K>;
  const auto params = [&](std::size_t c) {
    return np == 0 ? nullptr : cases.p.data() + (cases.p.size() == np ? 0 : c * np);
  };
  const auto inputs = [&](std::size_t c) {
    return nu == 0 ? nullptr : cases.u.data() + (cases.u.size() == nu ? 0 : c * nu);
  };
  std::array<std::size_t, W> lane_case{};
  std::array<bool, W> alive{};
  int live = 0;
  for (int l = 0; l < W; ++l) {
    const std::size_t c = first + static_cast<std::size_t>(l);
    alive[l] = c < last && rk4_starts<K>(opt, cases.x0[c], params(c));
    if (alive[l]) lane_case[l] = c, ++live;
  }
  const std::size_t ns = opt.sample_times.size();
  HeldInputs held;
  const auto alone = [&](std::size_t c) {
    run_case<K>(c, cases, opt, integration, held, results[c - base], samples.subspan((c - base) * ns, ns));
  };
  if (live > 0) {
    int donor = 0;
    while (!alive[donor]) ++donor;
    for (int l = 0; l < W; ++l)
      if (!alive[l]) lane_case[l] = lane_case[donor];
    // Structure of arrays: entry i of lane l at [i * W + l]; x = (q, v), q nq entries, v nv.
    std::array<double, m * W> x{}, y{}, k0{}, k1{}, k2{}, k3{};
    std::array<double, (np > 0 ? np : 1) * W> p{};
    std::array<double, (nu > 0 ? nu : 1) * W> u{};
    std::array<double, W> t{};
    // Lane l's quaternions back on the unit sphere (normalize_state; nothing without one).
    const auto normalize_lane = [&](int l) {
      if constexpr (nv != n) {
        std::array<double, n> q;
        for (int i = 0; i < n; ++i) q[i] = x[i * W + l];
        normalize_configuration(layout_of<K>(), q.data());
        for (int i = 0; i < n; ++i) x[i * W + l] = q[i];
      }
      (void)l;
    };
    for (int l = 0; l < W; ++l) {
      const std::size_t c = lane_case[l];
      for (int i = 0; i < m; ++i) x[i * W + l] = cases.x0[c][i];
      normalize_lane(l);  // as constrained_start begins every run
      for (std::size_t i = 0; i < np; ++i) p[i * W + l] = params(c)[i];
      for (std::size_t i = 0; i < nu; ++i) u[i * W + l] = inputs(c)[i];
    }
    // k = (G(q) v, v̇) at time tk (state_derivative's); the lanes whose dynamics failed drop out.
    const auto derivative = [&](double tk, const std::array<double, m * W>& s,
                                std::array<double, m * W>& k) {
      t.fill(tk);
      if constexpr (nv == n) {
        for (int j = 0; j < n * W; ++j) k[j] = s[n * W + j];
      } else {
        std::array<double, n> q, rate;
        std::array<double, nv> v;
        for (int l = 0; l < W; ++l) {
          for (int i = 0; i < n; ++i) q[i] = s[i * W + l];
          for (int i = 0; i < nv; ++i) v[i] = s[(n + i) * W + l];
          configuration_rate(layout_of<K>(), q.data(), v.data(), rate.data());
          for (int i = 0; i < n; ++i) k[i * W + l] = rate[i];
        }
      }
      const unsigned ok = K::forward_dynamics_batch(t.data(), s.data(), s.data() + n * W,
                                                    nu == 0 ? nullptr : u.data(),
                                                    np == 0 ? nullptr : p.data(), k.data() + n * W);
      for (int l = 0; l < W; ++l) alive[l] = alive[l] && ((ok >> l) & 1u) != 0;
    };
    // rk4() and rk4_step() (rk4.hpp), their arithmetic written out over the lanes.
    const long steps = fixed_step_count(opt.t0, opt.t1, integration.step);
    const double h = (opt.t1 - opt.t0) / static_cast<double>(steps);
    const auto stage = [&](const std::array<double, m * W>& k, double a) {
      for (int j = 0; j < m * W; ++j) y[j] = x[j] + a * h * k[j];
    };
    // Sample times: each case's own dense output, as eom::integrate makes it (cubic Hermite over
    // the steps that hold a sample time; it evaluates the scalar kernel there, 2 calls a step).
    using Dense = HermiteOutput<K, SampleSink<State>>;
    std::array<SampleSink<State>, W> sinks{};
    std::array<std::optional<Dense>, W> dense{};
    std::array<long, W> dense_evaluations{};
    const Stabilization output_stab =
        output_stabilization<K>(Method::rk4, integration.stabilization);
    const auto observe = [&](double tk) {
      for (int l = 0; l < W; ++l) {
        if (!dense[l] || !alive[l]) continue;
        State xl;
        for (int i = 0; i < m; ++i) xl[i] = x[i * W + l];
        (*dense[l])(tk, xl);
      }
    };
    if (ns > 0)
      for (int l = 0; l < W; ++l) {
        const std::size_t c = first + static_cast<std::size_t>(l);
        if (!alive[l] || lane_case[l] != c) continue;
        auto out = samples.subspan((c - base) * ns, ns);
        for (auto& sample : out) sample.fill(std::numeric_limits<double>::quiet_NaN());
        sinks[l].out = out;
        dense[l].emplace(opt.sample_times, inputs(c), params(c), integration.stabilization,
                         output_stab, sinks[l], dense_evaluations[l]);
        dense[l]->set_end(opt.t1);
      }
    observe(opt.t0);
    for (long step = 0; step < steps; ++step) {
      const double tk = opt.t0 + static_cast<double>(step) * h;
      derivative(tk, x, k0);
      stage(k0, 0.5);
      derivative(tk + 0.5 * h, y, k1);
      stage(k1, 0.5);
      derivative(tk + 0.5 * h, y, k2);
      stage(k2, 1.0);
      derivative(tk + h, y, k3);
      for (int j = 0; j < m * W; ++j) x[j] += h / 6.0 * (k0[j] + 2.0 * k1[j] + 2.0 * k2[j] + k3[j]);
      for (int l = 0; l < W; ++l) normalize_lane(l);
      for (int l = 0; l < W; ++l)
        for (int i = 0; i < m && alive[l]; ++i) alive[l] = std::isfinite(x[i * W + l]);
      if (std::none_of(alive.begin(), alive.end(), [](bool a) { return a; })) break;
      observe(step + 1 == steps ? opt.t1 : tk + h);
    }
    for (int l = 0; l < W; ++l) {
      const std::size_t c = first + static_cast<std::size_t>(l);
      if (!alive[l] || lane_case[l] != c) continue;
      IntegrationResultFor<K> r;  // as eom::integrate reports a completed RK4 run
      r.status = Status::ok;
      r.t = opt.t1;
      for (int i = 0; i < m; ++i) r.x[i] = x[i * W + l];
      r.accepted = steps;
      r.evaluations = 4 * steps + dense_evaluations[l];
      results[c - base] = r;
    }
  }
  for (int l = 0; l < W; ++l) {
    const std::size_t c = first + static_cast<std::size_t>(l);
    if (c < last && (!alive[l] || lane_case[l] != c)) alone(c);
  }
}

// Cases [first, last) in groups of K::batch_lanes, on `threads` threads.
template <Dynamics K>
void run_batch_cases(std::size_t first, std::size_t last, const EnsembleCasesFor<K>& cases,
                     const EnsembleOptions& opt, std::span<IntegrationResultFor<K>> results,
                     std::span<StateFor<K>> samples, std::size_t base = 0) noexcept {
  constexpr std::size_t W = K::batch_lanes;
  const std::size_t groups = (last - first + W - 1) / W;
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    const IntegrationOptions& integration = opt.integration;  // RK4: no Taylor workspace
    for (std::size_t g; (g = next.fetch_add(1, std::memory_order_relaxed)) < groups;)
      run_batch_group<K>(first + g * W, last, cases, opt, integration, results, samples, base);
  };
  run_on_threads(thread_count(opt.threads, groups), work);
}

// With quaternions in K's q, the lock-step system's: nv, and where each lane's quaternions are
// (lane by lane, below).
template <class K, bool = (nv_of<K> != K::nq)> struct LockstepQuaternions {};
template <class K> struct LockstepQuaternions<K, true> {
  static constexpr int nv = nv_of<K> * K::batch_lanes;
  static constexpr std::array<int, (K::nq - nv_of<K>) * K::batch_lanes> quaternions = [] {
    constexpr Layout one = layout_of<K>();
    std::array<int, (K::nq - nv_of<K>) * K::batch_lanes> at{};
    for (int l = 0; l < K::batch_lanes; ++l)
      for (int k = 0; k < one.count(); ++k) at[l * one.count() + k] = l * K::nq + one.quaternions[k];
    return at;
  }();
};

// K's batch lanes as one model of W·nq coordinates and W·nv velocities, for lock-step
// integration. Without quaternions, entry i of lane l's q (or v) at i·W + l, the batch kernel's
// layout; with them lane by lane (lane l's q at l·nq.., its v at l·nv..), so that each quaternion
// is four consecutive coordinates as eom::Layout needs, and forward_dynamics gathers the kernel's
// layout and scatters v̇ back. u and p in the kernel's layout (per lane) either way.
template <Dynamics K> struct LockstepLanes : LockstepQuaternions<K> {
  static constexpr int W = K::batch_lanes, nq = K::nq * W, np = K::np * W, nu = K::nu * W, nc = 0;
  static constexpr int n = K::nq, nv_lane = nv_of<K>;
  static constexpr bool lane_major = nv_lane != n;
  // Where entry i of lane l's state x = (q, v) (i < n + nv_lane) is in the system's state.
  static constexpr int at(int i, int l) noexcept {
    if constexpr (lane_major)
      return i < n ? l * n + i : nq + l * nv_lane + (i - n);
    else
      return i * W + l;
  }
  static bool forward_dynamics(double t, const double* q, const double* qd, const double* u,
                               const double* p, double* qdd) noexcept {
    std::array<double, W> ts;
    ts.fill(t);
    if constexpr (lane_major) {
      std::array<double, n * W> qs;
      std::array<double, nv_lane * W> vs, as;
      for (int l = 0; l < W; ++l) {
        for (int i = 0; i < n; ++i) qs[i * W + l] = q[l * n + i];
        for (int i = 0; i < nv_lane; ++i) vs[i * W + l] = qd[l * nv_lane + i];
      }
      const bool ok = K::forward_dynamics_batch(ts.data(), qs.data(), vs.data(), u, p, as.data()) == (1u << W) - 1;
      for (int l = 0; l < W; ++l)
        for (int i = 0; i < nv_lane; ++i) qdd[l * nv_lane + i] = as[i * W + l];
      return ok;
    } else {
      return K::forward_dynamics_batch(ts.data(), q, qd, u, p, qdd) == (1u << W) - 1;
    }
  }
  // (what eom::Dynamics asks of a model: the lanes' energies, summed)
  static double kinetic_energy(const double* q, const double* qd, const double* p) noexcept {
    double T = 0;
    for (int l = 0; l < W; ++l) {
      Lane lane(q, qd, p, l);
      T += K::kinetic_energy(lane.q.data(), lane.qd.data(), lane.p.data());
    }
    return T;
  }
  static double potential_energy(const double* q, const double* p) noexcept {
    double V = 0;
    for (int l = 0; l < W; ++l) {
      Lane lane(q, q, p, l);
      V += K::potential_energy(lane.q.data(), lane.p.data());
    }
    return V;
  }

 private:
  struct Lane {  // lane l's q, qd, p gathered (qd from QD, which is Q for the potential)
    std::array<double, n> q{};
    std::array<double, nv_lane> qd{};
    std::array<double, (K::np > 0 ? K::np : 1)> p{};
    Lane(const double* Q, const double* QD, const double* P, int l) noexcept {
      for (int i = 0; i < n; ++i) q[i] = Q[at(i, l)];
      for (int i = 0; i < nv_lane; ++i) qd[i] = QD[at(n + i, l) - nq];
      for (int i = 0; i < K::np; ++i) p[i] = P[i * W + l];
    }
  };
};

template <Dynamics K>
bool lockstep_applies(const EnsembleOptions& opt) noexcept {
  if constexpr (BatchModel<K>)
    return opt.lockstep &&
           (opt.integration.method == Method::dopri5 || opt.integration.method == Method::dop853) &&
           opt.integration.stabilization.method == Stabilization::Method::none;
  (void)opt;
  return false;
}

// Cases [first, first + W) (those below `last`) as one lock-step system; a lane without a case of
// its own repeats the group's first case. On failure every case of the group runs alone.
template <Dynamics K>
void run_lockstep_group(std::size_t first, std::size_t last, const EnsembleCasesFor<K>& cases,
                        const EnsembleOptions& opt, std::span<IntegrationResultFor<K>> results,
                        std::span<StateFor<K>> samples) noexcept {
  static_assert(BatchModel<K>);
  using L = LockstepLanes<K>;
  constexpr int m = K::nq + nv_of<K>, W = L::W;
  constexpr std::size_t np = K::np, nu = K::nu;
  const std::size_t ns = opt.sample_times.size();
  const std::size_t own = std::min<std::size_t>(W, last - first);
  auto lane_case = [&](int l) { return static_cast<std::size_t>(l) < own ? first + l : first; };
  StateFor<L> X{};
  std::array<double, (np > 0 ? np * W : 1)> P{};
  std::array<double, (nu > 0 ? nu * W : 1)> U{};
  bool finite = true;
  for (int l = 0; l < W; ++l) {
    const std::size_t c = lane_case(l);
    for (int i = 0; i < m; ++i) X[L::at(i, l)] = cases.x0[c][i], finite = finite && std::isfinite(cases.x0[c][i]);
    for (std::size_t i = 0; i < np; ++i) P[i * W + l] = cases.p[(cases.p.size() == np ? 0 : c * np) + i];
    for (std::size_t i = 0; i < nu; ++i) U[i * W + l] = cases.u[(cases.u.size() == nu ? 0 : c * nu) + i];
  }
  AdaptiveOptions a;
  a.rtol = opt.integration.rtol / std::sqrt(double(W));
  a.atol = opt.integration.atol / std::sqrt(double(W));
  a.initial_step = opt.integration.step;
  a.max_steps = opt.integration.max_steps;
  a.output_times = opt.sample_times;
  std::size_t k = 0;
  auto observe = [&](double, const StateFor<L>& x) {
    if (k >= ns) return;
    for (std::size_t l = 0; l < own; ++l)
      for (int i = 0; i < m; ++i) samples[(first + l) * ns + k][i] = x[L::at(i, static_cast<int>(l))];
    ++k;
  };
  const IntegrationResultFor<L> r =
      !finite ? IntegrationResultFor<L>{Status::invalid_argument}
      : opt.integration.method == Method::dopri5
          ? dopri5<L>(opt.t0, opt.t1, X, nu ? U.data() : nullptr, np ? P.data() : nullptr, a, observe)
          : dop853<L>(opt.t0, opt.t1, X, nu ? U.data() : nullptr, np ? P.data() : nullptr, a, observe);
  if (r.status != Status::ok) {  // case by case, as without lock-step
    HeldInputs held;
    IntegrationOptions integration = opt.integration;
    for (std::size_t c = first; c < first + own; ++c)
      run_case<K>(c, cases, opt, integration, held, results[c], samples.subspan(c * ns, ns));
    return;
  }
  for (std::size_t l = 0; l < own; ++l) {
    IntegrationResultFor<K> lane;
    lane.status = Status::ok;
    lane.t = r.t;
    for (int i = 0; i < m; ++i) lane.x[i] = r.x[L::at(i, static_cast<int>(l))];
    lane.accepted = r.accepted, lane.rejected = r.rejected, lane.evaluations = r.evaluations;
    results[first + l] = lane;
  }
}

template <Dynamics K>
void run_lockstep_cases(const EnsembleCasesFor<K>& cases, const EnsembleOptions& opt,
                        std::span<IntegrationResultFor<K>> results,
                        std::span<StateFor<K>> samples) noexcept {
  constexpr std::size_t W = K::batch_lanes;
  const std::size_t count = cases.x0.size(), groups = (count + W - 1) / W;
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t g; (g = next.fetch_add(1, std::memory_order_relaxed)) < groups;)
      run_lockstep_group<K>(g * W, count, cases, opt, results, samples);
  };
  run_on_threads(thread_count(opt.threads, groups), work);
}

}  // namespace detail

// Into the caller's storage: results[c] for case c, samples[c·S + k] at sample_times[k] (S sample
// times). Status::invalid_argument when the sizes do not fit (see above), else ok; each case's own
// status is in its result.
template <Dynamics K>
Status ensemble(const EnsembleCasesFor<K>& cases, const EnsembleOptions& opt,
                std::span<IntegrationResultFor<K>> results,
                std::span<StateFor<K>> samples = {}) noexcept {
  if (!detail::ensemble_input_ok<K>(cases, opt, false, results.size(), samples.size()))
    return Status::invalid_argument;
  if constexpr (detail::BatchModel<K>) {
    if (detail::batch_applies<K>(opt)) {
      detail::run_batch_cases<K>(0, cases.x0.size(), cases, opt, results, samples);
      return Status::ok;
    }
    if (detail::lockstep_applies<K>(opt)) {
      detail::run_lockstep_cases<K>(cases, opt, results, samples);
      return Status::ok;
    }
  }
  detail::HeldInputs held;
  detail::run_cases<K>(0, cases.x0.size(), cases, opt, held, results, samples);
  return Status::ok;
}

// Inputs from a callback: inputs(std::size_t case_index, double t, const StateFor<K>& x,
// std::span<double> u) at t0 and every opt.input_period.
template <Dynamics K, class Inputs>
Status ensemble_with_inputs(const EnsembleCasesFor<K>& cases, const EnsembleOptions& opt,
                            Inputs&& inputs, std::span<IntegrationResultFor<K>> results,
                            std::span<StateFor<K>> samples = {}) noexcept {
  if (!detail::ensemble_input_ok<K>(cases, opt, true, results.size(), samples.size()))
    return Status::invalid_argument;
  detail::run_cases<K>(0, cases.x0.size(), cases, opt, inputs, results, samples);
  return Status::ok;
}

// The same, results returned (allocated here, before any integration).
template <Dynamics K>
EnsembleResultFor<K> ensemble(const EnsembleCasesFor<K>& cases, const EnsembleOptions& opt) {
  EnsembleResultFor<K> r;
  r.sample_count = opt.sample_times.size();
  r.cases.resize(cases.x0.size());
  r.samples.resize(cases.x0.size() * r.sample_count);
  r.status = ensemble<K>(cases, opt, std::span(r.cases), std::span(r.samples));
  return r;
}

template <Dynamics K, class Inputs>
EnsembleResultFor<K> ensemble_with_inputs(const EnsembleCasesFor<K>& cases,
                                           const EnsembleOptions& opt, Inputs&& inputs) {
  EnsembleResultFor<K> r;
  r.sample_count = opt.sample_times.size();
  r.cases.resize(cases.x0.size());
  r.samples.resize(cases.x0.size() * r.sample_count);
  r.status = ensemble_with_inputs<K>(cases, opt, inputs, std::span(r.cases), std::span(r.samples));
  return r;
}

}  // namespace eom
