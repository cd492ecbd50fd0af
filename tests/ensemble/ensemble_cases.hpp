// The deployment ensemble shared by the ensemble tests and the benchmark: the paper's 10-link
// deployment (generated chain10 kernels) from its stowed start, each case with its own release
// rate θ̇1 and its own link masses, so that cases differ (also in cost for adaptive methods).
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <chain10.hpp>

#include <eom/ensemble/ensemble.hpp>

namespace eom_ensemble_cases {

struct Deployment {
  using K = chain10::Kernels;
  static constexpr int nq = K::nq, np = K::np;
  std::vector<eom::StateOf<nq>> x0;
  std::vector<double> p;  // np per case
  eom::EnsembleCases<nq> cases() const { return {x0, p, {}}; }
};

inline Deployment deployment(std::size_t n) {
  Deployment d;
  d.x0.resize(n);
  d.p.resize(n * Deployment::np);
  for (std::size_t c = 0; c < n; ++c) {
    auto& x = d.x0[c];
    for (int i = 0; i < 10; ++i) x[i] = i % 2 == 0 ? -0.08726646259971647 : 3.2288591161895095;
    x[10] = -0.05 - 0.01 * static_cast<double>(c % 7);
    double* p = d.p.data() + c * Deployment::np;
    for (int i = 0; i < Deployment::np; ++i) p[i] = chain10::parameter_values[i];
    for (int i = 0; i < 10; ++i) p[i] *= 1.0 + 0.05 * static_cast<double>((c + i) % 5);  // masses
  }
  return d;
}

// Bitwise equality of two results (fields one by one: the struct has padding).
template <int nq>
bool same_bits(const eom::IntegrationResult<nq>& a, const eom::IntegrationResult<nq>& b) {
  bool same = a.status == b.status && std::bit_cast<std::uint64_t>(a.t) == std::bit_cast<std::uint64_t>(b.t) &&
              a.accepted == b.accepted && a.rejected == b.rejected && a.evaluations == b.evaluations;
  for (int i = 0; i < 2 * nq; ++i)
    same = same && std::bit_cast<std::uint64_t>(a.x[i]) == std::bit_cast<std::uint64_t>(b.x[i]);
  return same;
}
template <std::size_t m> bool same_bits(const std::array<double, m>& a, const std::array<double, m>& b) {
  for (std::size_t i = 0; i < m; ++i)
    if (std::bit_cast<std::uint64_t>(a[i]) != std::bit_cast<std::uint64_t>(b[i])) return false;
  return true;
}

}  // namespace eom_ensemble_cases
