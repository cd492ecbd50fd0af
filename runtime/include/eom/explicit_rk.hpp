// What the explicit Runge–Kutta pairs (dopri5.hpp, dop853.hpp) share: the linear combinations of
// stage derivatives k[j] that make up stage inputs, solutions, error estimates and dense output.
// The weights are a tableau's constexpr rows, passed as template arguments, so which of them
// vanish is known at compile time and the zeros of a sparse tableau cost nothing.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <utility>

namespace eom::detail {

// Σⱼ w[j]·k[j][i], in the order of j, over the nonzero weights only.
template <const auto& w, std::size_t m, std::size_t S>
double weighted_sum(const std::array<std::array<double, m>, S>& k, std::size_t i) noexcept {
  constexpr std::size_t terms = std::min(S, std::size(w));
  double sum = 0;
  [&]<std::size_t... j>(std::index_sequence<j...>) {
    ((w[j] != 0 ? void(sum += w[j] * k[j][i]) : void()), ...);
  }(std::make_index_sequence<terms>{});
  return sum;
}

// out = x + h·Σⱼ w[j]·k[j]: a stage input or a solution.
template <const auto& w, std::size_t m, std::size_t S>
void advance(const std::array<double, m>& x, double h, const std::array<std::array<double, m>, S>& k,
             std::array<double, m>& out) noexcept {
  for (std::size_t i = 0; i < m; ++i) out[i] = x[i] + h * weighted_sum<w>(k, i);
}

// out = h·Σⱼ w[j]·k[j]: an error estimate or a dense-output coefficient.
template <const auto& w, std::size_t m, std::size_t S>
void scaled_sum(double h, const std::array<std::array<double, m>, S>& k,
                std::array<double, m>& out) noexcept {
  for (std::size_t i = 0; i < m; ++i) out[i] = h * weighted_sum<w>(k, i);
}

template <std::size_t m> bool all_finite(const std::array<double, m>& v) noexcept {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

}  // namespace eom::detail
