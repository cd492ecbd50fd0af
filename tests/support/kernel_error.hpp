// The error measure of the kernel tests: e = max_i |g_i − r_i| / max(1, max_i |r_i|), norm-wise
// against the reference r; NaN anywhere counts as infinitely wrong.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace eomtest {

inline double kernel_error(const double* g, const double* r, int n) {
  double diff = 0, size = 1;
  for (int i = 0; i < n; ++i) {
    const double d = std::abs(g[i] - r[i]);
    if (std::isnan(d)) return std::numeric_limits<double>::infinity();
    diff = std::max(diff, d);
    size = std::max(size, std::abs(r[i]));
  }
  return diff / size;
}

}  // namespace eomtest
