// Every generated kernel of every bundled model against eom::Reference<Model> (docs/CONTRACT.md §3).
//
// Inputs: 200 random states per model from a fixed seed (reproducible), with the parameters
// drawn around their defaults, so the kernels are checked away from the point the tape was
// recorded at. Error norm, per kernel output and per sample:
//     e = max_i |generated_i − reference_i| / max(1, max_i |reference_i|)
// (absolute for small values, relative for large ones); the test requires max e ≤ 1e-12 and
// prints the largest e seen for each kernel.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include <bundled_models.hpp>  // the cases: generated Kernels, Reference, sampling

#include <eom/integration/rk4.hpp>
#include <eom/model/kernels.hpp>
#include <eom/reference/reference.hpp>

#include "kernel_error.hpp"

namespace {

constexpr int kSamples = 200;
constexpr double kTolerance = 1e-12;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

static_assert(eom::Dynamics<spring_pendulum::Kernels>);
static_assert(eom::Dynamics<cartesian_pendulum::Kernels>);
static_assert(eom::Dynamics<chain10::Kernels> && eom::Dynamics<closed_chain5::Kernels>);
static_assert(eom::Dynamics<spacecraft_boom::Kernels>);

using namespace eom_cases;  // the bundled models' cases (tests/support/bundled_models.hpp)


// Fixed seed: every run checks the same states.
template <class Case> std::vector<Sample<Case>> samples() {
  return random_samples<Case>(kSamples, 20041);
}

using eomtest::kernel_error;

// Each check is a function template over the model's case; the TESTs at the end instantiate them.

template <class Case> void sizes_and_parameters_match_the_model() {
  using Gen = typename Case::Gen;
  using Ref = typename Case::Ref;
  static_assert(Gen::nq == Ref::nq && Gen::np == Ref::np && Gen::nu == Ref::nu &&
                Gen::nc == Ref::nc);
  for (int i = 0; i < Ref::np; ++i) {
    EXPECT_EQ(Gen::parameter_names[i], Ref::parameter_names[i]);
    EXPECT_EQ(Gen::parameter_values[i], Ref::parameter_values[i]);
  }
}

// Runs `evaluate(sample, generated_out, reference_out)` over all samples for one kernel with `n`
// outputs, and checks and prints the largest error.
template <class Case, int n, class F>
void check_kernel(const char* kernel, F&& evaluate) {
  double worst = 0;
  int worst_at = -1;
  const auto all = samples<Case>();
  for (int k = 0; k < kSamples; ++k) {
    std::array<double, n> g, r;
    g.fill(kNaN);
    r.fill(kNaN);
    evaluate(all[k], g.data(), r.data());
    const double e = kernel_error(g.data(), r.data(), n);
    if (e > worst) {
      worst = e;
      worst_at = k;
    }
  }
  std::printf("  %-30s max error %.2e over %d samples\n", kernel, worst, kSamples);
  EXPECT_LE(worst, kTolerance) << kernel << ", worst at sample " << worst_at;
}

template <class Case> void agree_with_the_reference() {
  using G = typename Case::Gen;
  using R = typename Case::Ref;
  constexpr int nq = R::nq, nc = R::nc, nu = R::nu;
  using S = Sample<Case>;

  check_kernel<Case, 1>("kinetic_energy", [](const S& s, double* g, double* r) {
    g[0] = G::kinetic_energy(s.q.data(), s.qd.data(), s.p.data());
    r[0] = R::kinetic_energy(s.q.data(), s.qd.data(), s.p.data());
  });
  check_kernel<Case, 1>("potential_energy", [](const S& s, double* g, double* r) {
    g[0] = G::potential_energy(s.q.data(), s.p.data());
    r[0] = R::potential_energy(s.q.data(), s.p.data());
  });
  check_kernel<Case, nq * nq>("mass_matrix", [](const S& s, double* g, double* r) {
    G::mass_matrix(s.q.data(), s.p.data(), g);
    R::mass_matrix(s.q.data(), s.p.data(), r);
  });
  check_kernel<Case, nq * nq>("mass_matrix_dot", [](const S& s, double* g, double* r) {
    G::mass_matrix_dot(s.q.data(), s.qd.data(), s.p.data(), g);
    R::mass_matrix_dot(s.q.data(), s.qd.data(), s.p.data(), r);
  });
  check_kernel<Case, nq>("coriolis", [](const S& s, double* g, double* r) {
    G::coriolis(s.q.data(), s.qd.data(), s.p.data(), g);
    R::coriolis(s.q.data(), s.qd.data(), s.p.data(), r);
  });
  check_kernel<Case, nq>("potential_gradient", [](const S& s, double* g, double* r) {
    G::potential_gradient(s.q.data(), s.p.data(), g);
    R::potential_gradient(s.q.data(), s.p.data(), r);
  });
  check_kernel<Case, nq>("generalized_forces", [](const S& s, double* g, double* r) {
    G::generalized_forces(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), g);
    R::generalized_forces(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), r);
  });
  if constexpr (nc > 0) {
    check_kernel<Case, nc>("constraint_residual", [](const S& s, double* g, double* r) {
      G::constraint_residual(s.q.data(), s.p.data(), g);
      R::constraint_residual(s.q.data(), s.p.data(), r);
    });
    check_kernel<Case, nc * nq>("constraint_jacobian", [](const S& s, double* g, double* r) {
      G::constraint_jacobian(s.q.data(), s.p.data(), g);
      R::constraint_jacobian(s.q.data(), s.p.data(), r);
    });
    check_kernel<Case, nc>("constraint_bias", [](const S& s, double* g, double* r) {
      G::constraint_bias(s.q.data(), s.qd.data(), s.p.data(), g);
      R::constraint_bias(s.q.data(), s.qd.data(), s.p.data(), r);
    });
  }
  check_kernel<Case, nq>("forward_dynamics", [](const S& s, double* g, double* r) {
    const bool okg = G::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), g);
    const bool okr = R::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), r);
    EXPECT_TRUE(okg && okr);
  });
  check_kernel<Case, nq * (2 * nq + nu)>(
      "forward_dynamics_derivatives", [](const S& s, double* g, double* r) {
        // One output vector: ∂q̈/∂q, then ∂q̈/∂q̇, then ∂q̈/∂u (null when nu = 0).
        const bool okg = G::forward_dynamics_derivatives(
            s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), g, g + nq * nq,
            nu > 0 ? g + 2 * nq * nq : nullptr);
        const bool okr = R::forward_dynamics_derivatives(
            s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), r, r + nq * nq,
            nu > 0 ? r + 2 * nq * nq : nullptr);
        EXPECT_TRUE(okg && okr);
      });
  check_kernel<Case, nq>("inverse_dynamics", [](const S& s, double* g, double* r) {
    G::inverse_dynamics(s.t, s.q.data(), s.qd.data(), s.qdd.data(), s.up(), s.p.data(), g);
    R::inverse_dynamics(s.t, s.q.data(), s.qd.data(), s.qdd.data(), s.up(), s.p.data(), r);
  });
}

// Physics, on the generated kernels alone: M symmetric; q̇ᵀc = ½ q̇ᵀṀq̇ (natural systems).
template <class Case> void mass_matrix_symmetric_and_coriolis_power_balanced() {
  using G = typename Case::Gen;
  constexpr int nq = G::nq;
  for (const auto& s : samples<Case>()) {
    std::array<double, nq * nq> M, Md;
    std::array<double, nq> c;
    G::mass_matrix(s.q.data(), s.p.data(), M.data());
    G::mass_matrix_dot(s.q.data(), s.qd.data(), s.p.data(), Md.data());
    G::coriolis(s.q.data(), s.qd.data(), s.p.data(), c.data());
    double qc = 0, qMq = 0, size = 1;
    for (int i = 0; i < nq; ++i) {
      qc += s.qd[i] * c[i];
      for (int j = 0; j < nq; ++j) {
        EXPECT_EQ(M[i + nq * j], M[j + nq * i]);
        qMq += s.qd[i] * Md[i + nq * j] * s.qd[j];
        size = std::max(size, std::abs(s.qd[i] * Md[i + nq * j] * s.qd[j]));
      }
    }
    EXPECT_LE(std::abs(qc - 0.5 * qMq) / size, kTolerance);
  }
}

// Bad input makes forward_dynamics fail cleanly: false, and q̈ all NaN (as the Reference does),
// never plausible numbers. Each input slot in turn is made NaN, then infinite.
template <class Case> void forward_dynamics_rejects_non_finite_input() {
  using G = typename Case::Gen;
  using R = typename Case::Ref;
  constexpr int nq = G::nq, np = G::np, nu = G::nu;
  const auto base = samples<Case>().front();
  for (double bad : {kNaN, kInf, -kInf}) {
    for (int slot = 0; slot < 1 + 2 * nq + np + nu; ++slot) {
      auto s = base;
      double* v = slot == 0 ? &s.t
                  : slot <= nq ? &s.q[slot - 1]
                  : slot <= 2 * nq ? &s.qd[slot - 1 - nq]
                  : slot <= 2 * nq + np ? &s.p[slot - 1 - 2 * nq]
                                        : &s.u[slot - 1 - 2 * nq - np];
      *v = bad;
      std::array<double, nq> g, r;
      g.fill(1234.5);
      const bool okg = G::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(),
                                           g.data());
      const bool okr = R::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(),
                                           r.data());
      EXPECT_FALSE(okr) << "reference, input slot " << slot << " = " << bad;
      EXPECT_FALSE(okg) << "input slot " << slot << " = " << bad;
      for (double x : g) EXPECT_TRUE(std::isnan(x)) << "input slot " << slot << ": q̈ = " << x;
    }
  }
}

template <class Case> void forward_dynamics_fails_when_singular() {
  if constexpr (!requires { Case::singular_q; }) {
    GTEST_SKIP() << "this model has no singular configuration";
  } else {
    using G = typename Case::Gen;
    constexpr int nq = G::nq;
    auto s = samples<Case>().front();
    s.q = Case::singular_q;
    std::array<double, nq> g;
    EXPECT_FALSE(G::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(), g.data()));
    for (double x : g) EXPECT_TRUE(std::isnan(x));
  }
}

// The generated Kernels go through the runtime's integrator exactly like the Reference does, and
// give the same trajectory: 2000 RK4 steps of 2.5 ms, compared at every step.
template <class Case> void rk4_trajectory_matches_the_reference() {
  using G = typename Case::Gen;
  using R = typename Case::Ref;
  constexpr int nq = G::nq;
  using State = eom::StateOf<nq>;
  const auto p = R::parameter_values;
  const State x0 = Case::x0;
  std::vector<State> gen, ref;
  auto rg = eom::rk4<G>(0.0, 5.0, 2000, x0, nullptr, p.data(),
                        [&](double, const State& x) { gen.push_back(x); });
  auto rr = eom::rk4<R>(0.0, 5.0, 2000, x0, nullptr, p.data(),
                        [&](double, const State& x) { ref.push_back(x); });
  EXPECT_EQ(rg.status, eom::Status::ok) << eom::to_string(rg.status);
  EXPECT_EQ(rr.status, eom::Status::ok) << eom::to_string(rr.status);
  if (gen.size() != ref.size()) {
    ADD_FAILURE() << "trajectories of different lengths";
    return;
  }
  double worst = 0;
  for (std::size_t k = 0; k < gen.size(); ++k)
    worst = std::max(worst, kernel_error(gen[k].data(), ref[k].data(), 2 * nq));
  std::printf("  rk4: max state difference %.2e over %zu steps\n", worst, gen.size() - 1);
  EXPECT_LE(worst, 1e-10);
}

#define EOM_KERNEL_TESTS(Suite, Case)                                                             \
  TEST(Suite, SizesAndParametersMatchTheModel) { sizes_and_parameters_match_the_model<Case>(); }  \
  TEST(Suite, AgreeWithTheReference) {                                                            \
    agree_with_the_reference<Case>();                                                             \
  }                                                                                               \
  TEST(Suite, MassMatrixSymmetricAndCoriolisPowerBalanced) {                                      \
    mass_matrix_symmetric_and_coriolis_power_balanced<Case>();                                    \
  }                                                                                               \
  TEST(Suite, ForwardDynamicsRejectsNonFiniteInput) {                                             \
    forward_dynamics_rejects_non_finite_input<Case>();                                            \
  }                                                                                               \
  TEST(Suite, ForwardDynamicsFailsWhenSingular) { forward_dynamics_fails_when_singular<Case>(); } \
  TEST(Suite, Rk4TrajectoryMatchesTheReference) { rk4_trajectory_matches_the_reference<Case>(); }

EOM_KERNEL_TESTS(SpringPendulumKernels, SpringPendulumCase)
EOM_KERNEL_TESTS(CartesianPendulumKernels, CartesianPendulumCase)
EOM_KERNEL_TESTS(DoublePendulumKernels, DoublePendulumCase)
EOM_KERNEL_TESTS(Chain10Kernels, Chain10Case)
EOM_KERNEL_TESTS(ClosedChain5Kernels, ClosedChain5Case)
EOM_KERNEL_TESTS(SpacecraftBoomKernels, SpacecraftBoomCase)

}  // namespace
