// forward_dynamics_batch against forward_dynamics (docs/CONTRACT.md §3), on every bundled model:
// 2000 random states per model (tests/support/bundled_models.hpp, fixed seed), packed lane by lane
// into the batch kernel's structure-of-arrays layout. Per lane:
//   - the result bit equals the scalar kernel's result;
//   - a good lane's q̈ equals the scalar one bitwise: the batch kernel performs the same IEEE
//     operations in the same order, and its math functions are std::'s, lane by lane (unless
//     floating-point contraction (FMA) treats the two differently: then within 1e-14 in the norm
//     of tests/kernels, e = max_i |batch_i − scalar_i| / max(1, max_i |scalar_i|));
//   - with EOM_BATCH_LIBMVEC (glibc's vector sin and cos, up to 4 ulp from std::sin), within the
//     bound that docs/CONTRACT.md §3 gives for it, 1e-13 (2.4e-14 measured on chain10);
//   - a failed lane's q̈ is all NaN, and the other lanes of its call are unaffected.
// Failures are mixed in: NaN and Inf in t, q, q̇, u, p, and the model's singular configuration.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include <bundled_models.hpp>  // the cases: generated Kernels, Reference, sampling

#include <cartesian_pendulum_batch.hpp>
#include <chain10_avx2.hpp>
#include <chain10_avx2_libmvec.hpp>
#include <chain10_baseline.hpp>
#include <chain10_lanes2.hpp>
#include <chain10_lanes8.hpp>
#include <chain10_libmvec.hpp>
#include <double_pendulum_batch.hpp>
#include <spacecraft_boom_batch.hpp>
#include <spring_pendulum_batch.hpp>

#include <eom/model/kernels.hpp>

#include "kernel_error.hpp"

namespace {

using namespace eom_cases;

#if defined(__FMA__)
constexpr double kTolerance = 1e-14;  // contraction may differ between the scalar and vector code
#else
constexpr double kTolerance = 0;
#endif
constexpr double kLibmvecTolerance = 1e-13;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

static_assert(eom::HasForwardDynamicsBatch<chain10::Kernels>);
static_assert(eom::HasForwardDynamicsBatch<closed_chain5::Kernels>);
static_assert(!eom::HasForwardDynamicsBatch<double_pendulum::Kernels>);
static_assert(eom::batch_lanes<chain10::Kernels> == 4);
static_assert(eom::batch_lanes<chain10_lanes8::Kernels> == 8);
static_assert(eom::batch_lanes<double_pendulum::Kernels> == 0);

using eomtest::kernel_error;

// W states in structure-of-arrays lanes: entry i of lane l at x[i * W + l].
template <class Case, int W> struct Lanes {
  static constexpr int nq = Case::Ref::nq, np = Case::Ref::np, nu = Case::Ref::nu;
  std::array<double, W> t{};
  std::array<double, nq * W> q{}, qd{}, qdd{};
  std::array<double, (nu > 0 ? nu : 1) * W> u{};
  std::array<double, (np > 0 ? np : 1) * W> p{};

  void set(int l, const Sample<Case>& s) {
    t[l] = s.t;
    for (int i = 0; i < nq; ++i) {
      q[i * W + l] = s.q[i];
      qd[i * W + l] = s.qd[i];
    }
    for (int i = 0; i < nu; ++i) u[i * W + l] = s.u[i];
    for (int i = 0; i < np; ++i) p[i * W + l] = s.p[i];
  }
  std::array<double, nq> result(int l) const {
    std::array<double, nq> x{};
    for (int i = 0; i < nq; ++i) x[i] = qdd[i * W + l];
    return x;
  }
};

// The ways a lane is spoiled (0: it is not): each makes the scalar kernel fail too.
template <class Case> void spoil(Sample<Case>& s, int how) {
  constexpr int nq = Case::Ref::nq, np = Case::Ref::np, nu = Case::Ref::nu;
  switch (how) {
    case 1: s.t = kNaN; break;
    case 2: s.q[nq - 1] = kInf; break;
    case 3: s.qd[0] = -kInf; break;
    case 4:
      if constexpr (nu > 0) s.u[0] = kNaN;
      else s.qd[nq - 1] = kNaN;
      break;
    case 5:
      if constexpr (np > 0) s.p[np - 1] = kNaN;
      else s.q[0] = kNaN;
      break;
    case 6:
      if constexpr (requires { Case::singular_q; })
        for (int i = 0; i < nq; ++i) s.q[i] = Case::singular_q[i];
      else
        s.q[0] = kNaN;
      break;
    default: break;
  }
}

// Batch is the Kernels type with forward_dynamics_batch; the reference is the bundled scalar
// kernel. Prints the largest error over good lanes.
template <class Case, class Batch>
void check(const char* label, double tolerance = kTolerance, int count = 2000) {
  constexpr int W = Batch::batch_lanes, nq = Case::Ref::nq;
  using Gen = typename Case::Gen;
  auto samples = random_samples<Case>(count, 20261124);
  // Every 7th state is spoiled, in turn by each way: failed lanes sit among good ones.
  for (int k = 0; k < count; ++k)
    if (k % 7 == 3) spoil(samples[k], 1 + (k / 7) % 6);

  double worst = 0;
  int failed = 0;
  for (int first = 0; first + W <= count; first += W) {
    Lanes<Case, W> x;
    for (int l = 0; l < W; ++l) x.set(l, samples[first + l]);
    const unsigned mask =
        Batch::forward_dynamics_batch(x.t.data(), x.q.data(), x.qd.data(), x.u.data(), x.p.data(),
                                      x.qdd.data());
    EXPECT_EQ(mask >> W, 0u) << label;
    for (int l = 0; l < W; ++l) {
      const Sample<Case>& s = samples[first + l];
      std::array<double, nq> scalar{};
      const bool ok = Gen::forward_dynamics(s.t, s.q.data(), s.qd.data(), s.up(), s.p.data(),
                                            scalar.data());
      const auto lane = x.result(l);
      ASSERT_EQ(((mask >> l) & 1u) != 0, ok) << label << ": state " << first + l;
      if (!ok) {
        ++failed;
        for (double v : lane) ASSERT_TRUE(std::isnan(v)) << label << ": state " << first + l;
        continue;
      }
      const double e = kernel_error(lane.data(), scalar.data(), nq);
      EXPECT_LE(e, tolerance) << label << ": state " << first + l;
      worst = std::max(worst, e);
    }
  }
  EXPECT_GE(failed, count / 7 - 1) << label << ": the spoiled states must fail";
  std::printf("%-20s %d lanes: max deviation from forward_dynamics %.2e (%d failed lanes)\n",
              label, W, worst, failed);
}

// A state's result does not depend on its lane or on the other lanes: bitwise.
template <class Case, class Batch> void lanes_are_independent() {
  constexpr int W = Batch::batch_lanes, nq = Case::Ref::nq;
  const auto samples = random_samples<Case>(W + 1, 7);
  std::array<double, nq> first{};
  for (int shift = 0; shift < W; ++shift) {
    Lanes<Case, W> x;
    for (int l = 0; l < W; ++l) x.set(l, samples[(l + W - shift) % W]);  // sample 0 in lane shift
    Batch::forward_dynamics_batch(x.t.data(), x.q.data(), x.qd.data(), x.u.data(), x.p.data(),
                                  x.qdd.data());
    const auto r = x.result(shift);
    if (shift == 0) first = r;
    for (int i = 0; i < nq; ++i) EXPECT_EQ(r[i], first[i]) << "lane " << shift << ", entry " << i;
  }
  // And with every other lane spoiled.
  Lanes<Case, W> x;
  for (int l = 0; l < W; ++l) {
    Sample<Case> s = samples[W];
    spoil(s, 1 + l % 6);
    x.set(l, s);
  }
  x.set(W - 1, samples[0]);
  const unsigned mask = Batch::forward_dynamics_batch(x.t.data(), x.q.data(), x.qd.data(),
                                                      x.u.data(), x.p.data(), x.qdd.data());
  EXPECT_EQ(mask, 1u << (W - 1));
  const auto r = x.result(W - 1);
  for (int i = 0; i < nq; ++i) EXPECT_EQ(r[i], first[i]);
}

TEST(Batch, SpringPendulum) {
  check<SpringPendulumCase, spring_pendulum_batch::Kernels>("spring_pendulum");
}
TEST(Batch, CartesianPendulum) {
  check<CartesianPendulumCase, cartesian_pendulum_batch::Kernels>("cartesian_pendulum");
}
TEST(Batch, DoublePendulum) {
  check<DoublePendulumCase, double_pendulum_batch::Kernels>("double_pendulum");
}
TEST(Batch, Chain10) { check<Chain10Case, chain10::Kernels>("chain10"); }
TEST(Batch, ClosedChain5) { check<ClosedChain5Case, closed_chain5::Kernels>("closed_chain5"); }
TEST(Batch, SpacecraftBoom) {
  check<SpacecraftBoomCase, spacecraft_boom_batch::Kernels>("spacecraft_boom");
}

TEST(Batch, Chain10WithTwoAndEightLanes) {
  check<Chain10Case, chain10_lanes2::Kernels>("chain10_lanes2");
  check<Chain10Case, chain10_lanes8::Kernels>("chain10_lanes8");
}
TEST(Batch, Chain10ForBaselineX86_64) {
  check<Chain10Case, chain10_baseline::Kernels>("chain10_baseline");
}
TEST(Batch, Chain10WithLibmvec) {
  check<Chain10Case, chain10_libmvec::Kernels>("chain10_libmvec", kLibmvecTolerance);
}
TEST(Batch, Chain10CompiledForAvx2) {
  if (!__builtin_cpu_supports("avx2")) GTEST_SKIP() << "no AVX2 on this machine";
  check<Chain10Case, chain10_avx2::Kernels>("chain10_avx2");
  check<Chain10Case, chain10_avx2_libmvec::Kernels>("chain10_avx2_libmvec", kLibmvecTolerance);
}

TEST(Batch, LanesAreIndependent) {
  lanes_are_independent<Chain10Case, chain10::Kernels>();
  lanes_are_independent<ClosedChain5Case, closed_chain5::Kernels>();
  lanes_are_independent<SpringPendulumCase, spring_pendulum_batch::Kernels>();
  lanes_are_independent<Chain10Case, chain10_lanes8::Kernels>();
}

}  // namespace
