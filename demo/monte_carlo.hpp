// The deployment Monte Carlo's cases, shared by the demo (eom::ensemble on 1 and 2 threads) and
// its MPI run (eom::mpi::ensemble over 2 ranks): 1000 cases of the nominal deployment with each
// link's mass dispersed by ±5 % (inertia m l²/12 following it), each hinge's damping by ±20 % and
// each link's stow angle by ±2°, all uniform and independent, from a fixed seed. RK4, h = 1 ms,
// over 5 s, sampled every 20 ms.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <random>
#include <vector>

#include <eom/ensemble/ensemble.hpp>
#include <models/chain_latches.hpp>  // stowed_accordion

namespace demo {

// The stowed accordion with every link's stow angle moved by offset[i] (radians; zero: nominal).
inline eom::StateOf<10> deployment_initial_state(const std::array<double, 10>& offset = {}) {
  constexpr int n = 10;
  eom::StateOf<n> x0 = eom::models::stowed_accordion<n>(5.0 * std::numbers::pi / 180.0, -0.05);
  for (int i = 0; i < n; ++i) x0[i] += offset[i];
  return x0;
}

// The tip's distance from the pin over the chain's full length, for link lengths l[0..10) and
// absolute link angles x[0..10).
inline double tip_fraction(const double* l, const eom::StateOf<10>& x) {
  double X = 0, Y = 0, length = 0;
  for (int i = 0; i < 10; ++i) X += l[i] * std::cos(x[i]), Y += l[i] * std::sin(x[i]), length += l[i];
  return std::hypot(X, Y) / length;
}

template <class K> struct MonteCarlo {
  static constexpr int n = 10;
  static constexpr std::size_t np = K::np, cases = 1000;
  static constexpr std::uint64_t seed = 20040242;  // AAS 04-242
  static constexpr double t1 = 5.0, h = 1e-3, dt = 0.02;
  std::vector<eom::StateOf<n>> x0 = std::vector<eom::StateOf<n>>(cases);
  std::vector<double> p = std::vector<double>(cases * np);
  std::vector<double> times;
  eom::EnsembleOptions options;

  MonteCarlo() {
    const auto nominal = K::parameter_values;
    // Uniform on [−a, a) from the 53 high bits of mt19937_64 (fully specified by the standard,
    // unlike the distributions): the same cases with every standard library.
    std::mt19937_64 rng(seed);
    auto uniform = [&rng](double a) { return a * (std::ldexp(static_cast<double>(rng() >> 11), -52) - 1.0); };
    for (std::size_t c = 0; c < cases; ++c) {
      double* pc = p.data() + c * np;
      std::copy(nominal.begin(), nominal.end(), pc);
      std::array<double, n> offset{};
      for (int i = 0; i < n; ++i) {
        const double m = nominal[i] * (1 + uniform(0.05)), l = nominal[n + i];
        pc[i] = m;
        pc[2 * n + i] = m * l * l / 12.0;
      }
      for (int i = 0; i < n; ++i) pc[3 * n + i] = nominal[3 * n + i] * (1 + uniform(0.20));
      for (int i = 0; i < n; ++i) offset[i] = uniform(2.0 * std::numbers::pi / 180.0);
      x0[c] = deployment_initial_state(offset);
    }
    const long samples = std::lround(t1 / dt);
    for (long k = 0; k <= samples; ++k) times.push_back(static_cast<double>(k) * dt);
    options.t0 = 0, options.t1 = t1;
    options.integration.method = eom::Method::rk4;
    options.integration.step = h;
    options.sample_times = times;
  }
  eom::EnsembleCases<n> ensemble_cases() const { return {x0, p, {}}; }
};

// A 64-bit FNV-1a digest of the bits of every final state and sample: equal digests mean (short
// of a collision) bitwise equal results, across processes.
template <int n>
std::uint64_t digest(std::size_t cases, const eom::IntegrationResult<n>* results, const eom::StateOf<n>* samples,
                     std::size_t sample_count) {
  std::uint64_t h = 1469598103934665603ull;
  auto add = [&h](const void* data, std::size_t size) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) h = (h ^ b[i]) * 1099511628211ull;
  };
  for (std::size_t c = 0; c < cases; ++c) {
    add(&results[c].t, sizeof results[c].t);
    add(results[c].x.data(), sizeof results[c].x);
  }
  for (std::size_t k = 0; k < sample_count; ++k) add(samples[k].data(), sizeof samples[k]);
  return h;
}

}  // namespace demo
