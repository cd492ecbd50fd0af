// The deployment Monte Carlo of the demo (monte_carlo.hpp) distributed over MPI ranks by
// eom::mpi::ensemble: scripts/demo.sh runs it with mpiexec -n 2 after eom_demo. Rank 0 writes
// report/monte_carlo_mpi.csv (ranks, seconds, cases per second, the cases each rank integrated,
// and the digest of the results, which demo/plot.py compares with the threaded run's).
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <chain10.hpp>
#include <eom/ensemble/mpi_ensemble.hpp>

#include "monte_carlo.hpp"

int main(int argc, char** argv) {
  int provided = 0;  // eom::mpi::ensemble asks for MPI_THREAD_FUNNELED (its threads never call MPI)
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  using K = chain10::Kernels;
  const demo::MonteCarlo<K> mc;
  std::vector<eom::IntegrationResult<K::nq>> results(rank == 0 ? mc.cases : 0);
  std::vector<eom::StateOf<K::nq>> samples(results.size() * mc.times.size());
  MPI_Barrier(MPI_COMM_WORLD);
  const auto start = std::chrono::steady_clock::now();
  const eom::mpi::Outcome r =
      eom::mpi::ensemble<K>(MPI_COMM_WORLD, mc.ensemble_cases(), mc.options, std::span(results), std::span(samples),
                            /*chunk=*/4 * K::batch_lanes);  // whole batch groups per request
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  unsigned long long mine = r.integrated;
  std::vector<unsigned long long> per_rank(ranks);
  MPI_Gather(&mine, 1, MPI_UNSIGNED_LONG_LONG, per_rank.data(), 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
  int status = r.status == eom::Status::ok ? 0 : 1;
  if (rank == 0 && status) std::fprintf(stderr, "eom_demo_mpi: %s\n", r.message);
  if (rank == 0 && !status) {
    const std::filesystem::path dir = argc > 1 ? argv[1] : ".";
    std::FILE* out = std::fopen((dir / "monte_carlo_mpi.csv").c_str(), "w");
    if (!out) {
      std::fprintf(stderr, "eom_demo_mpi: cannot write into %s\n", dir.c_str());
      status = 1;
    } else {
      std::string split;
      for (int i = 0; i < ranks; ++i) {
        if (i) split += ' ';
        split += std::to_string(per_rank[i]);
      }
      std::fprintf(out, "ranks,seconds,cases_per_second,cases_per_rank,digest\n%d,%.4f,%.1f,%s,%016" PRIx64 "\n",
                   ranks, seconds, mc.cases / seconds, split.c_str(),
                   demo::digest<K::nq>(mc.cases, results.data(), samples.data(), samples.size()));
      std::fclose(out);
      std::printf("deployment Monte Carlo over %d MPI ranks: %.0f cases/s (%.2f s), cases per rank %s\n", ranks,
                  mc.cases / seconds, seconds, split.c_str());
    }
  }
  MPI_Finalize();
  return status;
}
