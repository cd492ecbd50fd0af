// eom::mpi::ensemble: an ensemble (eom/ensemble/ensemble.hpp) distributed over the ranks of an MPI
// communicator, with dynamic load balancing, the results gathered on rank 0. Built only when MPI
// is found (the CMake target eom::mpi; Debian: libopenmpi-dev, openmpi-bin).
//
//   MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
//   ... every rank builds the same cases and options ...
//   auto r = eom::mpi::ensemble<K>(MPI_COMM_WORLD, cases, opt, results, samples, /*chunk=*/4);
//   if (r.status != eom::Status::ok) std::puts(r.message);
//   // rank 0: results[c], samples[c·S + k] for every case, bitwise as eom::ensemble gives them
//
// Rank 0 hands out work: its main thread answers requests (and calls MPI; nothing else does, so
// MPI_THREAD_FUNNELED suffices) while opt.threads threads of its own integrate cases. A worker
// rank asks for `chunk` cases, integrates them on opt.threads threads, and sends their results
// with its next request; rank 0 answers with the next chunk or "done". Every case is taken from
// one counter on rank 0, so a rank that drew expensive cases simply asks less often. Each case is
// integrated exactly as by eom::ensemble (the same function, the same inputs), so the gathered
// results are bitwise those of the threaded run for any number of ranks, threads and chunk size.
// Where eom::ensemble uses the batch kernel (held inputs, RK4, forward_dynamics_batch), so do the
// ranks: rank 0's threads take batch_lanes cases at a time, a worker steps its chunk in groups of
// batch_lanes (give chunk a multiple of K::batch_lanes, or the last lanes of a group idle).
//
// Every rank must pass the same cases and options (results and samples may be empty on ranks
// other than 0). Bad input is agreed on by all ranks (one MPI_Allreduce) and returned as
// Status::invalid_argument with a message, on every rank, before any work; no exceptions. An
// uninitialized MPI or one without MPI_THREAD_FUNNELED is reported the same way.
#pragma once

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cstdint>
#include <cstring>
#include <thread>
#include <type_traits>
#include <vector>

#include "eom/ensemble/ensemble.hpp"

namespace eom::mpi {

struct Outcome {
  Status status = Status::ok;
  const char* message = "ok";  // why, when status is not ok
  std::size_t integrated = 0;   // cases integrated on this rank (the load balance, for reports)
};

namespace detail {

inline constexpr int request_tag = 7301, work_tag = 7302;

// memcpy for spans that may be empty: an empty std::vector's data() may be null, and memcpy's
// pointers must not be, even for zero bytes (UBSan: "null pointer passed as argument").
inline void copy_bytes(void* to, const void* from, std::size_t bytes) noexcept {
  if (bytes > 0) std::memcpy(to, from, bytes);
}

template <Dynamics K, class Inputs>
Outcome distribute(MPI_Comm comm, const EnsembleCasesFor<K>& cases, const EnsembleOptions& opt,
                   bool input_callback, Inputs& inputs,
                   std::span<IntegrationResultFor<K>> results,
                   std::span<StateFor<K>> samples, std::size_t chunk) noexcept {
  using Result = IntegrationResultFor<K>;
  using State = StateFor<K>;
  static_assert(std::is_trivially_copyable_v<Result> && std::is_trivially_copyable_v<State>);

  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (!initialized || finalized)
    return {Status::invalid_argument,
            "eom::mpi::ensemble: MPI is not initialized (call MPI_Init_thread with "
            "MPI_THREAD_FUNNELED first, and start the program with mpiexec)"};
  int provided = MPI_THREAD_SINGLE;
  MPI_Query_thread(&provided);
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);

  const std::size_t n = cases.x0.size(), ns = opt.sample_times.size();
  const std::size_t message_bytes = 2 * sizeof(std::int64_t) + chunk * sizeof(Result) +
                                    chunk * ns * sizeof(State);
  const bool sizes_ok = eom::detail::ensemble_input_ok<K>(
      cases, opt, input_callback, rank == 0 ? results.size() : n,
      rank == 0 ? samples.size() : n * ns);
  const bool chunk_ok = chunk >= 1 && chunk <= (INT_MAX - 64) / (sizeof(Result) + ns * sizeof(State) + 1);
  int ok = sizes_ok && chunk_ok && provided >= MPI_THREAD_FUNNELED ? 1 : 0, all_ok = 0;
  MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, comm);
  if (!all_ok) {
    if (provided < MPI_THREAD_FUNNELED)
      return {Status::invalid_argument,
              "eom::mpi::ensemble: MPI gives no thread support; initialize it with "
              "MPI_Init_thread(..., MPI_THREAD_FUNNELED, ...)"};
    if (!chunk_ok) return {Status::invalid_argument, "eom::mpi::ensemble: bad chunk size"};
    if (!sizes_ok)
      return {Status::invalid_argument,
              "eom::mpi::ensemble: the sizes of the cases, options or result spans do not fit"};
    return {Status::invalid_argument, "eom::mpi::ensemble: another rank was given bad input"};
  }
  if (n == 0) return {};

  // As eom::ensemble: held inputs, RK4, a batch kernel: groups of batch_lanes cases step together
  // (bitwise the one-case path); a worker batches within each chunk it is dealt.
  const bool batch = !input_callback && eom::detail::batch_applies<K>(opt);
  if (rank != 0) {  // a worker: ask, integrate, send the results with the next request
    std::vector<std::byte> message(message_bytes);
    std::vector<Result> local_results(chunk);
    std::vector<State> local_samples(chunk * ns);
    std::size_t integrated = 0;
    std::int64_t done[2] = {0, 0}, work[2] = {0, 0};
    for (;;) {
      const auto count = static_cast<std::size_t>(done[1]);
      copy_bytes(message.data(), done, sizeof done);
      copy_bytes(message.data() + sizeof done, local_results.data(), count * sizeof(Result));
      copy_bytes(message.data() + sizeof done + count * sizeof(Result), local_samples.data(),
                 count * ns * sizeof(State));
      const auto bytes = sizeof done + count * (sizeof(Result) + ns * sizeof(State));
      MPI_Send(message.data(), static_cast<int>(bytes), MPI_BYTE, 0, request_tag, comm);
      MPI_Recv(work, 2, MPI_INT64_T, 0, work_tag, comm, MPI_STATUS_IGNORE);
      if (work[1] == 0) break;
      const auto first = static_cast<std::size_t>(work[0]), m = static_cast<std::size_t>(work[1]);
      const auto out = std::span(local_results).first(m);
      const auto out_samples = std::span(local_samples).first(m * ns);
      if constexpr (eom::detail::BatchModel<K>)
        if (batch) eom::detail::run_batch_cases<K>(first, first + m, cases, opt, out, out_samples, first);
      if (!batch) eom::detail::run_cases<K>(first, first + m, cases, opt, inputs, out, out_samples);
      done[0] = work[0], done[1] = work[1];
      integrated += m;
    }
    return {Status::ok, "ok", integrated};
  }

  // Rank 0: its own threads integrate single cases from the counter while this thread deals out
  // chunks from the same counter and stores what comes back, by case index.
  std::atomic<std::size_t> next{0}, integrated{0};
  auto local_work = [&] {
    IntegrationOptions integration = opt.integration;
    std::vector<double> workspace(eom::detail::taylor_workspace_doubles<K>(integration));
    integration.taylor_workspace = workspace;
    if constexpr (eom::detail::BatchModel<K>)
      if (batch) {  // a group of batch_lanes consecutive cases at a time
        constexpr std::size_t W = K::batch_lanes;
        for (std::size_t c; (c = next.fetch_add(W, std::memory_order_relaxed)) < n;) {
          eom::detail::run_batch_group<K>(c, std::min(c + W, n), cases, opt, integration, results, samples);
          integrated.fetch_add(std::min(W, n - c), std::memory_order_relaxed);
        }
        return;
      }
    for (std::size_t c; (c = next.fetch_add(1, std::memory_order_relaxed)) < n;)
    {
      eom::detail::run_case<K>(c, cases, opt, integration, inputs, results[c],
                               samples.subspan(c * ns, ns));
      integrated.fetch_add(1, std::memory_order_relaxed);
    }
  };
  {
    std::jthread local([&] {
      eom::detail::run_on_threads(eom::detail::thread_count(opt.threads, n), local_work);
    });
    std::vector<std::byte> message(message_bytes);
    for (int active = size - 1; active > 0;) {
      int flag = 0;
      MPI_Status status;
      MPI_Iprobe(MPI_ANY_SOURCE, request_tag, comm, &flag, &status);
      if (!flag) {  // poll gently: the local threads want the cores
        std::this_thread::sleep_for(std::chrono::microseconds(100));
        continue;
      }
      int bytes = 0;
      MPI_Get_count(&status, MPI_BYTE, &bytes);
      MPI_Recv(message.data(), bytes, MPI_BYTE, status.MPI_SOURCE, request_tag, comm,
               MPI_STATUS_IGNORE);
      std::int64_t done[2];
      copy_bytes(done, message.data(), sizeof done);
      const auto first = static_cast<std::size_t>(done[0]), m = static_cast<std::size_t>(done[1]);
      copy_bytes(results.data() + first, message.data() + sizeof done, m * sizeof(Result));
      copy_bytes(samples.data() + first * ns, message.data() + sizeof done + m * sizeof(Result),
                 m * ns * sizeof(State));
      const std::size_t start = next.fetch_add(chunk, std::memory_order_relaxed);
      std::int64_t work[2] = {0, 0};
      if (start < n) {
        work[0] = static_cast<std::int64_t>(start);
        work[1] = static_cast<std::int64_t>(std::min(chunk, n - start));
      } else {
        --active;  // this worker is done
      }
      MPI_Send(work, 2, MPI_INT64_T, status.MPI_SOURCE, work_tag, comm);
    }
  }  // the local threads join here
  return {Status::ok, "ok", integrated.load()};
}

}  // namespace detail

// Held inputs (EnsembleCases::u). results and samples as in eom::ensemble, filled on rank 0.
template <Dynamics K>
Outcome ensemble(MPI_Comm comm, const EnsembleCasesFor<K>& cases, const EnsembleOptions& opt,
                 std::span<IntegrationResultFor<K>> results,
                 std::span<StateFor<K>> samples = {}, std::size_t chunk = 1) noexcept {
  eom::detail::HeldInputs held;
  return detail::distribute<K>(comm, cases, opt, false, held, results, samples, chunk);
}

// Inputs from a callback, as eom::ensemble_with_inputs (every rank calls its own copy).
template <Dynamics K, class Inputs>
Outcome ensemble_with_inputs(MPI_Comm comm, const EnsembleCasesFor<K>& cases,
                             const EnsembleOptions& opt, Inputs&& inputs,
                             std::span<IntegrationResultFor<K>> results,
                             std::span<StateFor<K>> samples = {},
                             std::size_t chunk = 1) noexcept {
  return detail::distribute<K>(comm, cases, opt, true, inputs, results, samples, chunk);
}

}  // namespace eom::mpi
