// One case of an ensemble as a GPU thread runs it (eom/ensemble/cuda/ensemble.hpp), in code that any
// compiler builds: held inputs, fixed-step RK4 or adaptive dopri5, samples at given times by each
// method's dense output, no stabilization. It repeats, operation for operation, what
// eom::integrate does for such a case (integrate.hpp, rk4.hpp, explicit_rk.hpp, dopri5.hpp,
// adaptive.hpp, state.hpp, free_joint.hpp): compiled by the host compiler without floating-point
// contraction it gives eom::ensemble's results bit for bit (tests/cuda/test_cuda_case.cpp checks
// it); on a GPU the same arithmetic differs only where the device's sin, cos, pow and sqrt round
// differently from the host's libm.
//
// Why a copy and not the runtime's own integrators: those are host code (std::array, std::span,
// lambdas and observers over the standard library), and marking every function they share
// __host__ __device__ would change headers every integrator uses. This file keeps to what a device
// runs: plain arrays, no allocation, no standard-library calls but <cmath>'s.
//
// The model's forward dynamics come from K::forward_dynamics with the case's parameter-only values
// in pc (`K::forward_dynamics_parameter_cache` doubles, K::forward_dynamics_prepare(p, pc)) when the
// kernel has a parameter cache, else from the plain kernel: neither touches a thread_local.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>

#include "eom/integration/state.hpp"
#include "eom/model/kernels.hpp"

#if !defined(EOM_HOST_DEVICE)
#if defined(__CUDACC__)
#define EOM_HOST_DEVICE __host__ __device__
#else
#define EOM_HOST_DEVICE
#endif
#endif

namespace eom::cuda {

// Whether K's forward_dynamics has a parameter cache (and so the overload taking pc).
template <class K>
inline constexpr int parameter_cache_of = [] {
  if constexpr (requires { K::forward_dynamics_parameter_cache; })
    return static_cast<int>(K::forward_dynamics_parameter_cache);
  else
    return 0;
}();

// What every case shares: the time span, the method's settings (IntegrationOptions' step, rtol,
// atol, max_steps) and the sample times.
struct CaseSettings {
  double t0 = 0, t1 = 0;
  double step = 0, rtol = 1e-8, atol = 1e-10;
  long max_steps = 1000000;
  const double* times = nullptr;  // sample times, ascending in [t0, t1]
  int samples = 0;
};

// One case's inputs: u (K::nu), p (K::np), pc (K::forward_dynamics_parameter_cache values prepared
// from p, or null when the kernel has no cache), and the status of the constrained start, computed
// beforehand (eom::constrained_start: a constrained model's check of its initial state needs the
// constraint kernels; ok for a model without constraints).
struct CaseInputs {
  const double* u = nullptr;
  const double* p = nullptr;
  const double* pc = nullptr;
  Status start = Status::ok;
};

// What eom::integrate reports for the case; its state is the caller's x.
struct CaseResult {
  Status status = Status::ok;
  double t = 0;
  long accepted = 0, rejected = 0, evaluations = 0;
};

namespace detail {

// std::max and std::min, as they compare (NaN and signed zeros included).
EOM_HOST_DEVICE inline double max(double a, double b) noexcept { return (a < b) ? b : a; }
EOM_HOST_DEVICE inline double min(double a, double b) noexcept { return (b < a) ? b : a; }

template <class K> struct Sizes {
  static constexpr int nq = K::nq, nv = nv_of<K>, m = nq + nv;
  static constexpr bool free_joint = nq == nv + 1;
  static_assert(layout_of<K>().free_joint_only(),
                "eom CUDA ensembles: ball joints are not supported yet (the free joint's quaternion "
                "only)");
};

// free_joint.hpp's quaternion_norm_error, normalize_configuration and configuration_rate.
template <class K> EOM_HOST_DEVICE bool unit_quaternion(const double* x) noexcept {
  if constexpr (!Sizes<K>::free_joint) {
    (void)x;
    return true;
  } else {
    const double e = std::abs(std::sqrt(x[3] * x[3] + x[4] * x[4] + x[5] * x[5] + x[6] * x[6]) - 1.0);
    return e <= quaternion_norm_tolerance;
  }
}
template <class K> EOM_HOST_DEVICE void normalize_state(double* x) noexcept {
  if constexpr (Sizes<K>::free_joint) {
    const double n = std::sqrt(x[3] * x[3] + x[4] * x[4] + x[5] * x[5] + x[6] * x[6]);
    if (!(n > 0.0) || !(n < 1e300)) return;
    for (int i = 3; i < 7; ++i) x[i] = x[i] / n;
  } else {
    (void)x;
  }
}

// ẋ = (G(q) v, v̇): state.hpp's state_derivative without stabilization.
template <class K>
EOM_HOST_DEVICE bool derivative(double t, const double* x, const CaseInputs& in, double* dx) noexcept {
  using S = Sizes<K>;
  const double* q = x;
  const double* v = x + S::nq;
  if constexpr (!S::free_joint) {
    for (int i = 0; i < S::nq; ++i) dx[i] = v[i];
  } else {
    for (int i = 0; i < 3; ++i) dx[i] = v[i];
    const double* a = q + 3;  // the quaternion, scalar first
    const double* w = v + 3;
    const double r[4] = {-(a[1] * w[0] + a[2] * w[1] + a[3] * w[2]), a[0] * w[0] + a[2] * w[2] - a[3] * w[1],
                         a[0] * w[1] + a[3] * w[0] - a[1] * w[2], a[0] * w[2] + a[1] * w[1] - a[2] * w[0]};
    for (int i = 0; i < 4; ++i) dx[3 + i] = 0.5 * r[i];
    for (int i = 6; i < S::nv; ++i) dx[i + 1] = v[i];
  }
  if constexpr (parameter_cache_of<K> > 0)
    return K::forward_dynamics(t, q, v, in.u, in.p, dx + S::nq, in.pc);
  else
    return K::forward_dynamics(t, q, v, in.u, in.p, dx + S::nq);
}

template <int m> EOM_HOST_DEVICE bool all_finite(const double* x) noexcept {
  for (int i = 0; i < m; ++i)
    if (!std::isfinite(x[i])) return false;
  return true;
}

// adaptive.hpp's adaptive_input_ok (the options' tolerances and initial step included, as
// eom::integrate checks them for every method).
template <class K>
EOM_HOST_DEVICE bool input_ok(const CaseSettings& s, const double* x0) noexcept {
  bool ok = std::isfinite(s.t0) && std::isfinite(s.t1) && s.t1 > s.t0 && unit_quaternion<K>(x0);
  for (int i = 0; i < Sizes<K>::m; ++i) ok = ok && std::isfinite(x0[i]);
  ok = ok && std::isfinite(s.rtol) && std::isfinite(s.atol) && s.rtol > 0 && s.atol > 0 &&
       std::isfinite(s.step) && s.step >= 0 && s.max_steps > 0;
  double previous = s.t0;
  for (int k = 0; k < s.samples; ++k) {
    const double t = s.times[k];
    ok = ok && std::isfinite(t) && t >= previous && t <= s.t1;
    previous = t;
  }
  return ok;
}

// integrate.hpp's fixed_step_count.
EOM_HOST_DEVICE inline long fixed_step_count(double t0, double t1, double step) noexcept {
  if (!(std::isfinite(step) && step > 0 && t1 > t0)) return 0;
  const double count = std::ceil((t1 - t0) / step * (1 - 1e-12));
  return count >= 1 && count < 9e15 ? static_cast<long>(count) : 0;
}

// adaptive.hpp's OutputSchedule: which sample comes next, handed to out.sample(k, x).
template <class K, class Out> struct Schedule {
  static constexpr int m = Sizes<K>::m;
  const CaseSettings& s;
  Out& out;
  int next = 0;

  EOM_HOST_DEVICE bool dense() const noexcept { return s.samples > 0; }
  EOM_HOST_DEVICE bool interpolates_before(double t_end) const noexcept {
    return next < s.samples && s.times[next] < t_end;
  }
  EOM_HOST_DEVICE void start(double t0, const double* x0) noexcept {
    for (; next < s.samples && s.times[next] <= t0; ++next) out.sample(next, x0);
  }
  // interpolate(t, x) fills x at t inside the step that ended at t_end.
  template <class Interpolate>
  EOM_HOST_DEVICE void step(double t_end, const double* x_end, bool last, Interpolate& interpolate) noexcept {
    double x[m];
    for (; next < s.samples && (s.times[next] < t_end || last); ++next) {
      if (s.times[next] >= t_end) {
        out.sample(next, x_end);
        continue;
      }
      interpolate(s.times[next], x);
      out.sample(next, x);
    }
    for (; next < s.samples && s.times[next] == t_end; ++next) out.sample(next, x_end);
  }
};

// The cubic Hermite interpolant of integrate.hpp's HermiteOutput over a step [ta, tb] of RK4, from
// the states and their derivatives at both ends (evaluated once per step that holds a sample).
template <class K> struct HermiteStep {
  static constexpr int m = Sizes<K>::m;
  const CaseInputs& in;
  long& evaluations;
  double ta, tb;
  const double* xa;
  const double* xb;
  double fa[m], fb[m];
  bool have = false;

  EOM_HOST_DEVICE HermiteStep(const CaseInputs& in_, long& evaluations_, double ta_, double tb_,
                              const double* xa_, const double* xb_) noexcept
      : in(in_), evaluations(evaluations_), ta(ta_), tb(tb_), xa(xa_), xb(xb_) {}

  EOM_HOST_DEVICE void operator()(double s, double* out) noexcept {
    if (!have) {
      evaluations += 2;
      have = true;
      if (!derivative<K>(ta, xa, in, fa))
        for (int i = 0; i < m; ++i) fa[i] = std::numeric_limits<double>::quiet_NaN();
      if (!derivative<K>(tb, xb, in, fb))
        for (int i = 0; i < m; ++i) fb[i] = std::numeric_limits<double>::quiet_NaN();
    }
    const double h = tb - ta, th = (s - ta) / h;
    const double h00 = (1 + 2 * th) * (1 - th) * (1 - th), h10 = th * (1 - th) * (1 - th);
    const double h01 = th * th * (3 - 2 * th), h11 = th * th * (th - 1);
    for (int i = 0; i < m; ++i) out[i] = h00 * xa[i] + h10 * h * fa[i] + h01 * xb[i] + h11 * h * fb[i];
    normalize_state<K>(out);
  }
};

// ‖e‖ of adaptive.hpp's error_norm.
template <int m>
EOM_HOST_DEVICE double error_norm(const double* e, const double* a, const double* b, double rtol,
                                  double atol) noexcept {
  double s = 0;
  for (int i = 0; i < m; ++i) {
    const double w = e[i] / (atol + rtol * max(std::abs(a[i]), std::abs(b[i])));
    s += w * w;
  }
  return std::sqrt(s / static_cast<double>(m));
}

}  // namespace detail

// Fixed-step RK4 from s.t0 to s.t1 (IntegrationOptions::step rounded so that the steps divide the
// span), as eom::integrate with Method::rk4: x holds the initial state and gets the state reached;
// out.sample(k, x) receives the state at s.times[k] (cubic Hermite dense output). Samples a case
// never reaches are not written.
template <Dynamics K, class Out>
EOM_HOST_DEVICE CaseResult rk4_case(const CaseSettings& s, const CaseInputs& in, double* x, Out& out) noexcept {
  using S = detail::Sizes<K>;
  constexpr int m = S::m;
  CaseResult r;
  r.t = s.t0;
  const long steps = detail::fixed_step_count(s.t0, s.t1, s.step);
  if (!detail::input_ok<K>(s, x) || steps == 0) {
    r.status = Status::invalid_argument;
    return r;
  }
  if (steps > s.max_steps) {
    r.status = Status::step_limit;
    return r;
  }
  // rk4(): its own checks (passed: the same as above), then the constrained start.
  detail::normalize_state<K>(x);
  if ((r.status = in.start) != Status::ok) return r;
  const double h = (s.t1 - s.t0) / static_cast<double>(steps);
  detail::Schedule<K, Out> schedule{s, out};
  schedule.start(s.t0, x);
  double previous[m];  // the last step's start, for the dense output
  double t_previous = s.t0;
  if (schedule.dense())
    for (int i = 0; i < m; ++i) previous[i] = x[i];
  long dense_evaluations = 0;
  double k0[m], k1[m], k2[m], k3[m], y[m];
  for (long k = 0; k < steps; ++k) {
    const double t = s.t0 + static_cast<double>(k) * h;
    // rk4_step: x changes only when every stage succeeded
    bool ok = detail::derivative<K>(t, x, in, k0);
    if (ok) {
      for (int i = 0; i < m; ++i) y[i] = x[i] + 0.5 * h * k0[i];
      ok = detail::derivative<K>(t + 0.5 * h, y, in, k1);
    }
    if (ok) {
      for (int i = 0; i < m; ++i) y[i] = x[i] + 0.5 * h * k1[i];
      ok = detail::derivative<K>(t + 0.5 * h, y, in, k2);
    }
    if (ok) {
      for (int i = 0; i < m; ++i) y[i] = x[i] + 1.0 * h * k2[i];
      ok = detail::derivative<K>(t + h, y, in, k3);
    }
    if (!ok) {
      r.status = Status::singular_dynamics;
      r.t = t;
      r.evaluations = 4 * r.accepted + dense_evaluations;
      return r;
    }
    for (int i = 0; i < m; ++i) x[i] += h / 6.0 * (k0[i] + 2.0 * k1[i] + 2.0 * k2[i] + k3[i]);
    detail::normalize_state<K>(x);
    if (!detail::all_finite<m>(x)) {
      r.status = Status::non_finite_state;
      r.t = t + h;
      r.evaluations = 4 * r.accepted + dense_evaluations;
      return r;
    }
    r.t = k + 1 == steps ? s.t1 : t + h;
    ++r.accepted;
    if (schedule.dense()) {
      detail::HermiteStep<K> interpolate{in, dense_evaluations, t_previous, r.t, previous, x};
      schedule.step(r.t, x, r.t >= s.t1, interpolate);
      t_previous = r.t;
      for (int i = 0; i < m; ++i) previous[i] = x[i];
    }
  }
  r.evaluations = 4 * r.accepted + dense_evaluations;
  return r;
}

// Its state: what one dopri5 case keeps between steps (about 17·m doubles).
template <class K> struct Dopri5State {
  static constexpr int m = detail::Sizes<K>::m;
  double k[7][m];     // the stages; k[0] = f at the step's start
  double x_new[m];    // the attempted step's 5th-order solution
  double x_end[m];    // the same, normalized (free joint)
  double y[m];        // a stage's input; the error estimate
  double dense[5][m];  // the continuous extension of the last accepted step
};

// Adaptive Dormand–Prince 5(4) from s.t0 to s.t1 (rtol, atol; s.step the initial step, 0: Hairer's
// starting step), as eom::integrate with Method::dopri5: x holds the initial state and gets the
// state reached; out.sample(k, x) the state at s.times[k] (the 4th-order continuous extension).
// w: the method's arrays (the caller's, e.g. on the thread's stack).
template <Dynamics K, class Out>
EOM_HOST_DEVICE CaseResult dopri5_case(const CaseSettings& s, const CaseInputs& in, double* x, Out& out,
                                       Dopri5State<K>& w) noexcept {
  constexpr int m = detail::Sizes<K>::m;
  // The tableau (dopri5.hpp's Dopri5Tableau), as scalars: a device reads no constexpr arrays.
  constexpr double c2 = 1.0 / 5, c3 = 3.0 / 10, c4 = 4.0 / 5, c5 = 8.0 / 9;
  constexpr double a21 = 1.0 / 5;
  constexpr double a31 = 3.0 / 40, a32 = 9.0 / 40;
  constexpr double a41 = 44.0 / 45, a42 = -56.0 / 15, a43 = 32.0 / 9;
  constexpr double a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561, a54 = -212.0 / 729;
  constexpr double a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247, a64 = 49.0 / 176,
                   a65 = -5103.0 / 18656;
  constexpr double b1 = 35.0 / 384, b3 = 500.0 / 1113, b4 = 125.0 / 192, b5 = -2187.0 / 6784, b6 = 11.0 / 84;
  constexpr double e1 = 35.0 / 384 - 5179.0 / 57600, e3 = 500.0 / 1113 - 7571.0 / 16695,
                   e4 = 125.0 / 192 - 393.0 / 640, e5 = -2187.0 / 6784 + 92097.0 / 339200,
                   e6 = 11.0 / 84 - 187.0 / 2100, e7 = -1.0 / 40;
  constexpr double d1 = -12715105075.0 / 11282082432, d3 = 87487479700.0 / 32700410799,
                   d4 = -10690763975.0 / 1880347072, d5 = 701980252875.0 / 199316789632,
                   d6 = -1453857185.0 / 822651844, d7 = 69997945.0 / 29380423;
  CaseResult r;
  r.t = s.t0;
  long evaluations = 0;
  const auto f = [&](double t, const double* state, double* dx) {
    ++evaluations;
    return detail::derivative<K>(t, state, in, dx);
  };
  const auto end = [&](Status status) {
    r.status = status;
    r.evaluations = evaluations;
    return r;
  };
  // adaptive_start: the input, then the constrained start
  if (!detail::input_ok<K>(s, x)) {
    r.status = Status::invalid_argument;
    return r;
  }
  detail::normalize_state<K>(x);
  if ((r.status = in.start) != Status::ok) return r;
  auto& k = w.k;
  // The first step: the given one, or Hairer's starting step (adaptive.hpp's starting_step).
  double h = s.step;
  if (!f(s.t0, x, k[0])) return end(Status::singular_dynamics);
  if (!(h > 0)) {
    const double span = s.t1 - s.t0;
    const double d0 = detail::error_norm<m>(x, x, x, s.rtol, s.atol);
    const double d1n = detail::error_norm<m>(k[0], x, x, s.rtol, s.atol);
    const double h0 = detail::min(d0 < 1e-5 || d1n < 1e-5 ? 1e-6 : 0.01 * d0 / d1n, span);
    double* probe = w.y;
    double* dx_probe = w.x_new;
    for (int i = 0; i < m; ++i) probe[i] = x[i] + h0 * k[0][i];
    if (!f(s.t0 + h0, probe, dx_probe)) return end(Status::singular_dynamics);
    for (int i = 0; i < m; ++i) probe[i] = (dx_probe[i] - k[0][i]) / h0;
    const double d2 = detail::error_norm<m>(probe, x, x, s.rtol, s.atol), dmax = detail::max(d1n, d2);
    const double h1 = dmax <= 1e-15 ? detail::max(1e-6, h0 * 1e-3) : std::pow(0.01 / dmax, 1.0 / 5);
    h = detail::min(100 * h0, h1);
  }
  detail::Schedule<K, Out> schedule{s, out};
  schedule.start(s.t0, x);
  // The continuous extension of the step [t_step, t_step + h_step] (dopri5.hpp's interpolate).
  double t_step = 0, h_step = 0;
  struct Interpolate {
    const Dopri5State<K>& w;
    const double& t_step;
    const double& h_step;
    EOM_HOST_DEVICE void operator()(double t_out, double* out) const noexcept {
      const double theta = (t_out - t_step) / h_step;
      const double rest = 1 - theta;
      for (int i = 0; i < m; ++i)
        out[i] = w.dense[0][i] +
                 theta * (w.dense[1][i] + rest * (w.dense[2][i] + theta * (w.dense[3][i] + rest * w.dense[4][i])));
      detail::normalize_state<K>(out);
    }
  } interpolate{w, t_step, h_step};
  bool after_rejection = false;
  while (r.t < s.t1) {
    // step_allowed
    if (r.accepted + r.rejected >= s.max_steps) return end(Status::step_limit);
    const double h_min =
        16 * std::numeric_limits<double>::epsilon() * detail::max(1.0, std::abs(r.t));
    if (!(h >= h_min)) return end(Status::step_size_underflow);
    const bool last = r.t + h >= s.t1;
    if (last) h = s.t1 - r.t;
    const double t = r.t, t_end = last ? s.t1 : t + h;
    // The attempt (Dopri5Step::attempt): stages 2–7, each stage's weighted sum over its nonzero
    // weights in order, as explicit_rk.hpp's weighted_sum adds them.
    t_step = t, h_step = h;
    double* y = w.y;
    double e = std::numeric_limits<double>::infinity();
    bool ok = true;
    for (int i = 0; i < m; ++i) {
      double sum = 0;
      sum += a21 * k[0][i];
      y[i] = x[i] + h * sum;
    }
    ok = f(t + c2 * h, y, k[1]);
    if (ok) {
      for (int i = 0; i < m; ++i) {
        double sum = 0;
        sum += a31 * k[0][i];
        sum += a32 * k[1][i];
        y[i] = x[i] + h * sum;
      }
      ok = f(t + c3 * h, y, k[2]);
    }
    if (ok) {
      for (int i = 0; i < m; ++i) {
        double sum = 0;
        sum += a41 * k[0][i];
        sum += a42 * k[1][i];
        sum += a43 * k[2][i];
        y[i] = x[i] + h * sum;
      }
      ok = f(t + c4 * h, y, k[3]);
    }
    if (ok) {
      for (int i = 0; i < m; ++i) {
        double sum = 0;
        sum += a51 * k[0][i];
        sum += a52 * k[1][i];
        sum += a53 * k[2][i];
        sum += a54 * k[3][i];
        y[i] = x[i] + h * sum;
      }
      ok = f(t + c5 * h, y, k[4]);
    }
    if (ok) {
      for (int i = 0; i < m; ++i) {
        double sum = 0;
        sum += a61 * k[0][i];
        sum += a62 * k[1][i];
        sum += a63 * k[2][i];
        sum += a64 * k[3][i];
        sum += a65 * k[4][i];
        y[i] = x[i] + h * sum;
      }
      ok = f(t + 1.0 * h, y, k[5]);
    }
    if (ok) {
      for (int i = 0; i < m; ++i) {
        double sum = 0;
        sum += b1 * k[0][i];
        sum += b3 * k[2][i];
        sum += b4 * k[3][i];
        sum += b5 * k[4][i];
        sum += b6 * k[5][i];
        w.x_new[i] = x[i] + h * sum;
      }
      ok = f(t + h, w.x_new, k[6]);
    }
    if (ok) {
      for (int i = 0; i < m; ++i) {  // the error estimate, in y
        double sum = 0;
        sum += e1 * k[0][i];
        sum += e3 * k[2][i];
        sum += e4 * k[3][i];
        sum += e5 * k[4][i];
        sum += e6 * k[5][i];
        sum += e7 * k[6][i];
        y[i] = h * sum;
      }
      e = detail::error_norm<m>(y, x, w.x_new, s.rtol, s.atol);
    }
    for (int i = 0; i < m; ++i) w.x_end[i] = w.x_new[i];
    if (e <= 1.0) detail::normalize_state<K>(w.x_end);  // after the error estimate
    if (!(e <= 1.0)) {
      ++r.rejected;
      after_rejection = true;
      h *= !std::isfinite(e) ? 0.25 : detail::max(0.2, 0.9 * std::pow(e, -0.2));
      continue;
    }
    if (schedule.interpolates_before(t_end)) {  // Dopri5Step::prepare_dense, from the step's start
      for (int i = 0; i < m; ++i) {
        double sum = 0;
        sum += d1 * k[0][i];
        sum += d3 * k[2][i];
        sum += d4 * k[3][i];
        sum += d5 * k[4][i];
        sum += d6 * k[5][i];
        sum += d7 * k[6][i];
        w.dense[4][i] = h * sum;
      }
      for (int i = 0; i < m; ++i) {
        w.dense[0][i] = x[i];
        w.dense[1][i] = w.x_new[i] - x[i];
        w.dense[2][i] = h * k[0][i] - w.dense[1][i];
        w.dense[3][i] = w.dense[1][i] - h * k[6][i] - w.dense[2][i];
      }
    }
    r.t = t_end;
    for (int i = 0; i < m; ++i) x[i] = w.x_end[i];
    for (int i = 0; i < m; ++i) k[0][i] = k[6][i];  // FSAL
    ++r.accepted;
    schedule.step(r.t, x, last, interpolate);
    if (last) break;
    const double growth = detail::min(5.0, detail::max(0.2, 0.9 * std::pow(detail::max(e, 1e-10), -0.2)));
    h = h * growth;
    after_rejection = false;
  }
  (void)after_rejection;  // dopri5 does not cap the growth after a rejection
  return end(Status::ok);
}

// The methods a GPU case runs.
enum class CaseMethod { rk4, dopri5 };

// One case from start to end, as a GPU thread runs it: the method's arrays on the stack, the
// parameter cache prepared from in.p unless in.pc already holds it (a shared p, prepared once).
template <Dynamics K, CaseMethod method, class Out>
EOM_HOST_DEVICE CaseResult integrate_case(const CaseSettings& s, CaseInputs in, double* x, Out& out) noexcept {
  constexpr int cache = parameter_cache_of<K>;
  double pc[cache > 0 ? cache : 1];
  if constexpr (cache > 0)
    if (in.pc == nullptr) {
      K::forward_dynamics_prepare(in.p, pc);
      in.pc = pc;
    }
  if constexpr (method == CaseMethod::rk4) {
    return rk4_case<K>(s, in, x, out);
  } else {
    Dopri5State<K> w;
    return dopri5_case<K>(s, in, x, out, w);
  }
}

}  // namespace eom::cuda
