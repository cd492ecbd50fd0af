// eom::mpi::ensemble under mpiexec -n 2: the results gathered on rank 0 bitwise those of the
// threaded eom::ensemble, for several chunk sizes; failing cases reported; bad input (also on one
// rank only) refused on every rank; MPI not initialized reported with a message.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include <spring_pendulum.hpp>

#include <cart_pole.hpp>
#include <eom/ensemble/mpi_ensemble.hpp>
#include <eom/reference/reference.hpp>

#include "ensemble_cases.hpp"

namespace {

using eom_ensemble_cases::same_bits;
using Chain = chain10::Kernels;
constexpr int nq = Chain::nq;

int rank() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

eom::EnsembleOptions deployment_options() {
  eom::EnsembleOptions opt;
  opt.t0 = 0, opt.t1 = 2.0;
  opt.threads = 1;
  opt.integration.method = eom::Method::dop853;
  opt.integration.rtol = 1e-9, opt.integration.atol = 1e-11;
  return opt;
}
const std::vector<double> sample_times{0.0, 0.5, 1.0, 1.5, 2.0};
const std::vector<double> sample_times_rk4{0.0, 0.1, 0.25, 0.3};

TEST(MpiEnsemble, BitwiseTheThreadedRun) {
  auto d = eom_ensemble_cases::deployment(30);
  for (int i = 0; i < 10; ++i) d.p[7 * Chain::np + i] = 0, d.p[7 * Chain::np + 20 + i] = 0;  // M = 0
  auto opt = deployment_options();
  opt.sample_times = sample_times;
  eom::EnsembleResult<nq> threaded;
  if (rank() == 0) {
    opt.threads = 2;
    threaded = eom::ensemble<Chain>(d.cases(), opt);
    ASSERT_EQ(threaded.status, eom::Status::ok);
    EXPECT_EQ(threaded.failed(), 1u);
    EXPECT_EQ(threaded.cases[7].status, eom::Status::singular_dynamics);
  }
  for (std::size_t chunk : {1u, 4u, 64u}) {
    for (unsigned threads : {1u, 2u}) {
      opt.threads = threads;
      std::vector<eom::IntegrationResult<nq>> results(rank() == 0 ? 30 : 0);
      std::vector<eom::StateOf<nq>> samples(results.size() * sample_times.size());
      const auto r = eom::mpi::ensemble<Chain>(MPI_COMM_WORLD, d.cases(), opt, std::span(results),
                                               std::span(samples), chunk);
      ASSERT_EQ(r.status, eom::Status::ok) << r.message;
      // Every case integrated once, somewhere.
      unsigned long here = r.integrated, total = 0;
      MPI_Allreduce(&here, &total, 1, MPI_UNSIGNED_LONG, MPI_SUM, MPI_COMM_WORLD);
      EXPECT_EQ(total, 30u);
      if (rank() != 0) continue;
      for (std::size_t c = 0; c < 30; ++c) {
        EXPECT_TRUE(same_bits(threaded.cases[c], results[c])) << "case " << c << ", chunk " << chunk;
        for (std::size_t k = 0; k < sample_times.size(); ++k) {
          const auto& a = threaded.sample(c, k);
          const auto& b = samples[c * sample_times.size() + k];
          if (c == 7) {
            EXPECT_TRUE(std::isnan(a[0]) && std::isnan(b[0]));
          } else {
            EXPECT_TRUE(same_bits(a, b)) << "case " << c << ", sample " << k;
          }
        }
      }
    }
  }
}

// RK4 with held inputs: the ranks step groups of batch_lanes cases through forward_dynamics_batch,
// as eom::ensemble does; the gathered results are bitwise the one-case-at-a-time run, whatever the
// chunk (a multiple of the lanes, or not), with a failing case (M = 0) inside a group.
TEST(MpiEnsemble, BatchLanesBitwiseTheOneCaseRun) {
  static_assert(eom::HasForwardDynamicsBatch<Chain>);
  auto d = eom_ensemble_cases::deployment(23);
  for (int i = 0; i < 10; ++i) d.p[9 * Chain::np + i] = 0, d.p[9 * Chain::np + 20 + i] = 0;  // M = 0
  eom::EnsembleOptions opt;
  opt.t0 = 0, opt.t1 = 0.3;
  opt.integration.method = eom::Method::rk4;
  opt.integration.step = 1e-3;
  opt.sample_times = sample_times_rk4;
  eom::EnsembleResult<nq> one;
  if (rank() == 0) {
    opt.batch = false;
    opt.threads = 1;
    one = eom::ensemble<Chain>(d.cases(), opt);
    ASSERT_EQ(one.status, eom::Status::ok);
    EXPECT_EQ(one.cases[9].status, eom::Status::singular_dynamics);
    opt.batch = true;
  }
  const std::size_t ns = sample_times_rk4.size();
  for (std::size_t chunk : {1u, 6u, 8u}) {
    opt.threads = 2;
    std::vector<eom::IntegrationResult<nq>> results(rank() == 0 ? 23 : 0);
    std::vector<eom::StateOf<nq>> samples(results.size() * ns);
    const auto r = eom::mpi::ensemble<Chain>(MPI_COMM_WORLD, d.cases(), opt, std::span(results),
                                             std::span(samples), chunk);
    ASSERT_EQ(r.status, eom::Status::ok) << r.message;
    if (rank() != 0) continue;
    for (std::size_t c = 0; c < 23; ++c) {
      EXPECT_TRUE(same_bits(one.cases[c], results[c])) << "case " << c << ", chunk " << chunk;
      for (std::size_t k = 0; k < ns && c != 9; ++k)
        EXPECT_TRUE(same_bits(one.sample(c, k), samples[c * ns + k])) << "case " << c << ", sample " << k;
    }
  }
}

TEST(MpiEnsemble, InputsFromACallback) {
  using K = eom::Reference<examples::CartPole>;
  std::vector<eom::StateOf<2>> x0;
  for (int c = 0; c < 9; ++c) x0.push_back({0.1 * c, 0.05 - 0.02 * c, 0.0, 0.0});
  const std::vector<double> p(examples::CartPole::parameter_values.begin(), examples::CartPole::parameter_values.end());
  auto controller = [](std::size_t c, double t, const eom::StateOf<2>& x, std::span<double> u) {
    u[0] = -(1.0 + 0.1 * static_cast<double>(c)) * x[0] - 2.0 * x[2] + 0.5 * std::sin(t);
  };
  eom::EnsembleOptions opt;
  opt.t1 = 0.25, opt.input_period = 0.02;
  std::vector<eom::IntegrationResult<2>> results(rank() == 0 ? x0.size() : 0);
  const auto r = eom::mpi::ensemble_with_inputs<K>(MPI_COMM_WORLD, {x0, p, {}}, opt, controller,
                                                   std::span(results), {}, 2);
  ASSERT_EQ(r.status, eom::Status::ok) << r.message;
  if (rank() != 0) return;
  const auto threaded = eom::ensemble_with_inputs<K>({x0, p, {}}, opt, controller);
  for (std::size_t c = 0; c < x0.size(); ++c) {
    EXPECT_EQ(results[c].status, eom::Status::ok);
    EXPECT_TRUE(same_bits(threaded.cases[c], results[c])) << "case " << c;
  }
}

TEST(MpiEnsemble, BadInputRefusedOnEveryRank) {
  const auto d = eom_ensemble_cases::deployment(4);
  auto opt = deployment_options();
  std::vector<eom::IntegrationResult<nq>> results(rank() == 0 ? 4 : 0);
  // Bad everywhere: the parameters of three cases for four.
  const std::vector<double> short_p(d.p.begin(), d.p.end() - Chain::np);
  auto r = eom::mpi::ensemble<Chain>(MPI_COMM_WORLD, {d.x0, short_p, {}}, opt, std::span(results));
  EXPECT_EQ(r.status, eom::Status::invalid_argument);
  EXPECT_NE(std::strstr(r.message, "sizes"), nullptr) << r.message;
  // Bad on rank 1 only: every rank refuses (no rank waits for another forever).
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (size > 1) {
    const auto mine = rank() == 1 ? std::span<const double>(short_p) : std::span<const double>(d.p);
    r = eom::mpi::ensemble<Chain>(MPI_COMM_WORLD, {d.x0, mine, {}}, opt, std::span(results));
    EXPECT_EQ(r.status, eom::Status::invalid_argument);
    if (rank() == 0) {
      EXPECT_NE(std::strstr(r.message, "another rank"), nullptr) << r.message;
    }
  }
  // Result storage missing on rank 0.
  std::vector<eom::IntegrationResult<nq>> none;
  r = eom::mpi::ensemble<Chain>(MPI_COMM_WORLD, d.cases(), opt, std::span(none));
  EXPECT_EQ(r.status, eom::Status::invalid_argument);
  r = eom::mpi::ensemble<Chain>(MPI_COMM_WORLD, d.cases(), opt, std::span(results), {}, 0);
  EXPECT_EQ(r.status, eom::Status::invalid_argument);  // chunk 0
  // Empty: ok, nothing to do.
  r = eom::mpi::ensemble<Chain>(MPI_COMM_WORLD, {}, opt, std::span(none));
  EXPECT_EQ(r.status, eom::Status::ok) << r.message;
}

}  // namespace

int main(int argc, char** argv) {
  // Before MPI_Init: a clear message, no crash.
  {
    using S = spring_pendulum::Kernels;
    const std::vector<eom::StateOf<2>> x0{{0.55, 0.0, 0.01, 2.5}};
    std::vector<eom::IntegrationResult<2>> results(1);
    eom::EnsembleOptions opt;
    opt.t1 = 1;
    const std::vector<double> p(spring_pendulum::parameter_values.begin(), spring_pendulum::parameter_values.end());
    const auto r = eom::mpi::ensemble<S>(MPI_COMM_WORLD, {x0, p, {}}, opt, std::span(results));
    if (r.status != eom::Status::invalid_argument || !std::strstr(r.message, "not initialized")) {
      std::fprintf(stderr, "test_ensemble_mpi: MPI not initialized was not reported: %s\n", r.message);
      return 1;
    }
  }
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  ::testing::InitGoogleTest(&argc, argv);
  if (rank() != 0) {  // one report, rank 0's
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  const int failed = RUN_ALL_TESTS() != 0 ? 1 : 0;
  int any = 0;
  MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return any;
}
