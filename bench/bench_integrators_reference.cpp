// The reference for bench_integrators: the chaotic double pendulum in double-double by
// Gragg–Bulirsch–Stoer extrapolation (eom/integration/high_precision.hpp) at tolerance 1e-28 per step.
// Its own translation unit, compiled with -ffp-contract=off: with -march=native the compiler
// would otherwise fuse qd's inline error-free transformations (two_sum, two_prod) into FMAs,
// which destroys the double-double arithmetic (the integration then fails with a step size
// underflow).
#include <qd/dd_real.h>

#include <array>
#include <cstdio>
#include <vector>

#include <eom/integration/high_precision.hpp>

#include <models/double_pendulum.hpp>

std::array<double, 4> double_pendulum_reference(const std::array<double, 4>& x0, double t) {
  using DP = eom::models::DoublePendulum;
  std::array<dd_real, 4> xw;
  std::array<dd_real, 5> pw;
  for (int i = 0; i < 4; ++i) xw[i] = dd_real(x0[i]);
  for (int i = 0; i < 5; ++i) pw[i] = dd_real(DP::parameter_values[i]);
  std::array<double, 4> out{};
  const std::vector<double> times{t};
  eom::ExtrapolationOptions opt;
  opt.tolerance = 1e-28;
  const auto r = eom::extrapolate<DP, dd_real>(0.0, xw, times, nullptr, pw.data(), opt,
                                               [&](double, const std::array<dd_real, 4>& x) {
                                                 for (int i = 0; i < 4; ++i) out[i] = to_double(x[i]);
                                               });
  if (r.status != eom::Status::ok)
    std::fprintf(stderr, "double-double reference failed: %s\n", eom::to_string(r.status));
  return out;
}
