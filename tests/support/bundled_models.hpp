// The bundled models as test and benchmark cases: each names its generated Kernels and its
// eom::Reference, says where its random states live (away from singular configurations), and
// gives a singular configuration (if it has one) and an initial state for trajectory checks.
// Shared by tests/kernels and bench/, so both exercise the same states.
#pragma once

#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

// The generated headers (their include directories must come before the models') ...
#include <cartesian_pendulum.hpp>
#include <chain10.hpp>
#include <closed_chain5.hpp>
#include <double_pendulum.hpp>
#include <spacecraft_boom.hpp>
#include <spring_pendulum.hpp>
// ... and the models they were generated from.
#include <models/cartesian_pendulum.hpp>
#include <models/chain.hpp>
#include <models/double_pendulum.hpp>
#include <models/spacecraft_boom.hpp>
#include <models/spring_pendulum.hpp>

#include <eom/reference/reference.hpp>

namespace eom_cases {

struct SpringPendulumCase {
  static constexpr const char* name = "spring_pendulum";
  using Gen = spring_pendulum::Kernels;
  using Ref = eom::Reference<eom::models::SpringPendulum>;
  // r stays away from 0, where M = diag(m, m r²) is singular.
  static void sample_q(std::mt19937_64& rng, double* q) {
    q[0] = std::uniform_real_distribution<double>(0.2, 1.5)(rng);
    q[1] = std::uniform_real_distribution<double>(-std::numbers::pi, std::numbers::pi)(rng);
  }
  static constexpr std::array<double, 2> singular_q{0.0, 0.3};  // r = 0: M singular
  // The demo's initial state (the paper's Appendix B).
  static constexpr std::array<double, 4> x0{0.55, 0.0, 0.01, 2.5};
};

struct CartesianPendulumCase {
  static constexpr const char* name = "cartesian_pendulum";
  using Gen = cartesian_pendulum::Kernels;
  using Ref = eom::Reference<eom::models::CartesianPendulum>;
  // Anywhere but near the origin, where C = (2x, 2y) vanishes.
  static void sample_q(std::mt19937_64& rng, double* q) {
    std::uniform_real_distribution<double> u(-1.5, 1.5);
    do {
      q[0] = u(rng);
      q[1] = u(rng);
    } while (std::hypot(q[0], q[1]) < 0.2);
  }
  static constexpr std::array<double, 2> singular_q{0.0, 0.0};  // C = 0: C M⁻¹Cᵀ singular
  // On the constraint (l = 0.8), 0.3 rad from the bottom, moving tangentially.
  static constexpr std::array<double, 4> x0{0.8 * 0.29552020666133955, -0.8 * 0.955336489125606,
                                            1.2 * 0.955336489125606, 1.2 * 0.29552020666133955};
};

struct DoublePendulumCase {
  static constexpr const char* name = "double_pendulum";
  using Gen = double_pendulum::Kernels;
  using Ref = eom::Reference<eom::models::DoublePendulum>;
  // M is positive definite for every angle (det = m1 m2 l1² l2² + m2² l1² l2² sin²(a1 − a2)).
  static void sample_q(std::mt19937_64& rng, double* q) {
    std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
    q[0] = angle(rng);
    q[1] = angle(rng);
  }
  // The chaotic start of the integrator tests: a1 = 2.0, a2 = 2.5, at rest.
  static constexpr std::array<double, 4> x0{2.0, 2.5, 0.0, 0.0};
};

// Body-form models: the paper's 10-link deployment chain and 5-link closed chain.
struct Chain10Case {
  static constexpr const char* name = "chain10";
  using Gen = chain10::Kernels;
  using Ref = eom::Reference<eom::models::Chain<10>>;
  static void sample_q(std::mt19937_64& rng, double* q) {
    std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
    for (int i = 0; i < 10; ++i) q[i] = angle(rng);
  }
  // No singular_q: with Iᵢ > 0 an open chain's M is positive definite everywhere.
  // The deployment's stowed start (odd links at −5°, even at 185°), θ̇1 = −0.05 rad/s.
  static constexpr std::array<double, 20> x0 = [] {
    std::array<double, 20> x{};
    for (int i = 0; i < 10; ++i) x[i] = i % 2 == 0 ? -0.08726646259971647 : 3.2288591161895095;
    x[10] = -0.05;
    return x;
  }();
};

struct ClosedChain5Case {
  static constexpr const char* name = "closed_chain5";
  using Gen = closed_chain5::Kernels;
  using Ref = eom::Reference<eom::models::ClosedChain5>;
  // Off the constraint manifold too: the kernels are defined for any q.
  static void sample_q(std::mt19937_64& rng, double* q) {
    std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
    for (int i = 0; i < 5; ++i) q[i] = angle(rng);
  }
  // All links horizontal: C's first row (−sin θᵢ) vanishes, so C M⁻¹Cᵀ is singular.
  static constexpr std::array<double, 5> singular_q{};
  // From rest in the arch that closes the loop.
  static constexpr std::array<double, 10> x0 = [] {
    std::array<double, 10> x{};
    for (int i = 0; i < 5; ++i) x[i] = eom::models::ClosedChain5::initial_q[i];
    return x;
  }();
};

// The spatial body form: a spacecraft hub (z-x-y Euler angles) deploying a 6-link boom whose hinge
// axes alternate between z and y.
struct SpacecraftBoomCase {
  static constexpr const char* name = "spacecraft_boom";
  using Gen = spacecraft_boom::Kernels;
  using Ref = eom::Reference<eom::models::SpacecraftBoom>;
  // The hub's middle angle hub_x within ±69° (cos hub_x ≥ 0.36), away from its singularity at
  // ±90°; every other angle anywhere.
  static void sample_q(std::mt19937_64& rng, double* q) {
    std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
    for (int i = 0; i < 9; ++i) q[i] = angle(rng);
    q[1] = std::uniform_real_distribution<double>(-1.2, 1.2)(rng);
  }
  // hub_x = 90°: the hub's first and last Euler axes line up, so M loses rank.
  static constexpr std::array<double, 9> singular_q{0.3, std::numbers::pi / 2, -0.2, 0.1, 0.2,
                                                    0.3, 0.4, 0.5, 0.6};
  // The demo's start: stowed, at rest.
  static constexpr std::array<double, 18> x0 = [] {
    std::array<double, 18> x{};
    for (int i = 0; i < 9; ++i) x[i] = eom::models::SpacecraftBoom::initial_q[i];
    return x;
  }();
};

// One evaluation point of a case's kernels.
template <class Case> struct Sample {
  static constexpr int nq = Case::Ref::nq, np = Case::Ref::np, nu = Case::Ref::nu;
  double t = 0;
  std::array<double, nq> q{}, qd{}, qdd{};
  std::array<double, nu> u{};
  std::array<double, np> p{};
  const double* up() const { return nu > 0 ? u.data() : nullptr; }  // may be null when nu = 0
};

// `count` reproducible random points: t in [0, 10), q from the case's sampler, q̇, q̈ and u in
// [−3, 3), parameters between 0.5 and 1.5 times their defaults (away from the traced point).
template <class Case> std::vector<Sample<Case>> random_samples(std::size_t count, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> velocity(-3.0, 3.0), scale(0.5, 1.5), time(0.0, 10.0);
  std::vector<Sample<Case>> all(count);
  for (auto& s : all) {
    s.t = time(rng);
    Case::sample_q(rng, s.q.data());
    for (auto& v : s.qd) v = velocity(rng);
    for (auto& v : s.qdd) v = velocity(rng);
    for (auto& v : s.u) v = velocity(rng);
    for (int i = 0; i < Sample<Case>::np; ++i) s.p[i] = Case::Ref::parameter_values[i] * scale(rng);
  }
  return all;
}

}  // namespace eom_cases
