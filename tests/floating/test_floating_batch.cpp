// forward_dynamics_batch of models with unit quaternions in q (docs/CONTRACT.md §3, "Batch forward
// dynamics"): q has nq rows, qd and qdd nv. A hand-written tree on a free base (free_tree: nq 10,
// nv 9) and a top on a ball joint whose quaternion follows a slide (ball_top: nq 6, nv 5). Per
// lane, at random states with unit quaternions:
//   - the result bit equals forward_dynamics's result and a good lane's v̇ equals its v̇ bitwise
//     (compiled without contraction, as the scalar kernel);
//   - a lane with a NaN or Inf input fails alone: its v̇ all NaN, the others as above;
//   - the kernel writes nv rows of qdd, nothing after them.
// Then eom::ensemble's batch RK4 (which steps q̇ = G(q) v and normalizes the quaternions lane by
// lane) against the same ensemble case by case, bitwise: final states, step and evaluation counts,
// dense samples; a spoiled case and a refused one among them. And lock-step dopri5 and dop853
// (the lanes as one system, each lane's quaternions four consecutive coordinates of it): within
// the tolerance of the true motion as each case's own run, the quaternions unit, the same bits on
// 1 and 2 threads, and a group with a refused case run case by case exactly as without lock-step.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <algorithm>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <ball_top.hpp>
#include <free_tree.hpp>

#include <eom/ensemble/ensemble.hpp>
#include <eom/model/free_joint.hpp>
#include <eom/model/kernels.hpp>

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

static_assert(free_tree::nq == 10 && free_tree::nv == 9);
static_assert(ball_top::nq == 6 && ball_top::nv == 5);
static_assert(eom::HasForwardDynamicsBatch<free_tree::Kernels> &&
              eom::HasForwardDynamicsBatch<ball_top::Kernels>);

// One random state of K: unit quaternions, parameters near K's values.
template <class K> struct State {
  static constexpr int nq = K::nq, nv = K::nv, nu = K::nu, np = K::np;
  double t = 0;
  std::array<double, nq> q{};
  std::array<double, nv> v{};
  std::array<double, (nu > 0 ? nu : 1)> u{};
  std::array<double, (np > 0 ? np : 1)> p{};
  explicit State(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> x(-1, 1);
    t = x(rng);
    for (double& e : q) e = x(rng);
    for (double& e : v) e = 2 * x(rng);
    for (double& e : u) e = x(rng);
    for (int i = 0; i < np; ++i) p[i] = K::parameter_values[i] * (1 + 0.2 * x(rng));
    eom::normalize_configuration(eom::layout_of<K>(), q.data());
  }
};

// How a lane is spoiled (0: it is not); each makes forward_dynamics fail.
template <class K> void spoil(State<K>& s, int how) {
  switch (how) {
    case 1: s.t = kNaN; break;
    case 2: s.q[K::quaternions[0] + 2] = kInf; break;  // inside a quaternion
    case 3: s.v[K::nv - 1] = kNaN; break;              // the last velocity (v has nv rows)
    case 4: s.p[K::np - 1] = -kInf; break;
    default: break;
  }
}

template <class K> void check_lanes(const char* label, int groups) {
  constexpr int W = K::batch_lanes, nq = K::nq, nv = K::nv, nu = K::nu, np = K::np;
  constexpr int spare = 3 * W;  // qdd's entries after nv·W, which the kernel must not write
  std::mt19937_64 rng(20261206);
  int failed = 0, good = 0;
  for (int g = 0; g < groups; ++g) {
    std::vector<State<K>> s;
    for (int l = 0; l < W; ++l) s.emplace_back(rng);
    // In every third group one lane is spoiled, in turn by each way, at each lane in turn.
    if (g % 3 == 1) spoil(s[g % W], 1 + (g / 3) % 4);
    std::array<double, W> t{};
    std::array<double, nq * W> q{};
    std::array<double, nv * W> v{};
    std::array<double, (nu > 0 ? nu : 1) * W> u{};
    std::array<double, (np > 0 ? np : 1) * W> p{};
    std::array<double, nv * W + spare> a;
    a.fill(-7.0);
    for (int l = 0; l < W; ++l) {
      t[l] = s[l].t;
      for (int i = 0; i < nq; ++i) q[i * W + l] = s[l].q[i];
      for (int i = 0; i < nv; ++i) v[i * W + l] = s[l].v[i];
      for (int i = 0; i < nu; ++i) u[i * W + l] = s[l].u[i];
      for (int i = 0; i < np; ++i) p[i * W + l] = s[l].p[i];
    }
    const unsigned mask = K::forward_dynamics_batch(t.data(), q.data(), v.data(), u.data(), p.data(), a.data());
    EXPECT_EQ(mask >> W, 0u) << label;
    for (int i = nv * W; i < nv * W + spare; ++i) ASSERT_EQ(a[i], -7.0) << label << ": qdd written past nv rows";
    for (int l = 0; l < W; ++l) {
      std::array<double, nv> scalar{};
      const bool ok =
          K::forward_dynamics(s[l].t, s[l].q.data(), s[l].v.data(), s[l].u.data(), s[l].p.data(), scalar.data());
      ASSERT_EQ(((mask >> l) & 1u) != 0, ok) << label << ": group " << g << ", lane " << l;
      if (!ok) {
        ++failed;
        for (int i = 0; i < nv; ++i) EXPECT_TRUE(std::isnan(a[i * W + l])) << label << ": entry " << i;
        continue;
      }
      ++good;
      for (int i = 0; i < nv; ++i)  // bitwise (NaN-free here)
        ASSERT_EQ(a[i * W + l], scalar[i]) << label << ": group " << g << ", lane " << l << ", entry " << i;
    }
  }
  EXPECT_EQ(failed, (groups + 1) / 3) << label << ": exactly the spoiled lanes fail";
  std::printf("%-10s %d lanes: %d lanes bitwise forward_dynamics's, %d spoiled lanes failed alone\n", label, W,
              good, failed);
}

TEST(FloatingBatch, FreeTreeLanesEqualForwardDynamics) { check_lanes<free_tree::Kernels>("free_tree", 300); }
TEST(FloatingBatch, BallTopLanesEqualForwardDynamics) { check_lanes<ball_top::Kernels>("ball_top", 300); }

template <class K> void expect_same(const eom::EnsembleResultFor<K>& a, const eom::EnsembleResultFor<K>& b,
                                    const char* label) {
  ASSERT_EQ(a.status, eom::Status::ok);
  ASSERT_EQ(b.status, eom::Status::ok);
  ASSERT_EQ(a.cases.size(), b.cases.size());
  for (std::size_t c = 0; c < a.cases.size(); ++c) {
    EXPECT_EQ(a.cases[c].status, b.cases[c].status) << label << ": case " << c;
    EXPECT_EQ(a.cases[c].t, b.cases[c].t) << label << ": case " << c;
    EXPECT_EQ(a.cases[c].accepted, b.cases[c].accepted) << label << ": case " << c;
    EXPECT_EQ(a.cases[c].evaluations, b.cases[c].evaluations) << label << ": case " << c;
    for (std::size_t i = 0; i < a.cases[c].x.size(); ++i) {
      const double x = a.cases[c].x[i], y = b.cases[c].x[i];
      EXPECT_TRUE(x == y || (std::isnan(x) && std::isnan(y))) << label << ": case " << c << ", entry " << i;
    }
  }
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (std::size_t k = 0; k < a.samples.size(); ++k)
    for (std::size_t i = 0; i < a.samples[k].size(); ++i) {
      const double x = a.samples[k][i], y = b.samples[k][i];
      EXPECT_TRUE(x == y || (std::isnan(x) && std::isnan(y))) << label << ": sample " << k << ", entry " << i;
    }
}

// 11 cases (the last group partly filled); case 4 starts with a quaternion 1e-9 off the unit
// sphere (normalized at the start by both), case 6 with a NaN velocity (refused), case 9 with a
// quaternion 1e-3 off (refused).
template <class K> void check_ensemble(const char* label) {
  constexpr int nq = K::nq, nv = K::nv, np = K::np, nu = K::nu;
  std::mt19937_64 rng(7);
  std::vector<eom::StateFor<K>> x0;
  std::vector<double> p, u;
  for (int c = 0; c < 11; ++c) {
    State<K> s(rng);
    for (double& e : s.v) e *= 0.5;
    eom::StateFor<K> x{};
    for (int i = 0; i < nq; ++i) x[i] = s.q[i];
    for (int i = 0; i < nv; ++i) x[nq + i] = s.v[i];
    if (c == 4) x[K::quaternions[0]] *= 1 + 1e-9;
    if (c == 6) x[nq + 1] = kNaN;
    if (c == 9) x[K::quaternions[0]] *= 1 + 1e-3;
    x0.push_back(x);
    p.insert(p.end(), s.p.begin(), s.p.begin() + np);
    u.insert(u.end(), s.u.begin(), s.u.begin() + nu);
  }
  const std::vector<double> times{0.05, 0.13, 0.2, 0.31};
  eom::EnsembleOptions opt;
  opt.t0 = 0, opt.t1 = 0.31;
  opt.integration.method = eom::Method::rk4;
  opt.integration.step = 0.01;
  opt.sample_times = times;
  ASSERT_TRUE(eom::detail::batch_applies<K>(opt));
  const eom::EnsembleCasesFor<K> cases{x0, p, u};
  const auto batched = eom::ensemble<K>(cases, opt);
  opt.batch = false;
  const auto alone = eom::ensemble<K>(cases, opt);
  expect_same<K>(batched, alone, label);
  EXPECT_EQ(alone.failed(), 2u) << label;
  EXPECT_EQ(alone.cases[6].status, eom::Status::invalid_argument) << label;
  EXPECT_EQ(alone.cases[9].status, eom::Status::invalid_argument) << label;
  for (std::size_t c = 0; c < x0.size(); ++c)  // every completed case ends on the unit sphere
    if (alone.cases[c].status == eom::Status::ok) {
      EXPECT_LE(eom::quaternion_norm_error(eom::layout_of<K>(), alone.cases[c].x.data()), 1e-15) << label;
    }

  // Lock-step: cases 0-3 in lock-step; 4-7 (case 6 refused) and 8-10 (case 9 refused; lane 3
  // idle) case by case.
  for (eom::Method method : {eom::Method::dopri5, eom::Method::dop853}) {
    SCOPED_TRACE(eom::to_string(method));
    opt.integration.method = method;
    opt.lockstep = false;
    opt.integration.rtol = opt.integration.atol = 1e-13;
    const auto truth = eom::ensemble<K>(cases, opt);
    opt.integration.rtol = opt.integration.atol = 1e-8;
    const auto own = eom::ensemble<K>(cases, opt);
    opt.lockstep = true;
    ASSERT_TRUE(eom::detail::lockstep_applies<K>(opt));
    const auto lockstep = eom::ensemble<K>(cases, opt);
    opt.threads = 2;
    expect_same<K>(lockstep, eom::ensemble<K>(cases, opt), label);
    opt.threads = 1;
    double worst_own = 0, worst_lockstep = 0, worst_norm = 0;
    for (std::size_t c = 0; c < x0.size(); ++c) {
      const bool alone = c >= 4;
      EXPECT_EQ(lockstep.cases[c].status, own.cases[c].status) << label << ": case " << c;
      if (own.cases[c].status != eom::Status::ok) continue;
      if (!alone) {
        EXPECT_EQ(lockstep.cases[c].accepted, lockstep.cases[0].accepted) << "the group's steps";
      }
      for (std::size_t k = 0; k < times.size(); ++k) {
        const auto &x = lockstep.sample(c, k), &y = own.sample(c, k), &z = truth.sample(c, k);
        for (std::size_t i = 0; i < x.size(); ++i) {
          if (alone) {
            EXPECT_EQ(x[i], y[i]) << label << ": case " << c << " (case by case)";
            continue;
          }
          worst_own = std::max(worst_own, std::abs(y[i] - z[i]));
          worst_lockstep = std::max(worst_lockstep, std::abs(x[i] - z[i]));
        }
        worst_norm = std::max(worst_norm, eom::quaternion_norm_error(eom::layout_of<K>(), x.data()));
      }
    }
    std::printf("%-10s lock-step %s: worst sample error %.2e (each case's own run %.2e), tolerance 1e-8, "
                "quaternion norm error %.2e\n",
                label, eom::to_string(method), worst_lockstep, worst_own, worst_norm);
    EXPECT_GT(worst_lockstep, 0.0) << "lock-step gave the own runs' bits: did it run?";
    EXPECT_LT(worst_lockstep, 10 * worst_own + 1e-12);
    EXPECT_LE(worst_norm, 1e-15);
  }
}

TEST(FloatingBatch, FreeTreeEnsembleBatchAndLockstep) { check_ensemble<free_tree::Kernels>("free_tree"); }
TEST(FloatingBatch, BallTopEnsembleBatchAndLockstep) { check_ensemble<ball_top::Kernels>("ball_top"); }

}  // namespace
