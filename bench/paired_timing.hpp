// Two routes timed side by side in alternating rounds (by default 1000 calls per round, 201 rounds): the
// figure is the median of the per-round ratios, so that the machine's load changes both sides
// alike. Used by the benchmarks that compare a generated kernel with a baseline in one binary.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

namespace eombench {

inline volatile double sink;  // results go here, so that the compiler keeps the calls

template <class F> double seconds_per_call(F&& f, int calls) {
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < calls; ++i) f(i);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / calls;
}

// Prints the median times of a and b (ns) and the median of the per-round ratios a / b; fewer
// calls and rounds for routes of milliseconds.
template <class A, class B>
void compare(const char* what, A&& a, B&& b, int calls = 1000, int rounds = 201) {
  std::vector<double> ratio, ta, tb;
  for (int r = 0; r < rounds; ++r) {
    const double x = seconds_per_call(a, calls), y = seconds_per_call(b, calls);
    ta.push_back(x);
    tb.push_back(y);
    ratio.push_back(x / y);
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  // (three decimals: a target such as 0.25 is decided on them, not on a rounded 0.25)
  std::printf("%-62s %8.1f ns %8.1f ns   ratio %.3f\n", what, 1e9 * median(ta), 1e9 * median(tb),
              median(ratio));
}

}  // namespace eombench
