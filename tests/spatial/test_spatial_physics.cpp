// Physics of the spatial body form, on the generated body-form kernels of the three models:
// M symmetric positive definite, the power identity q̇ᵀc = ½ q̇ᵀṀq̇ (Ṁ − 2C skew-symmetric,
// equivalently: the gyroscopic forces do no work), and conservation of T + V along undamped
// trajectories integrated by DOP853 at tight tolerance.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include <eom/integration/integrate.hpp>

#include "record.hpp"
#include "spatial_cases.hpp"

namespace {

using namespace spatial_test;

// The smallest pivot d_j (= L_jj²) of the Cholesky factorization of M divided by M's largest
// diagonal entry: > 0 iff M is positive definite; −1 when a pivot is not positive.
template <int n> double cholesky_min_pivot(std::array<double, n * n> a) {
  double largest = 0, smallest = INFINITY;
  for (int i = 0; i < n; ++i) largest = std::max(largest, a[i + n * i]);
  for (int j = 0; j < n; ++j) {
    double d = a[j + n * j];
    for (int k = 0; k < j; ++k) d -= a[j + n * k] * a[j + n * k];
    if (!(d > 0)) return -1;
    smallest = std::min(smallest, d);
    const double r = std::sqrt(d);
    a[j + n * j] = r;
    for (int i = j + 1; i < n; ++i) {
      double s = a[i + n * j];
      for (int k = 0; k < j; ++k) s -= a[i + n * k] * a[j + n * k];
      a[i + n * j] = s / r;
    }
  }
  return smallest / largest;
}

template <class Case> void mass_matrix_is_symmetric_positive_definite(double min_pivot_expected) {
  using K = typename Case::GenBody;
  constexpr int n = Case::nq;
  std::mt19937_64 rng(71);
  double asymmetry = 0, min_pivot = INFINITY;
  for (int k = 0; k < 200; ++k) {
    const auto s = random_sample<Case>(rng);
    std::array<double, n * n> M;
    K::mass_matrix(s.q.data(), s.p.data(), M.data());
    double size = 0;
    for (double x : M) size = std::max(size, std::abs(x));
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        asymmetry = std::max(asymmetry, std::abs(M[i + n * j] - M[j + n * i]) / size);
    min_pivot = std::min(min_pivot, cholesky_min_pivot<n>(M));
  }
  std::printf("%s: max |M - M^T|/max|M| = %.2e, min Cholesky pivot / max diag = %.3e\n", Case::name,
              asymmetry, min_pivot);
  record_figure("asymmetry", asymmetry);
  record_figure("min_pivot", min_pivot);
  EXPECT_LE(asymmetry, 1e-15);
  EXPECT_GE(min_pivot, min_pivot_expected);
}

// Measured min pivot / max diagonal over 200 states: top 4.7e-02 (θ ∈ [0.3, π − 0.3]), universal
// pendulum 2.1e-02, chain 2.6e-02 (the generated M is exactly symmetric: 0.0e+00). Asserted:
// about half of each.
TEST(SpatialPhysics, MassMatrixSymmetricPositiveDefinite) {
  mass_matrix_is_symmetric_positive_definite<TopCase>(0.02);
  mass_matrix_is_symmetric_positive_definite<UniversalPendulumCase>(0.01);
  mass_matrix_is_symmetric_positive_definite<ChainCase>(0.01);
}

// q̇ᵀc = q̇ᵀṀq̇ − q̇ᵀ∂T/∂q = q̇ᵀṀq̇ − ½q̇ᵀṀq̇ (T = ½q̇ᵀM q̇, so q̇ᵀ∂T/∂q = ½q̇ᵀṀq̇).
// Error relative to the scale of its terms, |q̇|³·max|Mᵢⱼ| (|q̇| the Euclidean norm). Not relative
// to Σ|q̇ᵢcᵢ| + ½Σ|q̇ᵢṀᵢⱼq̇ⱼ|: the top's M depends on θ alone, so at small θ̇ Ṁ is small while the
// body form computes it from terms in ψ̇ and φ̇ that cancel only up to rounding; measured that way
// the top gave 3.8e-13 (generated body form; 1.7e-16 for the energy form, whose T has no such
// terms), which is rounding, not a wrong c.
template <class Case> double power_identity_error() {
  using K = typename Case::GenBody;
  constexpr int n = Case::nq;
  std::mt19937_64 rng(72);
  double worst = 0;
  for (int k = 0; k < 200; ++k) {
    const auto s = random_sample<Case>(rng);
    std::array<double, n * n> M, Md;
    std::array<double, n> c;
    K::mass_matrix(s.q.data(), s.p.data(), M.data());
    K::mass_matrix_dot(s.q.data(), s.qd.data(), s.p.data(), Md.data());
    K::coriolis(s.q.data(), s.qd.data(), s.p.data(), c.data());
    double lhs = 0, rhs = 0, speed2 = 0, m = 0;
    for (int i = 0; i < n; ++i) {
      lhs += s.qd[i] * c[i];
      speed2 += s.qd[i] * s.qd[i];
      for (int j = 0; j < n; ++j) {
        rhs += 0.5 * s.qd[i] * Md[i + n * j] * s.qd[j];
        m = std::max(m, std::abs(M[i + n * j]));
      }
    }
    worst = std::max(worst, std::abs(lhs - rhs) / (speed2 * std::sqrt(speed2) * m));
  }
  std::printf("%s: max |qd'c - qd'Mdot qd/2| / (|qd|^3 max|M|) = %.2e\n", Case::name, worst);
  return worst;
}

// Measured: 3.2e-16 (top), 2.1e-16 (universal pendulum), 2.4e-16 (chain).
TEST(SpatialPhysics, PowerIdentity) {
  EXPECT_LE(power_identity_error<TopCase>(), 1e-14);
  EXPECT_LE(power_identity_error<UniversalPendulumCase>(), 1e-14);
  EXPECT_LE(power_identity_error<ChainCase>(), 1e-14);
}

// max |E − E0| / max T over t ∈ [0, 5 s], DOP853 at rtol = atol = 1e-12; also checks the motion
// is not trivial (max T ≥ min_kinetic).
template <class Case>
double energy_drift(const std::array<double, 2 * Case::nq>& x0, double min_kinetic) {
  using K = typename Case::GenBody;
  constexpr int n = Case::nq;
  const auto p = Case::Body::parameter_values;
  auto energy = [&](const eom::StateOf<n>& x) {
    return K::kinetic_energy(x.data(), x.data() + n, p.data()) + K::potential_energy(x.data(), p.data());
  };
  eom::StateOf<n> x;
  for (int i = 0; i < 2 * n; ++i) x[i] = x0[i];
  const double E0 = energy(x);
  double worst = 0, kinetic_max = 0;
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = opt.atol = 1e-12;
  const auto r = eom::integrate<K>(0, 5, x, nullptr, p.data(), opt, [&](double, const eom::StateOf<n>& y) {
    worst = std::max(worst, std::abs(energy(y) - E0));
    kinetic_max = std::max(kinetic_max, K::kinetic_energy(y.data(), y.data() + n, p.data()));
  });
  EXPECT_EQ(r.status, eom::Status::ok) << Case::name << ": " << eom::to_string(r.status);
  EXPECT_EQ(r.t, 5.0);
  EXPECT_GE(kinetic_max, min_kinetic) << Case::name << " really moves";
  std::printf("%s: %ld steps, max T = %.3g J, max |E - E0| / max T = %.2e\n", Case::name, r.accepted,
              kinetic_max, worst / kinetic_max);
  return worst / kinetic_max;
}

// Measured max |E − E0| / max T: top 1.3e-13 (243 steps), universal pendulum 3.4e-13 (607),
// chain 1.7e-13 (725). Asserted: ≤ 1e-11 (a wrong c or M, e.g. a sign in the gyroscopic terms,
// drifts by O(1)).
TEST(SpatialPhysics, EnergyConservedWithoutDamping) {
  // A fast top (φ̇ = 30 rad/s) tilted 0.5 rad from the vertical, released with no precession:
  // it nutates and precesses.
  const double top = energy_drift<TopCase>({0.0, 0.5, 0.0, 0.0, 0.0, 30.0}, 2.0);
  // The tilted universal pendulum released from a bent, twisted pose with some spin.
  const double upend = energy_drift<UniversalPendulumCase>({0.8, -0.6, 1.2, 0.4, 0.0, 1.0, -2.0, 0.5}, 1.0);
  // Four unit links released from a bent rest state.
  const double chain = energy_drift<ChainCase>({0.3, -0.4, 0.9, 1.2, 0, 0, 0, 0}, 10.0);
  EXPECT_LE(top, 1e-11);
  EXPECT_LE(upend, 1e-11);
  EXPECT_LE(chain, 1e-11);
  record_figure("energy_drift_top", top);
  record_figure("energy_drift_universal_pendulum", upend);
  record_figure("energy_drift_chain", chain);
}

}  // namespace
