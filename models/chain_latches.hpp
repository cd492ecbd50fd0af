// Hinge latches for the planar chains of chain.hpp (eom/integration/locks.hpp): hinge i (i = 2..N, between
// links i−1 and i) locks when its relative angle θᵢ − θᵢ₋₁ reaches the straight position. The
// root pin (hinge 1) stays free. In the chain's absolute angles hinge i's row is
// aᵢ = eᵢ − eᵢ₋₁ (its relative rate is aᵢᵀq̇).
#pragma once

#include <array>
#include <cmath>
#include <numbers>

#include <eom/integration/locks.hpp>

namespace eom::models {

template <int N> struct ChainHingeRows {
  static constexpr int count = N - 1;  // row k: hinge k + 2
  static constexpr std::array<std::array<double, N>, N - 1> rows = [] {
    std::array<std::array<double, N>, N - 1> a{};
    for (int k = 0; k < N - 1; ++k) a[k][k] = -1, a[k][k + 1] = 1;
    return a;
  }();
};

// The straight position each hinge latches at: the multiple of 2π nearest its relative angle
// in q (a hinge stowed at 190° opens to 360°, one at −190° to −360°).
template <int N> std::array<double, N - 1> chain_straight_targets(const double* q) {
  constexpr double turn = 2 * std::numbers::pi;
  std::array<double, N - 1> t{};
  for (int k = 0; k < N - 1; ++k) t[k] = turn * std::round((q[k + 1] - q[k]) / turn);
  return t;
}

// The paper's stow: an accordion hanging from the pin, odd links at −fold, even ones at π + fold
// (folded back on each other), released with θ̇1 = rate.
template <int N> std::array<double, 2 * N> stowed_accordion(double fold, double rate) {
  std::array<double, 2 * N> x{};
  for (int i = 0; i < N; ++i) x[i] = i % 2 == 0 ? -fold : std::numbers::pi + fold;
  x[N] = rate;
  return x;
}

}  // namespace eom::models
