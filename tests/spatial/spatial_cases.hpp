// The spatial test models as cases: both forms (model types, generated Kernels, eom::Reference)
// and where their random states and parameters live. Shared by the tests of tests/spatial.
#pragma once

#include <array>
#include <cmath>
#include <numbers>
#include <random>

// The generated headers ...
#include <spatial_chain4.hpp>
#include <spatial_chain4_energy.hpp>
#include <spatial_top.hpp>
#include <spatial_top_energy.hpp>
#include <spatial_upend.hpp>
#include <spatial_upend_energy.hpp>
// ... and the models they were generated from.
#include "spatial_chain.hpp"
#include "symmetric_top.hpp"
#include "universal_pendulum.hpp"

#include <eom/reference/reference.hpp>

namespace spatial_test {

inline double uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

struct TopCase {
  static constexpr const char* name = "symmetric_top";
  using Body = SymmetricTop;
  using Energy = SymmetricTopEnergy;
  using GenBody = spatial_top::Kernels;
  using GenEnergy = spatial_top_energy::Kernels;
  static constexpr int nq = 3, np = 5;
  // θ away from 0 and π, where the ZYZ angles are singular (M = 0 along ψ̇ − φ̇ at θ = 0).
  static void sample_q(std::mt19937_64& rng, double* q) {
    q[0] = uniform(rng, -std::numbers::pi, std::numbers::pi);
    q[1] = uniform(rng, 0.3, std::numbers::pi - 0.3);
    q[2] = uniform(rng, -std::numbers::pi, std::numbers::pi);
  }
  // m, l, I1 within ±20 % of the defaults; I3 between ½ I1 and 1.8 I1 (a realizable top needs
  // I3 ≤ 2 I1); g as given.
  static void sample_p(std::mt19937_64& rng, double* p) {
    const auto& d = Body::parameter_values;
    for (int i = 0; i < 3; ++i) p[i] = d[i] * uniform(rng, 0.8, 1.2);
    p[3] = p[2] * uniform(rng, 0.5, 1.8);
    p[4] = d[4];
  }
};

struct UniversalPendulumCase {
  static constexpr const char* name = "universal_pendulum";
  using Body = UniversalPendulum;
  using Energy = UniversalPendulumEnergy;
  using GenBody = spatial_upend::Kernels;
  using GenEnergy = spatial_upend_energy::Kernels;
  static constexpr int nq = 4, np = 22;
  // M is positive definite at every angle (J1, J2 are).
  static void sample_q(std::mt19937_64& rng, double* q) {
    for (int i = 0; i < nq; ++i) q[i] = uniform(rng, -std::numbers::pi, std::numbers::pi);
  }
  // Masses, L1 and each offset component within ±20 %; each inertia tensor scaled as a whole
  // (which keeps it realizable); g as given.
  static void sample_p(std::mt19937_64& rng, double* p) {
    const auto& d = Body::parameter_values;
    for (int i = 0; i < 9; ++i) p[i] = d[i] * uniform(rng, 0.8, 1.2);
    for (int body = 0; body < 2; ++body) {
      const double f = uniform(rng, 0.8, 1.2);
      for (int k = 0; k < 6; ++k) p[9 + 6 * body + k] = d[9 + 6 * body + k] * f;
    }
    p[21] = d[21];
  }
};

struct ChainCase {
  static constexpr const char* name = "spatial_chain4";
  using Body = SpatialChain<4>;
  using Energy = ChainEnergy<4>;
  using GenBody = spatial_chain4::Kernels;
  using GenEnergy = spatial_chain4_energy::Kernels;
  static constexpr int nq = 4, np = 17;
  static void sample_q(std::mt19937_64& rng, double* q) {
    for (int i = 0; i < nq; ++i) q[i] = uniform(rng, -std::numbers::pi, std::numbers::pi);
  }
  // Masses, lengths and inertias within ±20 % of the defaults (unit rods); no dampers (c = 0).
  static void sample_p(std::mt19937_64& rng, double* p) {
    const auto& d = Body::parameter_values;
    for (int i = 0; i < np; ++i) p[i] = d[i] * (i < 12 ? uniform(rng, 0.8, 1.2) : 1.0);
  }
};

// One random state of a case: q, q̇, q̈ (for inverse dynamics) and p.
template <class Case> struct Sample {
  std::array<double, Case::nq> q{}, qd{}, qdd{};
  std::array<double, Case::np> p{};
};

template <class Case> Sample<Case> random_sample(std::mt19937_64& rng) {
  Sample<Case> s;
  Case::sample_q(rng, s.q.data());
  for (auto& x : s.qd) x = uniform(rng, -2, 2);
  for (auto& x : s.qdd) x = uniform(rng, -5, 5);
  Case::sample_p(rng, s.p.data());
  return s;
}

}  // namespace spatial_test
