// The references of the work-precision study: each problem integrated in a wider type by
// Gragg–Bulirsch–Stoer extrapolation (eom/integration/high_precision.hpp) over eom::Reference<Model, Real>.
// Small models run in double-double (qd's dd_real, tolerance 1e-28). The chains and the stiff
// spring pendulum run in long double (64-bit mantissa, tolerance 1e-17): dd_real AD on a 10-link
// body-form chain costs minutes per run, the stiff model needs ~1e5 extrapolation steps
// (stability, not accuracy; its round-off then limits the tolerance to 1e-15), and both are far
// below what double-precision runs reach.
// Each reference is computed twice (tolerance and 1e4 × tolerance) and the difference reported:
// it bounds the reference's own error.
//
// Its own translation unit, compiled with -ffp-contract=off: with -march=native the compiler
// would otherwise fuse qd's error-free transformations (two_sum, two_prod) into FMAs, which
// destroys double-double arithmetic.
#include "work_precision.hpp"

#include <qd/dd_real.h>

#include <chrono>
#include <cstdio>

#include <eom/integration/high_precision.hpp>

#include <models/chain.hpp>
#include <models/double_pendulum.hpp>
#include <models/spring_pendulum.hpp>

namespace {

template <class Model, class Real>
std::vector<double> solve(const std::vector<double>& x0, const std::vector<double>& p, double t1,
                          double tolerance, double* self_difference) {
  constexpr int m = 2 * eom::ModelInfo<Model>::nq;
  std::array<Real, m> xw;
  std::vector<Real> pw(p.size());
  for (int i = 0; i < m; ++i) xw[i] = Real(x0[i]);
  for (std::size_t i = 0; i < p.size(); ++i) pw[i] = Real(p[i]);
  const std::vector<double> times{t1};
  auto run = [&](double tol, std::array<Real, m>& out) {
    eom::ExtrapolationOptions opt;
    opt.tolerance = tol;
    opt.max_steps = 10000000;
    const auto r = eom::extrapolate<Model, Real>(0.0, xw, times, nullptr, pw.data(), opt,
                                                 [&](double, const auto& x) { out = x; });
    return r.status;
  };
  std::array<Real, m> tight{}, loose{};
  const eom::Status a = run(tolerance, tight), b = run(tolerance * 1e4, loose);
  if (a != eom::Status::ok || b != eom::Status::ok) {
    std::fprintf(stderr, "reference failed: %s / %s\n", eom::to_string(a), eom::to_string(b));
    return {};
  }
  std::vector<double> out(m);
  double diff = 0;
  using std::abs;
  for (int i = 0; i < m; ++i) {
    out[i] = eom::as_double(tight[i]);
    diff = std::max(diff, eom::as_double(abs(tight[i] - loose[i])));
  }
  *self_difference = diff;
  return out;
}

}  // namespace

std::vector<double> reference_state(ReferenceModel model, const std::vector<double>& x0,
                                    const std::vector<double>& p, double t1, double* self_difference) {
  switch (model) {
    case ReferenceModel::spring_pendulum:
      return solve<eom::models::SpringPendulum, dd_real>(x0, p, t1, 1e-28, self_difference);
    case ReferenceModel::stiff_spring_pendulum:  // round-off of the stiff midpoint chain: 1e-15
      return solve<eom::models::SpringPendulum, long double>(x0, p, t1, 1e-15, self_difference);
    case ReferenceModel::double_pendulum:
      return solve<eom::models::DoublePendulum, dd_real>(x0, p, t1, 1e-28, self_difference);
    case ReferenceModel::chain10:
      return solve<eom::models::Chain<10>, long double>(x0, p, t1, 1e-17, self_difference);
    case ReferenceModel::closed_chain5:
      return solve<eom::models::ClosedChain5, long double>(x0, p, t1, 1e-17, self_difference);
  }
  return {};
}
