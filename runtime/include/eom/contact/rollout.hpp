// Ensembles of contact steps (docs/CONTRACT.md §1, "Stepping with contact"): N cases, each from
// its own (q0, v0) with its own inputs, stepped `steps` times by eom::contact_step on a pool of
// threads (eom/numeric/threads.hpp, as eom::ensemble).
//
//   eom::RolloutCases cases{q0, v0, u, p};   // N·nq, N·nv; u and p below
//   eom::RolloutOptions opt{.steps = 200, .threads = 0};
//   const eom::RolloutResult r = eom::contact_rollout<K, Model>(cases, opt);
//   if (!r.ok()) ... r.error                 // bad input: says which argument and why
//   r.cases[c].status, r.cases[c].steps, r.final_q(c) ...
//
// Determinism: each case starts from a cold ContactStepper (no warm start from another case) and
// writes only its own results, so they are bitwise those of a loop of contact_step over the case
// alone, for any number of threads and any order in which the threads take cases. A case whose
// step fails keeps its last good state and reports the step's StepStatus and that step's index;
// the other cases run on. Allocation: the results and one ContactStepper per thread, before
// stepping.
#pragma once

#include <atomic>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "eom/contact/step.hpp"
#include "eom/numeric/threads.hpp"

namespace eom {

// The cases: q0 and v0 hold nq and nv values per case (case c at c·nq and c·nv); their count N is
// q0.size() / nq. u: nu values held by every case, N·nu (one row per case, held) or N·steps·nu
// (case c's inputs at step k at (c·steps + k)·nu). p: np values shared, or N·np. u or p is empty
// exactly when nu or np is 0.
struct RolloutCases {
  std::span<const double> q0{}, v0{}, u{}, p{};
};

struct RolloutOptions {
  long steps = 0;        // steps per case, ≥ 0
  double t0 = 0;         // every case's initial time
  unsigned threads = 1;  // threads that step (the caller's included); 0: one per hardware thread
  bool record = false;   // keep the state at t0 and after every step (RolloutResult::states)
};

struct RolloutCase {
  StepStatus status = StepStatus::ok;
  long steps = 0;           // steps taken; where status is not ok, the index of the step that failed
  double t = 0;             // the time reached
  int unmodeled_pair = -1;  // with StepStatus::unmodeled_pair: the pair's index
};

struct RolloutResult {
  std::string error;               // empty, or why nothing was run (bad input)
  std::size_t nq = 0, nv = 0;
  long steps = 0;
  std::vector<RolloutCase> cases;  // by case index
  std::vector<double> q, v;        // each case's last state: N·nq and N·nv
  // With RolloutOptions::record: case c's [q, v] at step k (k = 0: t0) at
  // ((c·(steps + 1) + k)·(nq + nv)); NaN after a failed step.
  std::vector<double> states;

  bool ok() const noexcept { return error.empty(); }
  std::span<const double> final_q(std::size_t c) const { return {q.data() + c * nq, nq}; }
  std::span<const double> final_v(std::size_t c) const { return {v.data() + c * nv, nv}; }
  std::span<const double> state(std::size_t c, long k) const {
    return {states.data() + (c * static_cast<std::size_t>(steps + 1) + static_cast<std::size_t>(k)) * (nq + nv),
            nq + nv};
  }
  std::size_t failed() const noexcept {
    std::size_t n = 0;
    for (const RolloutCase& c : cases) n += c.status != StepStatus::ok;
    return n;
  }
};

namespace detail {

// Why the cases do not fit K (empty when they do).
template <class K>
std::string rollout_input_error(const RolloutCases& cases, const RolloutOptions& opt) {
  constexpr std::size_t nq = K::nq, nv = K::nv, nu = K::nu, np = K::np;
  const auto str = [](auto x) { return std::to_string(x); };
  const std::string at = "eom::contact_rollout: ";
  if (opt.steps < 0) return at + "steps must be >= 0, given " + str(opt.steps);
  if (!std::isfinite(opt.t0)) return at + "t0 must be finite";
  if (cases.q0.empty()) return at + "no cases (q0 is empty)";
  if (cases.q0.size() % nq != 0)
    return at + "q0 has " + str(cases.q0.size()) + " values, not a multiple of nq = " + str(nq);
  const std::size_t n = cases.q0.size() / nq, steps = static_cast<std::size_t>(opt.steps);
  if (cases.v0.size() != n * nv)
    return at + "v0 has " + str(cases.v0.size()) + " values; " + str(n) + " cases (q0) need N·nv = " +
           str(n * nv);
  const std::size_t u = cases.u.size(), p = cases.p.size();
  if (nu == 0 ? u != 0 : u != nu && u != n * nu && u != n * steps * nu)
    return at + "u has " + str(u) + " values; expected " +
           (nu == 0 ? std::string("none (nu = 0)")
                    : "nu = " + str(nu) + " (held by all cases), N·nu = " + str(n * nu) +
                          " (one held per case) or N·steps·nu = " + str(n * steps * nu) +
                          " (per case and step)");
  if (np == 0 ? p != 0 : p != np && p != n * np)
    return at + "p has " + str(p) + " values; expected " +
           (np == 0 ? std::string("none (np = 0)")
                    : "np = " + str(np) + " (shared) or N·np = " + str(n * np) + " (per case)");
  return {};
}

}  // namespace detail

template <class K, class Model>
RolloutResult contact_rollout(const RolloutCases& cases, const RolloutOptions& opt) {
  constexpr std::size_t nq = K::nq, nv = K::nv, nu = K::nu, np = K::np, nx = nq + nv;
  RolloutResult r;
  r.error = detail::rollout_input_error<K>(cases, opt);
  if (!r.ok()) return r;
  const std::size_t n = cases.q0.size() / nq, steps = static_cast<std::size_t>(opt.steps);
  r.nq = nq, r.nv = nv, r.steps = opt.steps;
  r.cases.resize(n);
  r.q.assign(cases.q0.begin(), cases.q0.end());
  r.v.assign(cases.v0.begin(), cases.v0.end());
  if (opt.record) r.states.assign(n * (steps + 1) * nx, std::numeric_limits<double>::quiet_NaN());
  const auto inputs = [&](std::size_t c, std::size_t k) -> const double* {
    if (nu == 0) return nullptr;
    const std::size_t u = cases.u.size();
    // (where two layouts have the same size, they index the same values)
    return cases.u.data() + (u == n * steps * nu ? (c * steps + k) * nu : u == n * nu ? c * nu : 0);
  };
  const double* const p0 = np == 0 ? nullptr : cases.p.data();
  const auto params = [&](std::size_t c) { return np == 0 || cases.p.size() == np ? p0 : p0 + c * np; };

  const unsigned threads = detail::thread_count(opt.threads, n);
  std::vector<std::unique_ptr<ContactStepper<K, Model>>> steppers(threads);  // large: on the heap
  for (auto& s : steppers) s = std::make_unique<ContactStepper<K, Model>>();
  std::atomic<unsigned> slot{0};
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    ContactStepper<K, Model>& s = *steppers[slot.fetch_add(1, std::memory_order_relaxed)];
    for (std::size_t c; (c = next.fetch_add(1, std::memory_order_relaxed)) < n;) {
      s.warm = false;  // the stepper's only state carried from step to step: none from another case
      s.unmodeled_pair = -1;
      std::span<double, K::nq> q(r.q.data() + c * nq, nq);
      std::span<double, K::nv> v(r.v.data() + c * nv, nv);
      RolloutCase& out = r.cases[c];
      double t = opt.t0;
      const auto keep = [&](std::size_t k) {
        if (!opt.record) return;
        double* x = r.states.data() + (c * (steps + 1) + k) * nx;
        std::copy(q.begin(), q.end(), x);
        std::copy(v.begin(), v.end(), x + nq);
      };
      keep(0);
      std::size_t k = 0;
      for (; k < steps; ++k) {
        out.status = contact_step<K, Model>(s, t, q, v, inputs(c, k), params(c));
        if (out.status != StepStatus::ok) break;
        keep(k + 1);
      }
      out.steps = static_cast<long>(k);
      out.t = t;
      if (out.status == StepStatus::unmodeled_pair) out.unmodeled_pair = s.unmodeled_pair;
    }
  };
  detail::run_on_threads(threads, work);
  return r;
}

}  // namespace eom
