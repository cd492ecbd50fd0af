// eom::ensemble: bitwise the same results on 1, 2 and 4 threads and as a plain loop over
// eom::integrate; every method of eom::integrate; inputs from a callback; failing cases reported
// while the others complete; bad input of the ensemble itself refused with invalid_argument.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include <double_pendulum.hpp>
#include <spring_pendulum.hpp>

#include <cart_pole.hpp>  // examples/lqr_cartpole: a model with an input
#include <eom/ensemble/ensemble.hpp>
#include <eom/reference/reference.hpp>

#include "ensemble_cases.hpp"

namespace {

using eom_ensemble_cases::same_bits;
using Chain = chain10::Kernels;
constexpr int nq = Chain::nq;

eom::EnsembleOptions deployment_options(unsigned threads) {
  eom::EnsembleOptions opt;
  opt.t0 = 0, opt.t1 = 2.0;
  opt.threads = threads;
  opt.integration.method = eom::Method::dop853;
  opt.integration.rtol = 1e-9, opt.integration.atol = 1e-11;
  return opt;
}

const std::vector<double> sample_times{0.0, 0.5, 1.0, 1.5, 2.0};

TEST(Ensemble, BitwiseTheSameOnOneTwoAndFourThreads) {
  const auto d = eom_ensemble_cases::deployment(24);
  std::vector<eom::EnsembleResult<nq>> runs;
  for (unsigned threads : {1u, 2u, 4u}) {
    auto opt = deployment_options(threads);
    opt.sample_times = sample_times;
    runs.push_back(eom::ensemble<Chain>(d.cases(), opt));
    ASSERT_EQ(runs.back().status, eom::Status::ok);
    ASSERT_EQ(runs.back().cases.size(), 24u);
    ASSERT_EQ(runs.back().samples.size(), 24u * sample_times.size());
    EXPECT_EQ(runs.back().failed(), 0u);
  }
  for (std::size_t r = 1; r < runs.size(); ++r) {
    for (std::size_t c = 0; c < 24; ++c) {
      EXPECT_TRUE(same_bits(runs[0].cases[c], runs[r].cases[c])) << "case " << c << ", run " << r;
      for (std::size_t k = 0; k < sample_times.size(); ++k)
        EXPECT_TRUE(same_bits(runs[0].sample(c, k), runs[r].sample(c, k))) << c << ", " << k;
    }
  }
  // The cases really differ (different release rates and masses).
  EXPECT_NE(runs[0].cases[0].x[0], runs[0].cases[1].x[0]);
}

TEST(Ensemble, BitwiseAPlainLoopOverIntegrate) {
  const auto d = eom_ensemble_cases::deployment(9);
  auto opt = deployment_options(2);
  opt.sample_times = sample_times;
  const auto r = eom::ensemble<Chain>(d.cases(), opt);
  ASSERT_EQ(r.status, eom::Status::ok);
  auto integration = opt.integration;
  integration.output_times = sample_times;
  for (std::size_t c = 0; c < 9; ++c) {
    std::vector<eom::StateOf<nq>> seen;
    const auto single = eom::integrate<Chain>(opt.t0, opt.t1, d.x0[c], nullptr, d.p.data() + c * Chain::np,
                                              integration, [&](double, const eom::StateOf<nq>& x) { seen.push_back(x); });
    EXPECT_EQ(single.status, eom::Status::ok);
    EXPECT_TRUE(same_bits(single, r.cases[c])) << "case " << c;
    ASSERT_EQ(seen.size(), sample_times.size());
    for (std::size_t k = 0; k < seen.size(); ++k) EXPECT_TRUE(same_bits(seen[k], r.sample(c, k)));
  }
  // The final sample is the final state.
  EXPECT_TRUE(same_bits(r.sample(0, sample_times.size() - 1), r.cases[0].x));
}

TEST(Ensemble, IntoTheCallersStorageWithSharedParameters) {
  const auto d = eom_ensemble_cases::deployment(5);
  const std::vector<double> shared(chain10::parameter_values.begin(), chain10::parameter_values.end());
  std::vector<eom::IntegrationResult<nq>> results(5);
  auto opt = deployment_options(3);
  opt.t1 = 0.5;
  ASSERT_EQ(eom::ensemble<Chain>({d.x0, shared, {}}, opt, std::span(results)), eom::Status::ok);
  for (std::size_t c = 0; c < 5; ++c) {
    const auto single = eom::integrate<Chain>(opt.t0, opt.t1, d.x0[c], nullptr, shared.data(), opt.integration);
    EXPECT_TRUE(same_bits(single, results[c])) << "case " << c;
  }
}

// Every method of eom::integrate, 1 thread against 3.
TEST(Ensemble, EveryMethodDeterministic) {
  using K = double_pendulum::Kernels;
  std::vector<eom::StateOf<2>> x0;
  for (int c = 0; c < 7; ++c) x0.push_back({2.0 - 0.1 * c, 2.5, 0.0, 0.1 * c});
  const std::vector<double> p(double_pendulum::parameter_values.begin(), double_pendulum::parameter_values.end());
  for (auto method : {eom::Method::rk4, eom::Method::dopri5, eom::Method::dop853, eom::Method::radau5,
                      eom::Method::taylor, eom::Method::taylor_paper, eom::Method::variational}) {
    eom::EnsembleOptions opt;
    opt.t0 = 0, opt.t1 = 1.0;
    opt.integration.method = method;
    opt.integration.step = eom::is_fixed_step(method) ? 1e-3 : 0;
    opt.sample_times = std::span(sample_times).first(3);
    opt.threads = 1;
    const auto one = eom::ensemble<K>({x0, p, {}}, opt);
    opt.threads = 3;
    const auto three = eom::ensemble<K>({x0, p, {}}, opt);
    ASSERT_EQ(one.status, eom::Status::ok) << eom::to_string(method);
    ASSERT_EQ(three.status, eom::Status::ok) << eom::to_string(method);
    for (std::size_t c = 0; c < x0.size(); ++c) {
      EXPECT_EQ(one.cases[c].status, eom::Status::ok) << eom::to_string(method) << ": "
                                                      << eom::to_string(one.cases[c].status);
      EXPECT_TRUE(same_bits(one.cases[c], three.cases[c])) << eom::to_string(method) << ", case " << c;
      for (std::size_t k = 0; k < 3; ++k) EXPECT_TRUE(same_bits(one.sample(c, k), three.sample(c, k)));
    }
  }
}

// A failing case reports its status; the others complete, as they would alone.
TEST(Ensemble, FailingCasesReportedOthersComplete) {
  auto d = eom_ensemble_cases::deployment(8);
  for (int i = 0; i < 10; ++i) d.p[3 * Chain::np + i] = 0, d.p[3 * Chain::np + 20 + i] = 0;  // M = 0
  d.x0[5][2] = std::numeric_limits<double>::quiet_NaN();  // not a state
  auto opt = deployment_options(2);
  opt.t1 = 0.5;
  opt.sample_times = std::span(sample_times).first(2);
  const auto r = eom::ensemble<Chain>(d.cases(), opt);
  ASSERT_EQ(r.status, eom::Status::ok);
  EXPECT_EQ(r.failed(), 2u);
  EXPECT_EQ(r.cases[3].status, eom::Status::singular_dynamics);
  EXPECT_EQ(r.cases[5].status, eom::Status::invalid_argument);
  EXPECT_TRUE(std::isnan(r.sample(3, 1)[0]));  // never reached
  auto integration = opt.integration;
  for (std::size_t c : {0u, 1u, 2u, 4u, 6u, 7u}) {
    EXPECT_EQ(r.cases[c].status, eom::Status::ok) << "case " << c;
    const auto single = eom::integrate<Chain>(opt.t0, opt.t1, d.x0[c], nullptr, d.p.data() + c * Chain::np, integration);
    EXPECT_TRUE(same_bits(single, r.cases[c])) << "case " << c;
    EXPECT_FALSE(std::isnan(r.sample(c, 1)[0]));
  }
  // A singular start of a bundled model: the spring pendulum at r = 0.
  using S = spring_pendulum::Kernels;
  const std::vector<eom::StateOf<2>> x0{{0.55, 0.0, 0.01, 2.5}, {0.0, 0.3, 0.0, 0.0}, {0.6, 0.1, 0.0, 1.0}};
  const std::vector<double> p(spring_pendulum::parameter_values.begin(), spring_pendulum::parameter_values.end());
  eom::EnsembleOptions sopt;
  sopt.t1 = 1.0, sopt.threads = 2;
  sopt.integration.method = eom::Method::rk4, sopt.integration.step = 1e-3;
  const auto s = eom::ensemble<S>({x0, p, {}}, sopt);
  ASSERT_EQ(s.status, eom::Status::ok);
  EXPECT_EQ(s.cases[0].status, eom::Status::ok);
  EXPECT_EQ(s.cases[1].status, eom::Status::singular_dynamics);
  EXPECT_EQ(s.cases[2].status, eom::Status::ok);
  EXPECT_EQ(s.cases[2].t, 1.0);
}

// The batch path (chain10 has forward_dynamics_batch): RK4, held inputs. Bitwise the
// one-case-at-a-time path, final states and samples, on 1 and 2 threads, with a case count that
// leaves a partial group and with cases that eom::integrate refuses or that fail on the way (they
// are run alone).
TEST(Ensemble, BatchRk4BitwiseTheScalarPath) {
  static_assert(eom::HasForwardDynamicsBatch<Chain>);
  auto d = eom_ensemble_cases::deployment(23);
  d.x0[5][3] = std::numeric_limits<double>::quiet_NaN();  // refused: invalid_argument
  d.x0[9][12] = 1e200;                                     // fails on the way
  d.p[14 * Chain::np + 2] = -1.0;  // a negative mass: M not positive definite
  eom::EnsembleOptions opt;
  opt.t0 = 0, opt.t1 = 0.25;
  opt.integration.method = eom::Method::rk4;
  opt.integration.step = 1e-3;
  const std::vector<double> times{0.0, 0.0105, 0.1, 0.2, 0.25};
  for (bool sampled : {false, true}) {
    opt.sample_times = sampled ? std::span<const double>(times) : std::span<const double>();
    opt.batch = false;
    opt.threads = 1;
    const auto scalar = eom::ensemble<Chain>(d.cases(), opt);
    ASSERT_EQ(scalar.status, eom::Status::ok);
    EXPECT_EQ(scalar.cases[5].status, eom::Status::invalid_argument);
    EXPECT_NE(scalar.cases[9].status, eom::Status::ok);
    EXPECT_NE(scalar.cases[14].status, eom::Status::ok);
    EXPECT_EQ(scalar.failed(), 3u);
    opt.batch = true;
    for (unsigned threads : {1u, 2u}) {
      opt.threads = threads;
      const auto batch = eom::ensemble<Chain>(d.cases(), opt);
      ASSERT_EQ(batch.status, eom::Status::ok);
      for (std::size_t c = 0; c < d.x0.size(); ++c) {
        EXPECT_TRUE(same_bits(scalar.cases[c], batch.cases[c]))
            << "case " << c << ", " << threads << " threads";
        for (std::size_t k = 0; k < scalar.sample_count; ++k)
          EXPECT_TRUE(same_bits(scalar.sample(c, k), batch.sample(c, k)))
              << "case " << c << ", sample " << k;
      }
    }
  }
}

// Lock-step (dopri5, dop853): the lanes of a group share every step, so a lane's result is not its
// own run's but within the tolerance of the true motion, as its own run's is; the same bits on 1
// and 2 threads; a group with a failing case falls back to case by case, which reports each case
// exactly as without lock-step.
TEST(Ensemble, LockstepWithinTheToleranceOfEachCasesOwnRun) {
  static_assert(eom::HasForwardDynamicsBatch<Chain>);
  auto d = eom_ensemble_cases::deployment(10);  // groups 0-3, 4-7 and 8-9 (two lanes idle)
  d.p[5 * Chain::np + 2] = -1.0;                // case 5: M not positive definite
  const std::vector<double> times{0.0, 0.3, 0.75, 1.0};
  for (eom::Method method : {eom::Method::dopri5, eom::Method::dop853}) {
    SCOPED_TRACE(eom::to_string(method));
    eom::EnsembleOptions opt;
    opt.t0 = 0, opt.t1 = 1.0;
    opt.integration.method = method;
    opt.sample_times = times;
    opt.integration.rtol = opt.integration.atol = 1e-13;
    const auto truth = eom::ensemble<Chain>(d.cases(), opt);
    opt.integration.rtol = opt.integration.atol = 1e-8;
    const auto own = eom::ensemble<Chain>(d.cases(), opt);
    opt.lockstep = true;
    std::vector<eom::EnsembleResult<nq>> lockstep;
    for (unsigned threads : {1u, 2u}) {
      opt.threads = threads;
      lockstep.push_back(eom::ensemble<Chain>(d.cases(), opt));
      ASSERT_EQ(lockstep.back().status, eom::Status::ok);
    }
    const auto& r = lockstep[0];
    double worst_own = 0, worst_lockstep = 0;
    for (std::size_t c = 0; c < d.x0.size(); ++c) {
      EXPECT_TRUE(same_bits(r.cases[c], lockstep[1].cases[c])) << "case " << c;
      if (c >= 4 && c < 8) {  // the group with the failing case: case by case
        EXPECT_TRUE(same_bits(r.cases[c], own.cases[c])) << "case " << c;
        continue;
      }
      ASSERT_EQ(r.cases[c].status, eom::Status::ok) << "case " << c;
      EXPECT_EQ(r.cases[c].accepted, r.cases[c / 4 * 4].accepted) << "the group's steps, case " << c;
      for (std::size_t k = 0; k < times.size(); ++k)
        for (int i = 0; i < 2 * nq; ++i) {
          worst_own = std::max(worst_own, std::abs(own.sample(c, k)[i] - truth.sample(c, k)[i]));
          worst_lockstep = std::max(worst_lockstep, std::abs(r.sample(c, k)[i] - truth.sample(c, k)[i]));
        }
    }
    EXPECT_EQ(r.cases[5].status, own.cases[5].status);
    EXPECT_NE(r.cases[5].status, eom::Status::ok);
    std::printf("lock-step %s: worst sample error %.2e (each case's own run %.2e), tolerance 1e-8\n",
                eom::to_string(method), worst_lockstep, worst_own);
    EXPECT_GT(worst_lockstep, 0.0) << "lock-step gave the own runs' bits: did it run?";
    EXPECT_LT(worst_lockstep, 1e-6);
    EXPECT_LT(worst_lockstep, 10 * worst_own + 1e-12);
  }
}

TEST(Ensemble, BadInputRefusedWithInvalidArgument) {
  const auto d = eom_ensemble_cases::deployment(4);
  auto opt = deployment_options(2);
  opt.t1 = 0.1;
  std::vector<eom::IntegrationResult<nq>> results(4);
  const std::vector<double> short_p(d.p.begin(), d.p.end() - 1);
  EXPECT_EQ(eom::ensemble<Chain>({d.x0, short_p, {}}, opt, std::span(results)), eom::Status::invalid_argument);
  EXPECT_EQ(eom::ensemble<Chain>({d.x0, {}, {}}, opt, std::span(results)), eom::Status::invalid_argument);
  const std::vector<double> u{1.0};  // the chain has no inputs
  EXPECT_EQ(eom::ensemble<Chain>({d.x0, d.p, u}, opt, std::span(results)), eom::Status::invalid_argument);
  std::vector<eom::IntegrationResult<nq>> three(3);
  EXPECT_EQ(eom::ensemble<Chain>(d.cases(), opt, std::span(three)), eom::Status::invalid_argument);
  std::vector<eom::StateOf<nq>> samples(3);  // 4 cases × 1 sample time needs 4
  const std::vector<double> one_time{0.05};
  opt.sample_times = one_time;
  EXPECT_EQ(eom::ensemble<Chain>(d.cases(), opt, std::span(results), std::span(samples)),
            eom::Status::invalid_argument);
  const std::vector<double> descending{0.05, 0.01}, outside{0.05, 0.2};
  opt.sample_times = descending;
  EXPECT_EQ(eom::ensemble<Chain>(d.cases(), opt).status, eom::Status::invalid_argument);
  opt.sample_times = outside;
  EXPECT_EQ(eom::ensemble<Chain>(d.cases(), opt).status, eom::Status::invalid_argument);
  opt.sample_times = {};
  opt.integration.output_times = one_time;  // sample_times is the ensemble's way
  EXPECT_EQ(eom::ensemble<Chain>(d.cases(), opt).status, eom::Status::invalid_argument);
  opt.integration.output_times = {};
  opt.input_period = -1;
  EXPECT_EQ(eom::ensemble_with_inputs<Chain>(d.cases(), opt, [](std::size_t, double, const auto&, std::span<double>) {}).status,
            eom::Status::invalid_argument);
  // Nothing was written where the input was refused.
  for (const auto& r : results) EXPECT_EQ(r.t, 0.0);
  // A bad time span is every case's own bad input.
  opt.input_period = 0;
  opt.t1 = opt.t0;
  const auto span = eom::ensemble<Chain>(d.cases(), opt);
  ASSERT_EQ(span.status, eom::Status::ok);
  for (const auto& r : span.cases) EXPECT_EQ(r.status, eom::Status::invalid_argument);
}

TEST(Ensemble, EmptyEnsembleIsOkAndEmpty) {
  auto opt = deployment_options(4);
  opt.sample_times = sample_times;
  const auto r = eom::ensemble<Chain>({}, opt);
  EXPECT_EQ(r.status, eom::Status::ok);
  EXPECT_TRUE(r.cases.empty());
  EXPECT_TRUE(r.samples.empty());
  const std::vector<double> shared(chain10::parameter_values.begin(), chain10::parameter_values.end());
  EXPECT_EQ(eom::ensemble<Chain>({{}, shared, {}}, opt).status, eom::Status::ok);
}

// Inputs from a callback, held over each input period (a sampled controller): the same as
// integrating period by period by hand, and the same on 1 and 4 threads.
TEST(Ensemble, InputsFromACallback) {
  using K = eom::Reference<examples::CartPole>;
  std::vector<eom::StateOf<2>> x0;
  for (int c = 0; c < 6; ++c) x0.push_back({0.1 * c, 0.05 - 0.02 * c, 0.0, 0.0});
  const std::vector<double> p(examples::CartPole::parameter_values.begin(), examples::CartPole::parameter_values.end());
  auto controller = [](std::size_t c, double t, const eom::StateOf<2>& x, std::span<double> u) {
    u[0] = -(1.0 + 0.1 * static_cast<double>(c)) * x[0] - 2.0 * x[2] + 0.5 * std::sin(t);
  };
  eom::EnsembleOptions opt;
  opt.t0 = 0, opt.t1 = 0.25, opt.input_period = 0.02;  // 13 periods, the last one 0.01 s
  opt.integration.method = eom::Method::dopri5;
  const std::vector<double> times{0.0, 0.02, 0.1, 0.25};
  opt.sample_times = times;
  opt.threads = 1;
  const auto one = eom::ensemble_with_inputs<K>({x0, p, {}}, opt, controller);
  opt.threads = 4;
  const auto four = eom::ensemble_with_inputs<K>({x0, p, {}}, opt, controller);
  ASSERT_EQ(one.status, eom::Status::ok);
  ASSERT_EQ(four.status, eom::Status::ok);
  for (std::size_t c = 0; c < x0.size(); ++c) {
    EXPECT_EQ(one.cases[c].status, eom::Status::ok);
    EXPECT_TRUE(same_bits(one.cases[c], four.cases[c]));
    for (std::size_t k = 0; k < times.size(); ++k) EXPECT_TRUE(same_bits(one.sample(c, k), four.sample(c, k)));
    // By hand.
    auto x = x0[c];
    double t = 0;
    long accepted = 0;
    for (int s = 0; s < 13; ++s) {
      const double tb = s == 12 ? 0.25 : 0.02 * (s + 1);
      double u[1];
      controller(c, t, x, u);
      const auto r = eom::integrate<K>(t, tb, x, u, p.data(), opt.integration);
      ASSERT_EQ(r.status, eom::Status::ok);
      x = r.x, t = tb, accepted += r.accepted;
      if (s == 0) {
        EXPECT_TRUE(same_bits(x, one.sample(c, 1)));  // 0.02 is the start of period 1: exact
      }
    }
    EXPECT_TRUE(same_bits(x, one.cases[c].x));
    EXPECT_TRUE(same_bits(x, one.sample(c, 3)));
    EXPECT_EQ(accepted, one.cases[c].accepted);
    EXPECT_TRUE(same_bits(x0[c], one.sample(c, 0)));
  }
  EXPECT_NE(one.cases[0].x[0], one.cases[1].x[0]);
}

}  // namespace
