// The hand-derived chain (bench/hand_chain.hpp) computes the same q̈ as the generated
// forward_dynamics of UndampedChain<N>, parameters free and fixed (each also compiled with
// EOM_LIBMVEC), and as eom::Reference, so that
// eom_bench_hand_chain times equal work. 100 random states per N from a fixed seed; the free
// forms get random non-uniform links (uniform ones would hide a swapped index in a_jk). Error:
// max_i |x_i − y_i| / max_i |y_i| ≤ 1e-12. Also: the operation counts stated in the header are
// the code's.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include <eom/reference/reference.hpp>
#include <hand_chain.hpp>
#include <models/chain.hpp>

#include <hand_chain10_fixed.hpp>
#include <hand_chain10_free.hpp>
#include <hand_chain10_fixed_libmvec.hpp>
#include <hand_chain10_free_libmvec.hpp>
#include <hand_chain2_fixed.hpp>
#include <hand_chain2_free.hpp>
#include <hand_chain2_fixed_libmvec.hpp>
#include <hand_chain2_free_libmvec.hpp>
#include <hand_chain5_fixed.hpp>
#include <hand_chain5_free.hpp>
#include <hand_chain5_fixed_libmvec.hpp>
#include <hand_chain5_free_libmvec.hpp>

namespace {

constexpr int kStates = 100;
constexpr double kTolerance = 1e-12;

template <int N>
double relative_error(const std::array<double, N>& x, const std::array<double, N>& y) {
  double diff = 0, size = 0;
  for (int i = 0; i < N; ++i) {
    diff = std::max(diff, std::abs(x[i] - y[i]));
    size = std::max(size, std::abs(y[i]));
  }
  return std::isfinite(diff) ? diff / size : INFINITY;
}

template <int N, class Free, class Fixed, class FreeV, class FixedV> void check() {
  using Model = eom::models::UndampedChain<N>;
  static_assert(Free::np == 4 * N + 1 && Fixed::np == 0 && FreeV::np == Free::np && FixedV::np == 0);
  std::mt19937_64 rng(15 + N);
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi), rate(-2, 2),
      mass(0.5, 2.0), length(0.5, 2.0), inertia(0.02, 0.3), gravity(5, 15);
  double worst_free = 0, worst_reference = 0, worst_fixed = 0, worst_libmvec = 0, worst_rows = 0;
  for (int n = 0; n < kStates; ++n) {
    std::array<double, N> q, qd, hand, generated, reference;
    std::array<double, 4 * N + 1> p{};
    for (int i = 0; i < N; ++i) {
      q[i] = angle(rng), qd[i] = rate(rng);
      p[i] = mass(rng), p[N + i] = length(rng), p[2 * N + i] = inertia(rng);  // c stays 0
    }
    p[4 * N] = gravity(rng);

    // Parameters free, everything per call: the generated kernel and the reference.
    hand_chain::forward_dynamics<N>(q.data(), qd.data(), p.data(), hand.data());
    ASSERT_TRUE(
        Free::forward_dynamics(0.0, q.data(), qd.data(), nullptr, p.data(), generated.data()));
    ASSERT_TRUE(eom::Reference<Model>::forward_dynamics(0.0, q.data(), qd.data(), nullptr, p.data(),
                                                        reference.data()));
    worst_free = std::max(worst_free, relative_error<N>(hand, generated));
    worst_reference = std::max(worst_reference, relative_error<N>(hand, reference));
    {  // the vectorized floor (bench: hand_rows) on the same random parameters
      hand_chain::Coefficients<N> random_k;
      hand_chain::prepare<N>(p.data(), random_k);
      std::array<double, N> rows;
      hand_chain::forward_dynamics_rows<N>(q.data(), qd.data(), random_k, rows.data());
      worst_rows = std::max(worst_rows, relative_error<N>(rows, reference));
    }
    ASSERT_TRUE(
        FreeV::forward_dynamics(0.0, q.data(), qd.data(), nullptr, p.data(), generated.data()));
    worst_libmvec = std::max(worst_libmvec, relative_error<N>(hand, generated));

    // Parameters fixed at the model's defaults: the prepared coefficients.
    hand_chain::Coefficients<N> k;
    hand_chain::prepare<N>(Model::parameter_values.data(), k);
    hand_chain::forward_dynamics<N>(q.data(), qd.data(), k, hand.data());
    ASSERT_TRUE(
        Fixed::forward_dynamics(0.0, q.data(), qd.data(), nullptr, nullptr, generated.data()));
    worst_fixed = std::max(worst_fixed, relative_error<N>(hand, generated));
    ASSERT_TRUE(
        FixedV::forward_dynamics(0.0, q.data(), qd.data(), nullptr, nullptr, generated.data()));
    worst_libmvec = std::max(worst_libmvec, relative_error<N>(hand, generated));
  }
  std::printf("N = %d: hand vs generated free %.1e, vs Reference %.1e, vs generated fixed %.1e, "
              "vs generated with libmvec %.1e; hand rows vs Reference %.1e\n",
              N, worst_free, worst_reference, worst_fixed, worst_libmvec, worst_rows);
  EXPECT_LE(worst_free, kTolerance);
  EXPECT_LE(worst_reference, kTolerance);
  EXPECT_LE(worst_fixed, kTolerance);
  EXPECT_LE(worst_libmvec, kTolerance);
  EXPECT_LE(worst_rows, kTolerance);
}

TEST(HandChain, AgreesWithGeneratedAndReferenceN2) {
  check<2, hand_chain2_free::Kernels, hand_chain2_fixed::Kernels,
        hand_chain2_free_libmvec::Kernels, hand_chain2_fixed_libmvec::Kernels>();
}
TEST(HandChain, AgreesWithGeneratedAndReferenceN5) {
  check<5, hand_chain5_free::Kernels, hand_chain5_fixed::Kernels,
        hand_chain5_free_libmvec::Kernels, hand_chain5_fixed_libmvec::Kernels>();
}
TEST(HandChain, AgreesWithGeneratedAndReferenceN10) {
  check<10, hand_chain10_free::Kernels, hand_chain10_fixed::Kernels,
        hand_chain10_free_libmvec::Kernels, hand_chain10_fixed_libmvec::Kernels>();
}

template <int N> void check_counts() {
  EXPECT_EQ(hand_chain::counted_operations<N>(false), hand_chain::operations_prepared(N)) << N;
  EXPECT_EQ(hand_chain::counted_operations<N>(true),
            hand_chain::operations_prepared(N) + hand_chain::operations_prepare(N))
      << N;
}

TEST(HandChain, OperationCountsAreTheFormulas) {
  check_counts<1>(), check_counts<2>(), check_counts<3>(), check_counts<5>();
  check_counts<10>(), check_counts<20>(), check_counts<50>();
}

}  // namespace
