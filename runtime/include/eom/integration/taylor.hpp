// Taylor series integration with exact higher derivatives (paper eq. 28), over any kernel type
// that provides the Taylor-coefficient kernel (eom::Reference<Model>, generated Kernels):
//
//   x(t + h) = Σ_{k=0..p} x_k h^k,   x_k = x⁽ᵏ⁾(t)/k!,   x = (q, v),
//
// with the coefficients x_k from K::taylor_coefficients (one call per step, whatever the order).
// Three ways to choose p and h:
//
//  * Scheme::paper (Griffith et al., AAS 04-242): a 4th-order Taylor step whose step size comes
//    from the exactly computed 5th-order term. The local error is estimated as ‖x₅ h⁵‖ in the
//    weighted RMS norm of the Runge–Kutta methods (atol + rtol·max(|xᵢ|, |x̃ᵢ|)); a step is
//    accepted when it is ≤ 1. Because x₅ is known before the step, h is taken from it directly,
//    h = 0.9·‖x₅‖^(−1/5) (weights at the step's start, growth at most 5× per step); the check
//    after the step then rejects only when the end state is not finite. TaylorOptions::order
//    p > 0 generalizes it to an order-p step controlled by the exact term p + 1.
//    The step stays 4th order (the 5th term is not added): it is the paper's method.
//  * Scheme::jorba_zou (Jorba & Zou, Experimental Mathematics 14, 2005; as in heyoka): the order
//    from the tolerance, p = ⌈−½ ln ε + 1⌉, and the step from the last two coefficients,
//      ρ = min((s/‖x_{p−1}‖∞)^(1/(p−1)), (s/‖x_p‖∞)^(1/p)),   h = ρ/e² · exp(−0.7/(p−1)),
//    where the tolerance is absolute (ε = atol, s = 1) while rtol·‖x‖∞ ≤ atol and relative
//    (ε = rtol, s = ‖x‖∞) beyond. No error estimate and no rejections: h makes the truncated
//    terms ~ε by the Cauchy bound of an analytic solution (at that order ε^(1/(p−1)) = e^(−2),
//    so ρ/e² is the step that makes x_{p−1} h^(p−1) ≈ ε s). ε below what taylor_max_order can
//    reach is served by that order (whose steps give errors ~e^(−2p), beneath double precision).
//    TaylorOptions::order p > 0 fixes the order (p >= 2) and takes the step that makes each of
//    the last two terms ε s: h = exp(−0.7/(p−1)) · min_{j=p−1,p} (ε s/‖x_j‖∞)^(1/j) — the same
//    step at the order from the tolerance, a shorter (longer) one at a lower (higher) order.
//  * taylor_fixed: order p, N equal steps (for convergence-order measurements); its result counts
//    the steps as accepted.
//
// Both adaptive schemes guard against the failures of a long step: a non-finite end state, or a
// coefficient call that fails (singular dynamics or overflowing coefficients) at the end state,
// rejects the step and retries a quarter of it with the same coefficients; steps below
// 16 ε |t| stop with Status::step_size_underflow and opt.max_steps with Status::step_limit.
// Dense output (AdaptiveOptions::output_times) is the step's own polynomial, so it is as accurate
// as the steps. opt.initial_step > 0 replaces the scheme's choice for the first step.
// Evaluations (AdaptiveResult::evaluations) count taylor_coefficients calls.
//
// Constrained models: the coefficients are those of the index-1 dynamics, so the solution
// drifts off the constraints like any explicit method's; Stabilization::projection projects
// after each accepted step (the next coefficients are taken at the projected state; the dense
// output inside a step is the step's polynomial, projected). Baumgarte terms live inside the right-hand
// side, which the Taylor kernel does not see: Stabilization::baumgarte is refused with
// Status::invalid_argument.
//
// A free joint or ball joints (eom/model/free_joint.hpp): the coefficients are those of
// q̇ = G(q) v, v̇ (eom::Reference computes them, and a generated taylor_coefficients where KERNELS
// names it: docs/CONTRACT.md §3); the quaternions are normalized after each step and in the dense
// output (state.hpp).
//
// Memory: the coefficients live in fixed arrays sized by K::taylor_max_order (two sets of
// (nq + nv)·(taylor_max_order + 1) doubles, on the stack). The kernel's workspace (K::taylor_workspace
// doubles per order, none for eom::Reference, plus K::taylor_coefficients_workspace of scratch
// for a kernel split into parts, so that the kernel needs no large stack frame) is by default one std::vector allocated per call
// before the first step; nothing is allocated while stepping. A real-time caller that must not
// allocate at all passes its own: TaylorOptions::workspace of taylor_workspace_size<K>(opt,
// taylor_opt) doubles or more, the `workspace` argument of taylor_fixed of
// taylor_workspace_size<K>(order), or taylor_workspace_capacity<K> for any options, e.g. a static
// std::array sized at compile time (for a generated 10-link chain 295·65 doubles, 150 kB: too
// large for the stack of a real-time thread, hence no stack array here). Too small a workspace
// is refused with Status::invalid_argument before any evaluation.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <limits>
#include <numbers>
#include <span>
#include <vector>

#include "eom/integration/adaptive.hpp"
#include "eom/integration/stabilization.hpp"
#include "eom/integration/state.hpp"
#include "eom/model/kernels.hpp"

namespace eom {

// The Taylor-coefficient kernel (contract: generator/README.md, "Taylor mode") on top of the dynamics.
template <class K>
concept TaylorDynamics = Dynamics<K> && HasTaylorCoefficients<K>;

struct TaylorOptions {
  enum class Scheme {
    paper,      // order-4 step, step size from the exact 5th-order term (with accept/reject)
    jorba_zou,  // order and step size from the tolerance and the last two coefficients
  };
  Scheme scheme = Scheme::jorba_zou;
  // 0: the scheme's own (paper: 4; Jorba–Zou: from the tolerance). Otherwise the step's order p:
  // paper needs 1 <= p < taylor_max_order (it also computes term p + 1), Jorba–Zou
  // 2 <= p <= taylor_max_order.
  int order = 0;
  // The kernel's workspace, provided by the caller so that taylor() allocates nothing; empty:
  // taylor() allocates it (see "Memory" above).
  std::span<double> workspace{};
};

// The doubles of scratch a generated taylor_coefficients split into parts takes from the caller
// (K::taylor_coefficients_workspace: the arrays its parts share); 0 when it has none.
template <TaylorDynamics K> constexpr std::size_t taylor_scratch_size() noexcept {
  if constexpr (requires { K::taylor_coefficients_workspace; })
    return static_cast<std::size_t>(K::taylor_coefficients_workspace);
  else
    return 0;
}

// The doubles of kernel workspace taylor_coefficients needs up to `order` (0 for eom::Reference):
// its series, then its scratch.
template <TaylorDynamics K> constexpr std::size_t taylor_workspace_size(int order) noexcept {
  if (order < 0) return 0;
  return static_cast<std::size_t>(K::taylor_workspace) * static_cast<std::size_t>(order + 1) +
         taylor_scratch_size<K>();
}

// Enough for every order K accepts: a compile-time size for a caller's static workspace.
template <TaylorDynamics K>
inline constexpr std::size_t taylor_workspace_capacity =
    taylor_workspace_size<K>(K::taylor_max_order);

namespace detail {

// The Taylor coefficients of x = (q, v) at one point, up to the order last computed.
template <TaylorDynamics K> class TaylorSeries {
 public:
  static constexpr int nq = K::nq, nv = nv_of<K>, m = nq + nv, max_order = K::taylor_max_order;
  using State = StateFor<K>;

  // Coefficients 0..order at (t, x); false when the kernel fails or a coefficient is not finite.
  bool compute(int order, double t, const State& x, const double* u, const double* p,
               double* work) noexcept {
    order_ = order;
    bool ok = false;
    if constexpr (taylor_scratch_size<K>() > 0) {  // the scratch follows this order's series
      double* const scratch = work + static_cast<std::ptrdiff_t>(K::taylor_workspace) * (order + 1);
      ok = K::taylor_coefficients(order, t, x.data(), x.data() + nq, u, p, q_.data(), qd_.data(),
                                  work, scratch);
    } else {
      ok = K::taylor_coefficients(order, t, x.data(), x.data() + nq, u, p, q_.data(), qd_.data(),
                                  work);
    }
    if (!ok) {
      detail::note_dynamics_failure<K>(t, x.data(), x.data() + nq, u, p);
      return false;
    }
    for (int k = 0; k < (order + 1) * nq; ++k)
      if (!std::isfinite(q_[k])) return false;
    for (int k = 0; k < (order + 1) * nv; ++k)
      if (!std::isfinite(qd_[k])) return false;
    return true;
  }
  int order() const noexcept { return order_; }
  // Component i of x_k.
  double operator()(int k, int i) const noexcept {
    return i < nq ? q_[k * nq + i] : qd_[k * nv + i - nq];
  }
  State term(int k) const noexcept {
    State v;
    for (int i = 0; i < m; ++i) v[i] = (*this)(k, i);
    return v;
  }
  double max_abs(int k) const noexcept {
    double s = 0;
    for (int i = 0; i < m; ++i) s = std::max(s, std::abs((*this)(k, i)));
    return s;
  }
  // Σ_{k=0..degree} x_k θ^k by Horner's rule.
  void evaluate(int degree, double theta, State& out) const noexcept {
    for (int i = 0; i < m; ++i) {
      double s = (*this)(degree, i);
      for (int k = degree - 1; k >= 0; --k) s = s * theta + (*this)(k, i);
      out[i] = s;
    }
  }

 private:
  std::array<double, (max_order + 1) * nq> q_{};
  std::array<double, (max_order + 1) * nv> qd_{};
  int order_ = 0;
};

inline double max_abs(std::span<const double> x) noexcept {
  double s = 0;
  for (double v : x) s = std::max(s, std::abs(v));
  return s;
}

// Jorba–Zou: the order for tolerance ε, within [2, max_order].
inline int jorba_zou_order(double eps, int max_order) noexcept {
  const double p = std::ceil(-0.5 * std::log(eps) + 1);
  return p >= max_order ? max_order : std::max(2, static_cast<int>(p));
}

// The highest coefficient order taylor() computes with these options (valid options assumed).
inline int taylor_highest_order(const AdaptiveOptions& opt, const TaylorOptions& taylor_opt,
                                int max_order) noexcept {
  const int fixed = taylor_opt.order;
  if (taylor_opt.scheme == TaylorOptions::Scheme::paper) return (fixed > 0 ? fixed : 4) + 1;
  if (fixed > 0) return fixed;
  return std::max(jorba_zou_order(opt.rtol, max_order), jorba_zou_order(opt.atol, max_order));
}

// Points `work` at the kernel workspace of one call of `size` doubles: the caller's when it gave
// one, else `owned`, resized. False when the caller's is too small.
inline bool taylor_work(std::span<double> given, std::size_t size, std::vector<double>& owned,
                        double*& work) noexcept {
  if (given.empty()) {
    owned.resize(size);
    work = owned.data();
    return true;
  }
  work = given.data();
  return given.size() >= size;
}

// A Taylor scheme as the stepper of adaptive_steps (adaptive.hpp). The coefficients at the
// step's start fix the step before it is taken: its size comes from them (the paper: the exact
// term p + 1 as the error estimate; Jorba–Zou: the last two terms), so a step is rejected only
// when its end state is not finite, the paper's estimate exceeds the tolerance at a step given
// from outside (initial or retried), or the next coefficients fail at its end. The series at the
// end of an accepted step is the next step's: computed once (complete), swapped in (next).
template <TaylorDynamics K> class TaylorStepper {
 public:
  static constexpr int nq = K::nq, max_order = K::taylor_max_order;
  using State = StateFor<K>;

  TaylorStepper(const double* u, const double* p, const AdaptiveOptions& opt,
                const TaylorOptions& taylor_opt, double* work) noexcept
      : u_(u), p_(p), opt_(opt), paper_(taylor_opt.scheme == TaylorOptions::Scheme::paper),
        fixed_(taylor_opt.order), work_(work) {}
  TaylorStepper(const TaylorStepper&) = delete;  // current_ and next_ point into series_
  TaylorStepper& operator=(const TaylorStepper&) = delete;

  long evaluations = 0;

  bool start(double t, const State& x, double, double& h) noexcept {
    if (!series_at(*current_, t, x)) return false;
    h = opt_.initial_step > 0 ? opt_.initial_step : proposed(x);
    return true;
  }
  double attempt(double t, double h, const State& x) noexcept {
    t_ = t;
    degree_ = paper_ ? current_->order() - 1 : current_->order();
    current_->evaluate(degree_, h, x_new_);
    for (double v : x_new_)
      if (!std::isfinite(v)) return std::numeric_limits<double>::infinity();
    if (!paper_) return 0;
    State e = current_->term(degree_ + 1);  // the exact next term as the local error estimate
    const double hp = std::pow(h, degree_ + 1);
    for (double& v : e) v *= hp;
    return error_norm(e, x, x_new_, opt_);
  }
  const State& solution() const noexcept { return x_new_; }
  // The next step's coefficients at the (projected) end; failing there (a singular or
  // overflowing point that a long step reached) rejects this step. The last step needs none.
  bool complete(double t, double h, const State& x_end, bool last, bool) noexcept {
    return last || series_at(*next_, t + h, x_end);
  }
  Status restart(double, const State&) noexcept { return Status::ok; }
  void interpolate(double t_out, State& x) const noexcept {
    current_->evaluate(degree_, t_out - t_, x);
  }
  // Only the paper's scheme has an error estimate (Jorba–Zou's attempts return 0 or ∞).
  double shrink(double e) const noexcept { return std::max(0.2, 0.9 * std::pow(e, -1.0 / (degree_ + 1))); }
  double next(double h, double, bool, const State& x_end) noexcept {
    std::swap(current_, next_);
    previous_h_ = h;
    return proposed(x_end);
  }

 private:
  // Jorba–Zou picks the degree per step from the tolerance mode.
  int degree_at(const State& x) const noexcept {
    if (paper_) return fixed_ > 0 ? fixed_ : 4;
    if (fixed_ > 0) return fixed_;
    const bool relative = opt_.rtol * max_abs(x) > opt_.atol;
    return jorba_zou_order(relative ? opt_.rtol : opt_.atol, max_order);
  }
  bool series_at(TaylorSeries<K>& s, double t, const State& x) noexcept {
    ++evaluations;
    const int degree = degree_at(x);
    return s.compute(paper_ ? degree + 1 : degree, t, x, u_, p_, work_);
  }
  // The step the scheme asks for at x from the current coefficients (may be +inf when the
  // terms vanish).
  double proposed(const State& x) const noexcept {
    const TaylorSeries<K>& s = *current_;
    const double inf = std::numeric_limits<double>::infinity();
    if (paper_) {
      const int d = s.order() - 1;
      const double norm = error_norm(s.term(d + 1), x, x, opt_);
      double h = norm > 0 ? 0.9 * std::pow(norm, -1.0 / (d + 1)) : inf;
      if (previous_h_ > 0) h = std::min(h, 5 * previous_h_);
      return h;
    }
    const int d = s.order();
    const double x_norm = max_abs(x);
    const bool relative = opt_.rtol * x_norm > opt_.atol;
    const double scale = relative ? x_norm : 1.0;
    const double a = s.max_abs(d - 1), b = s.max_abs(d);
    const double safety = std::exp(-0.7 / (d - 1));
    if (fixed_ > 0) {  // the order is given: the last two terms each ≈ ε s
      const double eps_scale = (relative ? opt_.rtol : opt_.atol) * scale;
      return safety * std::min(a > 0 ? std::pow(eps_scale / a, 1.0 / (d - 1)) : inf,
                               b > 0 ? std::pow(eps_scale / b, 1.0 / d) : inf);
    }
    const double rho = std::min(a > 0 ? std::pow(scale / a, 1.0 / (d - 1)) : inf,
                                b > 0 ? std::pow(scale / b, 1.0 / d) : inf);
    return rho / (std::numbers::e * std::numbers::e) * safety;
  }

  const double *u_, *p_;
  const AdaptiveOptions& opt_;
  bool paper_;
  int fixed_;
  double* work_;
  // The coefficients at the step's start and at its end (swapped by pointer, not copied).
  std::array<TaylorSeries<K>, 2> series_;
  TaylorSeries<K>* current_ = &series_[0];
  TaylorSeries<K>* next_ = &series_[1];
  State x_new_{};
  double t_ = 0, previous_h_ = 0;
  int degree_ = 0;
};

}  // namespace detail

// The doubles of workspace taylor() needs with these options (for TaylorOptions::workspace).
template <TaylorDynamics K>
std::size_t taylor_workspace_size(const AdaptiveOptions& opt,
                                  const TaylorOptions& taylor_opt) noexcept {
  const int highest = detail::taylor_highest_order(opt, taylor_opt, K::taylor_max_order);
  return taylor_workspace_size<K>(highest);
}

// Integrates from t0 to t1 with the scheme of `taylor_opt`, calling observer(t, x) at t0 and
// after every accepted step (or at opt.output_times). Bad input (tolerances, time span, x0,
// output times, an order out of range, Baumgarte stabilization, stabilization without
// constraints, a caller's workspace too small) returns Status::invalid_argument before any
// evaluation.
template <TaylorDynamics K, class Observer>
AdaptiveResult<K::nq, nv_of<K>> taylor(double t0, double t1, const StateFor<K>& x0,
                                       const double* u, const double* p,
                                       const AdaptiveOptions& opt, const TaylorOptions& taylor_opt,
                                       Observer&& observer,
                                       const Stabilization& stab = {}) noexcept {
  constexpr int max_order = K::taylor_max_order;
  using Method = Stabilization::Method;
  using Scheme = TaylorOptions::Scheme;
  AdaptiveResult<K::nq, nv_of<K>> r;
  r.t = t0;
  r.x = x0;
  const bool paper = taylor_opt.scheme == Scheme::paper;
  const int fixed = taylor_opt.order;
  const bool order_ok = paper ? fixed >= 0 && fixed + 1 <= max_order
                              : fixed == 0 || (fixed >= 2 && fixed <= max_order);
  const bool scheme_ok = paper || taylor_opt.scheme == Scheme::jorba_zou;
  const bool stab_ok = K::nc == 0 ? stab.method == Method::none : stab.method != Method::baumgarte;
  if (!detail::adaptive_input_ok<K>(t0, t1, x0, opt) || !scheme_ok || !order_ok || !stab_ok) {
    r.status = Status::invalid_argument;
    return r;
  }
  // The highest coefficient each call computes fixes the kernel's workspace.
  const int highest = detail::taylor_highest_order(opt, taylor_opt, max_order);
  std::vector<double> owned;  // stays empty (no allocation) when the caller gave a workspace
  double* work = nullptr;
  if (!detail::taylor_work(taylor_opt.workspace, taylor_workspace_size<K>(highest), owned, work)) {
    r.status = Status::invalid_argument;  // the caller's workspace is too small
    return r;
  }
  if ((r.status = constrained_start<K>(r.x, p, stab)) != Status::ok) return r;
  detail::TaylorStepper<K> s(u, p, opt, taylor_opt, work);
  return detail::adaptive_steps<K>(s, t0, t1, r.x, p, opt, observer, stab);
}

// Order-p Taylor steps of equal size: `steps` steps from t0 to t1, each one coefficient call.
// observer(t, x) at t0 and after every step; projection after each step for constrained models
// as in rk4 (Baumgarte refused). Status::invalid_argument for steps <= 0, an order outside
// [1, taylor_max_order], t1 <= t0, a non-finite t0, t1 or x0, a free joint's quaternion off the
// unit sphere, or a workspace given but smaller than taylor_workspace_size<K>(order) (empty:
// allocated here, see "Memory" above).
template <TaylorDynamics K, class Observer>
AdaptiveResult<K::nq, nv_of<K>> taylor_fixed(double t0, double t1, long steps, int order,
                                             const StateFor<K>& x0, const double* u,
                                             const double* p, Observer&& observer,
                                             const Stabilization& stab = {},
                                             std::span<double> workspace = {}) noexcept {
  constexpr int n = K::nq;
  using Method = Stabilization::Method;
  AdaptiveResult<n, nv_of<K>> r;
  r.t = t0;
  r.x = x0;
  const bool ok = steps > 0 && order >= 1 && order <= K::taylor_max_order &&
                  detail::adaptive_input_ok<K>(t0, t1, x0, AdaptiveOptions{}) &&  // t0, t1, x0
                  (K::nc == 0 ? stab.method == Method::none : stab.method != Method::baumgarte);
  std::vector<double> owned;  // stays empty (no allocation) when the caller gave a workspace
  double* work = nullptr;
  if (!ok || !detail::taylor_work(workspace, taylor_workspace_size<K>(order), owned, work)) {
    r.status = Status::invalid_argument;
    return r;
  }
  if ((r.status = constrained_start<K>(r.x, p, stab)) != Status::ok) return r;
  detail::TaylorSeries<K> series;
  const double h = (t1 - t0) / static_cast<double>(steps);
  observer(r.t, r.x);
  for (long k = 0; k < steps; ++k) {
    const double t = t0 + static_cast<double>(k) * h;
    ++r.evaluations;
    if (!series.compute(order, t, r.x, u, p, work)) {
      r.status = Status::singular_dynamics;
      r.t = t;
      return r;
    }
    series.evaluate(order, h, r.x);
    normalize_state<K>(r.x);
    r.t = k + 1 == steps ? t1 : t + h;
    for (double v : r.x)
      if (!std::isfinite(v)) {
        r.status = Status::non_finite_state;
        return r;
      }
    if constexpr (K::nc > 0)
      if (stab.method == Method::projection &&
          !project<K>(r.x.data(), r.x.data() + n, p, stab.tolerance)) {
        r.status = Status::projection_failed;
        return r;
      }
    ++r.accepted;
    observer(r.t, r.x);
  }
  return r;
}

}  // namespace eom
