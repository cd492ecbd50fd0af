// The demo: simulates the paper's examples with their generated kernels (models/CMakeLists.txt)
// and writes one CSV per example plus a summary that demo/plot.py turns into the report.
// Usage: eom_demo <output directory>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <eom/integration/rk4.hpp>
#include <eom/reference/reference.hpp>

#include <numbers>
#include <vector>

#include <eom/integration/stabilization.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <span>

#include <eom/ensemble/ensemble.hpp>
#include <eom/integration/integrate.hpp>
#include <eom/integration/locks.hpp>
#include <eom/multibody/momentum.hpp>
#include <eom/numeric/linalg.hpp>

#include <cinttypes>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <thread>

#include <chain10.hpp>  // generated kernels
#include <closed_chain5.hpp>
#include <panda.hpp>  // generated from models/robots/panda.urdf
#include <panda_tracking.hpp>  // examples/panda_computed_torque: the loop, the law, the payload
#include <ur5.hpp>    // generated from models/robots/ur5.urdf
#include <models/chain.hpp>  // the models they were generated from (initial states)
#include <models/chain_latches.hpp>  // hinge latches for the chain (eom/integration/locks.hpp)
#include <models/spacecraft_boom.hpp>
#include <models/spring_pendulum.hpp>
#include <spacecraft_boom.hpp>
#include <spring_pendulum.hpp>

#include "contact_quadruped.hpp"  // Solo12 standing and trotting on MuJoCo's soft contact
#include "contacts.hpp"
#ifdef EOM_DEMO_CONTACT_SIMULATION
#include "contact_simulation.hpp"  // MuJoCo's humanoid and an incline, contact as MuJoCo
#endif
#include "free_flight.hpp"  // the free-flying scenes
#include "monte_carlo.hpp"  // the Monte Carlo cases, shared with mpi_main.cpp

namespace {

// The spring pendulum (paper Figures 2 and 3): RK4, h = 1 ms, 10 s, from (0.55, 0, 0.01, 2.5).
template <class K> bool simulate_spring_pendulum(const std::filesystem::path& dir, std::FILE* summary) {
  using Model = eom::models::SpringPendulum;
  const auto p = K::parameter_values;
  const eom::StateOf<2> x0{Model::initial_q[0], Model::initial_q[1], Model::initial_qd[0],
                           Model::initial_qd[1]};
  const double t1 = 10.0;
  const long steps = 10000;
  auto energy = [&](const eom::StateOf<2>& x) {
    return K::kinetic_energy(x.data(), x.data() + 2, p.data()) + K::potential_energy(x.data(), p.data());
  };
  const double E0 = energy(x0);
  const auto path = dir / "spring_pendulum.csv";
  std::FILE* csv = std::fopen(path.c_str(), "w");
  if (!csv) {
    std::fprintf(stderr, "eom_demo: cannot write %s\n", path.c_str());
    return false;
  }
  std::fprintf(csv, "t,r,theta,r_dot,theta_dot,energy\n");
  long k = 0;
  double worst = 0;
  const auto r = eom::rk4<K>(0.0, t1, steps, x0, nullptr, p.data(), [&](double t, const eom::StateOf<2>& x) {
    const double E = energy(x);
    worst = std::max(worst, std::abs(E - E0) / std::abs(E0));
    if (k++ % 10 == 0) std::fprintf(csv, "%.6f,%.17g,%.17g,%.17g,%.17g,%.17g\n", t, x[0], x[1], x[2], x[3], E);
  });
  std::fclose(csv);
  if (r.status != eom::Status::ok) {
    std::fprintf(stderr, "eom_demo: spring pendulum stopped at t = %g: %s\n", r.t, eom::to_string(r.status));
    return false;
  }
  std::fprintf(summary,
               "spring_pendulum,RK4 h=%g s,%ld steps,t1=%g,r=%.12f,theta=%.12f,max relative energy error=%.3e\n",
               t1 / static_cast<double>(steps), r.steps, t1, r.x[0], r.x[1], worst);
  std::printf("spring pendulum: %ld RK4 steps to t = %g s, max relative energy error %.3e\n", r.steps, t1, worst);
  return true;
}

using demo::deployment_initial_state;

// The 10-link inflated-beam deployment (paper Figure 5): stowed as an accordion hanging from the
// pin (odd links at −5°, even links at 185°, i.e. folded back on each other), released with
// θ̇1 = −0.05 rad/s; gravity and hinge damping. RK4, h = 1 ms, 10 s.
template <class K> bool simulate_deployment(const std::filesystem::path& dir, std::FILE* summary) {
  constexpr int n = 10;
  const auto p = K::parameter_values;
  const eom::StateOf<n> x0 = deployment_initial_state();
  auto tip_fraction = [&](const eom::StateOf<n>& x) { return demo::tip_fraction(&p[n], x); };
  std::FILE* csv = std::fopen((dir / "deployment.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t");
  for (int i = 1; i <= n; ++i) std::fprintf(csv, ",theta%d", i);
  std::fprintf(csv, ",tip_fraction,kinetic_energy\n");
  long k = 0;
  double at5 = 0;
  const auto r = eom::rk4<K>(0.0, 10.0, 10000, x0, nullptr, p.data(), [&](double t, const eom::StateOf<n>& x) {
    if (std::abs(t - 5.0) < 1e-9) at5 = tip_fraction(x);
    if (k++ % 20 != 0) return;
    std::fprintf(csv, "%.4f", t);
    for (int i = 0; i < n; ++i) std::fprintf(csv, ",%.10f", x[i]);
    std::fprintf(csv, ",%.8f,%.6e\n", tip_fraction(x), K::kinetic_energy(x.data(), x.data() + n, p.data()));
  });
  std::fclose(csv);
  if (r.status != eom::Status::ok) {
    std::fprintf(stderr, "eom_demo: deployment stopped at t = %g: %s\n", r.t, eom::to_string(r.status));
    return false;
  }
  const double K10 = K::kinetic_energy(r.x.data(), r.x.data() + n, p.data());
  std::fprintf(summary, "deployment,RK4 h=1 ms,tip at 5 s=%.4f of full length,tip at 10 s=%.4f,kinetic energy at 10 s=%.3e J\n",
               at5, tip_fraction(r.x), K10);
  std::printf("deployment: tip at %.1f%% of the full length at 5 s, %.1f%% at 10 s; kinetic energy at 10 s %.2e J\n",
              100 * at5, 100 * tip_fraction(r.x), K10);
  return true;
}

// Monte Carlo of the deployment: the 1000 dispersed cases of monte_carlo.hpp, run by
// eom::ensemble on 1 and on 2 threads, timed; both runs must give bitwise the same final states
// and samples (and mpi_main.cpp's run over MPI ranks the same digest, which plot.py checks).
template <class K> bool simulate_deployment_monte_carlo(const std::filesystem::path& dir, std::FILE* summary) {
  using MC = demo::MonteCarlo<K>;
  constexpr int n = MC::n;
  constexpr std::size_t cases = MC::cases;
  constexpr std::uint64_t seed = MC::seed;
  constexpr double t1 = MC::t1, h = MC::h, dt = MC::dt;
  const auto nominal = K::parameter_values;
  MC mc;
  const std::vector<double>& times = mc.times;
  eom::EnsembleOptions& opt = mc.options;
  const eom::EnsembleCases<n> ensemble_cases = mc.ensemble_cases();
  // Runs: one case at a time on one thread (batch off), then through the batch lanes on 1 and 2
  // threads; every run must give the first one's bits.
  struct Run {
    unsigned threads;
    bool batch;
    double seconds = 0;
  };
  std::array<Run, 3> plan{{{1, false}, {1, true}, {2, true}}};
  std::vector<eom::EnsembleResult<n>> runs;
  for (Run& run : plan) {
    opt.threads = run.threads;
    opt.batch = run.batch;
    const auto start = std::chrono::steady_clock::now();
    runs.push_back(eom::ensemble<K>(ensemble_cases, opt));
    run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (runs.back().status != eom::Status::ok) {
      std::fprintf(stderr, "eom_demo: Monte Carlo ensemble refused: %s\n", eom::to_string(runs.back().status));
      return false;
    }
  }
  const auto& r = runs[0];
  // Bitwise: every final state (and time, status, step counts), then every sample.
  std::size_t final_differ = 0, samples_differ = 0;
  for (std::size_t other = 1; other < runs.size(); ++other) {
    for (std::size_t c = 0; c < cases; ++c) {
      const auto &a = r.cases[c], &b = runs[other].cases[c];
      if (a.status != b.status || std::memcmp(&a.t, &b.t, sizeof a.t) != 0 ||
          std::memcmp(a.x.data(), b.x.data(), sizeof a.x) != 0 || a.accepted != b.accepted ||
          a.evaluations != b.evaluations)
        ++final_differ;
    }
    for (std::size_t k = 0; k < r.samples.size(); ++k)
      if (std::memcmp(r.samples[k].data(), runs[other].samples[k].data(), sizeof r.samples[k]) != 0) ++samples_differ;
  }
  const bool identical = final_differ == 0 && samples_differ == 0;
  const std::array<double, 2> seconds{plan[1].seconds, plan[2].seconds};  // batch, 1 and 2 threads

  // (lengths are not dispersed)
  auto tip_fraction = [&](const eom::StateOf<n>& x) { return demo::tip_fraction(&nominal[n], x); };
  // Percentile of sorted values, linear between order statistics (as numpy's default).
  auto percentile = [](const std::vector<double>& sorted, double q) {
    if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
    const double at = q * static_cast<double>(sorted.size() - 1);
    const auto i = static_cast<std::size_t>(at);
    if (i + 1 >= sorted.size()) return sorted.back();
    return sorted[i] + (at - static_cast<double>(i)) * (sorted[i + 1] - sorted[i]);
  };
  const std::size_t failed = r.failed();
  std::FILE* band = std::fopen((dir / "monte_carlo_band.csv").c_str(), "w");
  if (!band) return false;
  std::fprintf(band, "t,p5,median,p95,min,max\n");
  std::vector<double> tips;
  std::vector<double> t99(cases, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < times.size(); ++k) {
    tips.clear();
    for (std::size_t c = 0; c < cases; ++c) {
      const double f = tip_fraction(r.sample(c, k));
      if (!std::isfinite(f)) continue;  // a failed case after it stopped
      tips.push_back(f);
      if (std::isnan(t99[c]) && f >= 0.99) t99[c] = times[k];
    }
    std::sort(tips.begin(), tips.end());
    std::fprintf(band, "%.4f,%.8f,%.8f,%.8f,%.8f,%.8f\n", times[k], percentile(tips, 0.05), percentile(tips, 0.5),
                 percentile(tips, 0.95), tips.empty() ? NAN : tips.front(), tips.empty() ? NAN : tips.back());
  }
  std::fclose(band);
  std::FILE* hit = std::fopen((dir / "monte_carlo_t99.csv").c_str(), "w");
  if (!hit) return false;
  std::fprintf(hit, "case,t99\n");
  std::vector<double> reached;
  for (std::size_t c = 0; c < cases; ++c) {
    std::fprintf(hit, "%zu,%.4f\n", c, t99[c]);  // nan: never within t1
    if (!std::isnan(t99[c])) reached.push_back(t99[c]);
  }
  std::fclose(hit);
  std::sort(reached.begin(), reached.end());
  const std::size_t never = cases - reached.size();
  std::FILE* speed = std::fopen((dir / "monte_carlo_throughput.csv").c_str(), "w");
  if (!speed) return false;
  std::fprintf(speed, "threads,batch,seconds,cases_per_second\n");
  for (const Run& run : plan)
    std::fprintf(speed, "%u,%d,%.4f,%.1f\n", run.threads, run.batch ? 1 : 0, run.seconds, cases / run.seconds);
  std::fclose(speed);
  std::FILE* facts = std::fopen((dir / "monte_carlo.txt").c_str(), "w");
  if (!facts) return false;
  std::fprintf(facts,
               "cases=%zu\nseed=%llu\nt1=%g\nstep=%g\nsample_step=%g\nfailed=%zu\nnever_99=%zu\nmedian_t99=%.3f\n"
               "p5_t99=%.3f\np95_t99=%.3f\nmax_t99=%.3f\nfinal_states_differ=%zu\nsamples_differ=%zu\n"
               "hardware_threads=%u\ndigest=%016" PRIx64 "\n",
               cases, static_cast<unsigned long long>(seed), t1, h, dt, failed, never, percentile(reached, 0.5),
               percentile(reached, 0.05), percentile(reached, 0.95), reached.empty() ? NAN : reached.back(),
               final_differ, samples_differ, std::thread::hardware_concurrency(),
               demo::digest<n>(cases, r.cases.data(), r.samples.data(), r.samples.size()));
  std::fclose(facts);
  std::fprintf(summary,
               "deployment Monte Carlo,%zu cases,RK4 h=1 ms over %g s,median time to 99%%=%.2f s,never reached=%zu,"
               "%.0f cases/s on 1 thread,%.0f on 2,1 and 2 threads bitwise identical=%s\n",
               cases, t1, percentile(reached, 0.5), never, cases / seconds[0], cases / seconds[1],
               identical ? "yes" : "NO");
  std::printf("deployment Monte Carlo: %zu cases, %zu failed; 99%% deployed at median %.2f s (5-95%% %.2f-%.2f s), %zu "
              "never within %g s; %.0f cases/s on 1 thread (%.2f s), %.0f on 2 (%.2f s); 1 vs 2 threads %s\n",
              cases, failed, percentile(reached, 0.5), percentile(reached, 0.05), percentile(reached, 0.95), never, t1,
              cases / seconds[0], seconds[0], cases / seconds[1], seconds[1],
              identical ? "bitwise identical" : "DIFFER");
  if (!identical)
    std::fprintf(stderr, "eom_demo: Monte Carlo: %zu final states and %zu samples differ between 1 and 2 threads\n",
                 final_differ, samples_differ);
  return identical && failed == 0;
}

// The deployment above with hinge latches: hinge i = 2..10 locks when it comes
// straight (eom/integration/locks.hpp: the perfectly inelastic impulse, then held exactly by a switched
// constraint; the root pin stays free). DOP853, rtol = atol = 1e-12, the events located on its
// dense output; sampled every 5 ms. Per latch: the kinetic energy lost (T⁻ − T⁺ from the
// kinetic_energy kernel) against the impulse-momentum formula ½ r²/(aᵀWa), r = aᵀq̇ the hinge's
// relative rate and W the inverse mass matrix of the chain with the earlier latches locked (W a
// = M⁻¹a with the part that would move a locked hinge removed). tests/events/test_latches
// checks the same in the coordinates of the model with fewer coordinates.
template <class K> bool simulate_latched_deployment(const std::filesystem::path& dir, std::FILE* summary) {
  constexpr int n = 10, hinges = n - 1;
  using Latched = eom::Locked<K, eom::models::ChainHingeRows<n>>;
  using Latches = eom::Latches<Latched>;
  const eom::StateOf<n> x0 = deployment_initial_state();
  const auto targets = eom::models::chain_straight_targets<n>(x0.data());
  Latches latches(K::parameter_values, targets, x0);
  const double* p = latches.parameters.data();
  constexpr double t1 = 10.0, dt = 0.005;
  std::vector<double> times;
  for (long k = 0; k <= std::lround(t1 / dt); ++k) times.push_back(static_cast<double>(k) * dt);
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = opt.atol = 1e-12;
  opt.output_times = times;
  auto tip_fraction = [&](const eom::StateOf<n>& x) { return demo::tip_fraction(&p[n], x); };
  std::FILE* csv = std::fopen((dir / "latched_deployment.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t,tip_fraction,kinetic_energy,potential_energy\n");
  double worst_angle = 0, worst_rate = 0;  // latched hinges, at every output after their latch
  std::array<eom::EventRecord<n>, 2 * hinges> storage;
  eom::EventLog<n> log(storage);
  const auto start = std::chrono::steady_clock::now();
  const auto r = eom::integrate<Latched>(0.0, t1, x0, nullptr, p, opt, latches.events(), log,
                                         [&](double t, const eom::StateOf<n>& x) {
    for (int k = 0; k < hinges; ++k)
      if (latches.locked(k)) {  // output times at a latch instant get x⁺ (events.hpp)
        worst_angle = std::max(worst_angle, std::abs(Latches::row(x.data(), k) - targets[k]));
        worst_rate = std::max(worst_rate, std::abs(Latches::row(x.data() + n, k)));
      }
    std::fprintf(csv, "%.4f,%.10f,%.10e,%.10e\n", t, tip_fraction(x), K::kinetic_energy(x.data(), x.data() + n, p),
                 K::potential_energy(x.data(), p));
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fclose(csv);
  if (r.status != eom::Status::ok) {
    std::fprintf(stderr, "eom_demo: latched deployment stopped at t = %g: %s (event %d)\n", r.t,
                 eom::to_string(r.status), r.event);
    return false;
  }
  // The formula, with the flags as they were before each latch.
  std::FILE* table = std::fopen((dir / "latches.csv").c_str(), "w");
  if (!table) return false;
  std::fprintf(table, "hinge,t,T_before,T_after,lost,formula,relative_difference\n");
  auto before = Latched::parameter_values;
  std::copy(p, p + K::np, before.begin());
  double worst_energy = 0;
  for (const auto& e : log.records()) {
    const double *q = e.x.data(), *qd = e.x.data() + n, *qd_after = e.x_after.data() + n;
    std::array<double, n * n> M;
    K::mass_matrix(q, p, M.data());
    if (!eom::linalg::cholesky<double, n>(M)) return false;
    std::array<double, n> a{}, Wa{};
    a = eom::models::ChainHingeRows<n>::rows[e.index];
    Wa = a;
    eom::linalg::cholesky_solve<double, n>(M, Wa.data());
    if (!Latched::project(q, before.data(), Wa.data())) return false;
    double aWa = 0;
    for (int k = 0; k < n; ++k) aWa += a[k] * Wa[k];
    const double rate = Latches::row(qd, e.index), formula = 0.5 * rate * rate / aWa;
    const double Tb = K::kinetic_energy(q, qd, p), Ta = K::kinetic_energy(q, qd_after, p);
    const double rel = std::abs((Tb - Ta) - formula) / formula;
    worst_energy = std::max(worst_energy, rel);
    std::fprintf(table, "%d,%.15f,%.12e,%.12e,%.12e,%.12e,%.3e\n", e.index + 2, e.t, Tb, Ta, Tb - Ta, formula, rel);
    before[K::np + e.index] = 1;
  }
  std::fclose(table);
  std::FILE* facts = std::fopen((dir / "latched_deployment.txt").c_str(), "w");
  if (!facts) return false;
  std::fprintf(facts,
               "latches=%zu\nsteps=%ld\nrejected=%ld\nwall_ms=%.1f\nworst_energy_relative=%.3e\n"
               "max_angle_after_latch=%.3e\nmax_rate_after_latch=%.3e\ntip_end=%.15f\n",
               log.size(), r.accepted, r.rejected, 1e3 * seconds, worst_energy, worst_angle, worst_rate,
               tip_fraction(r.x));
  std::fclose(facts);
  std::fprintf(summary,
               "latched deployment,DOP853 rtol=atol=1e-12,%zu latches,last at %.6f s,%ld steps,%.1f ms,"
               "energy lost vs formula worst rel. %.1e,latched hinges within %.1e rad of straight\n",
               log.size(), log.size() ? log.records().back().t : NAN, r.accepted, 1e3 * seconds, worst_energy,
               worst_angle);
  std::printf("latched deployment: %zu latches (last at %.3f s) in %.1f ms; energy lost vs formula worst %.1e "
              "(rel.); latched hinges within %.1e rad of straight, relative rates below %.1e rad/s\n",
              log.size(), log.size() ? log.records().back().t : NAN, 1e3 * seconds, worst_energy, worst_angle,
              worst_rate);
  return log.size() == static_cast<std::size_t>(hinges) && log.dropped() == 0;
}

// The 5-link closed chain (paper Figure 7): from rest in the symmetric arch, driven on link 1,
// RK4 h = 1 ms with projection, 10 s. Then the constraint residual over 10 s and 1000 s for each
// stabilization, at h = 5 ms.
template <class K> bool simulate_closed_chain(const std::filesystem::path& dir, std::FILE* summary) {
  constexpr int n = 5;
  using Method = eom::Stabilization::Method;
  const auto p = K::parameter_values;
  eom::StateOf<n> x0{};
  for (int i = 0; i < n; ++i) x0[i] = eom::models::ClosedChain5::initial_q[i];
  std::FILE* csv = std::fopen((dir / "closed_chain.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t,theta1,theta2,theta3,theta4,theta5,phi_max\n");
  eom::Stabilization projection;
  projection.method = Method::projection;
  long k = 0;
  auto r = eom::rk4<K>(0.0, 10.0, 10000, x0, nullptr, p.data(), [&](double t, const eom::StateOf<n>& x) {
    if (k++ % 10 != 0) return;
    const auto res = eom::constraint_residuals<K>(x.data(), x.data() + n, p.data());
    std::fprintf(csv, "%.4f,%.10f,%.10f,%.10f,%.10f,%.10f,%.3e\n", t, x[0], x[1], x[2], x[3], x[4], res[0]);
  }, projection);
  std::fclose(csv);
  if (r.status != eom::Status::ok) {
    std::fprintf(stderr, "eom_demo: closed chain stopped at t = %g: %s\n", r.t, eom::to_string(r.status));
    return false;
  }
  std::FILE* table = std::fopen((dir / "constraint_residuals.csv").c_str(), "w");
  if (!table) return false;
  std::fprintf(table, "method,t_end,max_abs_phi,max_abs_Cqd\n");
  const char* names[] = {"none", "baumgarte", "projection"};
  for (double t1 : {10.0, 1000.0})
    for (int m = 0; m < 3; ++m) {
      eom::Stabilization stab;
      stab.method = static_cast<Method>(m);
      double wp = 0, wv = 0;
      r = eom::rk4<K>(0.0, t1, static_cast<long>(t1 / 0.005), x0, nullptr, p.data(), [&](double, const eom::StateOf<n>& x) {
        const auto res = eom::constraint_residuals<K>(x.data(), x.data() + n, p.data());
        wp = std::max(wp, res[0]);
        wv = std::max(wv, res[1]);
      }, stab);
      std::fprintf(table, "%s,%g,%.3e,%.3e\n", names[m], t1, wp, wv);
      std::fprintf(summary, "closed chain residual,%s,RK4 h=5 ms,t=%g s,status=%s,max |phi|=%.3e,max |C qd|=%.3e\n",
                   names[m], t1, eom::to_string(r.status), wp, wv);
      std::printf("closed chain, %-10s over %6g s: max |phi| %.3e, max |C qd| %.3e (%s)\n", names[m], t1, wp, wv,
                  eom::to_string(r.status));
    }
  std::fclose(table);
  return true;
}

// The spacecraft-boom deployment (models/spacecraft_boom.hpp): the hub free to rotate about its
// fixed mass centre, the 6-link boom released from its stowed 3D accordion at rest, hinge springs
// unfolding it and hinge dampers taking the energy. DOP853 at rtol 1e-10, dense output every
// 1 ms over 60 s: the hub's attitude, H (must stay at H(0) = 0: no external torque), E against the
// dampers' work ∫ Σ c q̇ₖ² dt (Simpson over the dense output), the distance of the middle Euler
// angle from its singularity, and snapshots of the shape for the frame strip.
template <class K> bool simulate_spacecraft(const std::filesystem::path& dir, std::FILE* summary) {
  using Boom = eom::models::SpacecraftBoom;
  constexpr int nq = K::nq, links = Boom::links;
  using State = eom::StateOf<nq>;
  constexpr double deg = 180.0 / std::numbers::pi;
  const auto p = K::parameter_values;
  const double c = p[9], r_root = p[4], l = p[6], length = links * l;
  const double t1 = 60.0, dt = 0.001;
  const long n = std::lround(t1 / dt);
  State x0{};
  for (int i = 0; i < nq; ++i) x0[i] = Boom::initial_q[i];
  auto energy = [&](const State& x) {
    return K::kinetic_energy(x.data(), x.data() + nq, p.data()) + K::potential_energy(x.data(), p.data());
  };
  auto bodies = [&](const State& x) {
    return eom::body_motions_of<Boom>(std::span<const double>(x.data(), nq),
                                      std::span<const double>(x.data() + nq, nq), p);
  };
  // The joints: the root on the hub's face, then the far end of each link.
  auto joints = [&](const std::array<eom::BodyMotion<double>, Boom::body_count>& b) {
    std::array<std::array<double, 3>, links + 1> j{};
    for (int i = 0; i < 3; ++i) j[0][i] = r_root * b[0].rotation[i];
    for (int k = 0; k < links; ++k)
      for (int i = 0; i < 3; ++i) j[k + 1][i] = b[k + 1].position[i] + 0.5 * l * b[k + 1].rotation[i];
    return j;
  };
  std::vector<double> times(n + 1);
  for (long k = 0; k <= n; ++k) times[k] = static_cast<double>(k) * dt;
  const std::array<double, 8> snapshot_times{0, 1, 2, 3, 4, 6, 10, 60};

  std::FILE* csv = std::fopen((dir / "spacecraft.csv").c_str(), "w");
  std::FILE* frames = std::fopen((dir / "spacecraft_frames.csv").c_str(), "w");
  if (!csv || !frames) return false;
  std::fprintf(csv, "t,hub_z,hub_x,hub_y");
  for (int k = 1; k <= links; ++k) std::fprintf(csv, ",hinge%d", k);
  std::fprintf(csv, ",Hx,Hy,Hz,hub_H,energy,damper_work,tip_fraction\n");
  std::fprintf(frames, "t");
  for (int i = 0; i < 9; ++i) std::fprintf(frames, ",R%d", i);
  for (int k = 0; k <= links; ++k) std::fprintf(frames, ",x%d,y%d,z%d", k, k, k);
  std::fprintf(frames, "\n");

  const double E0 = energy(x0);
  double work = 0, previous_power = 0, middle_power = 0;  // Simpson over pairs of 1 ms intervals
  double max_dH = 0, max_hub_H = 0, max_angle[3]{};
  double deployed_95 = -1, max_abs_hub_x = 0;
  long k = 0;
  std::size_t snapshot = 0;
  const auto start = std::chrono::steady_clock::now();
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = 1e-10;
  opt.atol = 1e-12;
  opt.output_times = times;
  const auto r = eom::integrate<K>(0.0, t1, x0, nullptr, p.data(), opt, [&](double t, const State& x) {
    double power = 0;
    for (int h = 0; h < links; ++h) power += c * x[nq + 3 + h] * x[nq + 3 + h];
    if (k > 0 && k % 2 == 0) work += dt / 3 * (previous_power + 4 * middle_power + power);
    if (k % 2 == 0) previous_power = power; else middle_power = power;
    const auto b = bodies(x);
    const auto H = eom::angular_momentum(b);
    const auto hub = b[0].angular_momentum();
    const double hub_H = std::hypot(hub[0], hub[1], hub[2]);
    max_dH = std::max(max_dH, std::hypot(H[0], H[1], H[2]));  // H(0) = 0: at rest
    max_hub_H = std::max(max_hub_H, hub_H);
    for (int i = 0; i < 3; ++i) max_angle[i] = std::max(max_angle[i], std::abs(x[i]));
    max_abs_hub_x = max_angle[1];
    const auto j = joints(b);
    const double tip = std::hypot(j[links][0] - j[0][0], j[links][1] - j[0][1], j[links][2] - j[0][2]) / length;
    if (deployed_95 < 0 && tip >= 0.95) deployed_95 = t;
    if (k % 50 == 0) {  // every 50 ms (k even: `work` is Simpson's sum up to t)
      std::fprintf(csv, "%.3f", t);
      for (int i = 0; i < 3 + links; ++i) std::fprintf(csv, ",%.10f", x[i] * deg);
      std::fprintf(csv, ",%.3e,%.3e,%.3e,%.8f,%.10f,%.10f,%.8f\n", H[0], H[1], H[2], hub_H, energy(x), work,
                   tip);
    }
    if (snapshot < snapshot_times.size() && std::abs(t - snapshot_times[snapshot]) < 0.5 * dt) {
      ++snapshot;
      std::fprintf(frames, "%.3f", t);
      for (int i = 0; i < 9; ++i) std::fprintf(frames, ",%.10f", b[0].rotation[i]);
      for (const auto& point : j) std::fprintf(frames, ",%.8f,%.8f,%.8f", point[0], point[1], point[2]);
      std::fprintf(frames, "\n");
    }
    ++k;
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fclose(csv);
  std::fclose(frames);
  if (r.status != eom::Status::ok) {
    std::fprintf(stderr, "eom_demo: spacecraft deployment stopped at t = %g: %s\n", r.t, eom::to_string(r.status));
    return false;
  }
  const double E1 = energy(r.x), lost = E0 - E1;
  double hinge_end = 0;
  for (int h = 0; h < links; ++h) hinge_end = std::max(hinge_end, std::abs(r.x[3 + h]));
  // The singularity: cos(hub_x) = 0. Its distance along the run: 90° − max |hub_x|.
  const double margin = 90.0 - max_abs_hub_x * deg;
  std::FILE* facts = std::fopen((dir / "spacecraft.txt").c_str(), "w");
  if (!facts) return false;
  std::fprintf(facts,
               "steps=%ld\nrejected=%ld\nevaluations=%ld\nwall_ms=%.1f\n"
               "max_hub_z_deg=%.4f\nmax_hub_x_deg=%.4f\nmax_hub_y_deg=%.4f\n"
               "end_hub_z_deg=%.4f\nend_hub_x_deg=%.4f\nend_hub_y_deg=%.4f\n"
               "max_abs_H=%.3e\nmax_hub_H=%.6f\nrelative_H=%.3e\n"
               "E0=%.9f\nE_end=%.3e\nlost=%.9f\ndamper_work=%.9f\nenergy_relative_difference=%.3e\n"
               "singularity_margin_deg=%.4f\nmin_cos_hub_x=%.8f\ndeployed_95_s=%.3f\nmax_hinge_end_deg=%.4f\n",
               r.accepted, r.rejected, r.evaluations, 1e3 * seconds, max_angle[0] * deg, max_angle[1] * deg,
               max_angle[2] * deg, r.x[0] * deg, r.x[1] * deg, r.x[2] * deg, max_dH, max_hub_H,
               max_dH / max_hub_H, E0, E1, lost, work, std::abs(lost - work) / lost, margin,
               std::cos(max_abs_hub_x), deployed_95, hinge_end * deg);
  std::fclose(facts);
  std::fprintf(summary,
               "spacecraft boom,DOP853 rtol=1e-10,%ld steps,%.0f ms,max |hub angles| (z x y)=%.3f %.3f %.3f deg,"
               "max |H(t)-H(0)|=%.2e N m s (max |H_hub|=%.3f),E(0)-E(60)=%.9f J,damper work=%.9f J,"
               "singularity margin=%.3f deg\n",
               r.accepted, 1e3 * seconds, max_angle[0] * deg, max_angle[1] * deg, max_angle[2] * deg, max_dH,
               max_hub_H, lost, work, margin);
  std::printf("spacecraft boom: 95%% deployed at %.2f s; hub max |z, x, y| = %.2f, %.2f, %.2f deg; max |H - H0| %.2e "
              "(%.1e of max |H_hub|); E lost %.6f J vs damper work %.6f J (rel. %.1e); %.2f deg from the "
              "Euler singularity; %ld DOP853 steps, %.0f ms\n",
              deployed_95, max_angle[0] * deg, max_angle[1] * deg, max_angle[2] * deg, max_dH, max_dH / max_hub_H,
              lost, work, std::abs(lost - work) / lost, margin, r.accepted, 1e3 * seconds);
  return true;
}

// The operation counts the generator wrote into a robot's generated source ("// <name>:
// <kernel> (<n> operations"), for the report; written as robot,kernel,operations.
bool write_operation_counts(std::FILE* out, const char* robot, const char* source) {
  std::ifstream in(source);
  if (!in) {
    std::fprintf(stderr, "eom_demo: cannot read %s (the operation counts)\n", source);
    return false;
  }
  const std::string prefix = std::string("// ") + robot + ": ";
  std::string line;
  int found = 0;
  while (std::getline(in, line)) {
    if (!line.starts_with(prefix)) continue;
    const auto open = line.find(" (", prefix.size());
    if (open == std::string::npos) continue;
    const std::string kernel = line.substr(prefix.size(), open - prefix.size());
    const long ops = std::strtol(line.c_str() + open + 2, nullptr, 10);
    std::fprintf(out, "%s,%s,%ld\n", robot, kernel.c_str(), ops);
    ++found;
  }
  return found > 0;
}

// The Panda (models/robots/panda.urdf, 7 dof, the bundled `panda` kernels) tracking a 7-joint
// multi-sine by computed torque at 1 kHz with a 1 kg payload: the loop of
// examples/panda_computed_torque (panda_tracking.hpp), run here on the bundled kernels. Three
// runs of 10 s: the exact model, the law without the velocity terms (no c), and a payload 20%
// heavier than the controller assumes.
bool simulate_panda(const std::filesystem::path& dir, std::FILE* summary) {
  using K = panda::Kernels;
  using panda_ct::Law;
  constexpr int n = panda_ct::n;
  const panda_ct::Settings settings;
  const auto p = panda_ct::with_payload<K>(K::parameter_values, 1.0);
  const auto p_heavy = panda_ct::with_payload<K>(K::parameter_values, 1.2);
  const auto start = std::chrono::steady_clock::now();
  const auto nominal = panda_ct::simulate<K>(p, p, Law::full, settings);
  const auto no_c = panda_ct::simulate<K>(p, p, Law::no_velocity_terms, settings);
  const auto payload = panda_ct::simulate<K>(p_heavy, p, Law::full, settings);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const auto* run : {&nominal, &no_c, &payload})
    if (!run->ok) {
      std::fprintf(stderr, "eom_demo: Panda plant stopped at t = %g: %s\n", run->failed_at, run->failure);
      return false;
    }
  std::FILE* csv = std::fopen((dir / "panda_ct.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t");
  for (const char* column : {"e", "no_c_e", "payload_e", "tau"})
    for (int i = 1; i <= n; ++i) std::fprintf(csv, ",%s%d", column, i);
  std::fprintf(csv, "\n");
  for (std::size_t r = 0; r < nominal.log.size(); ++r) {
    std::fprintf(csv, "%.3f", nominal.log[r].t);
    for (const auto* run : {&nominal, &no_c, &payload})
      for (int i = 0; i < n; ++i) std::fprintf(csv, ",%.6e", run->log[r].e[i]);
    for (int i = 0; i < n; ++i) std::fprintf(csv, ",%.6g", nominal.log[r].tau[i]);
    std::fprintf(csv, "\n");
  }
  std::fclose(csv);
  std::FILE* facts = std::fopen((dir / "panda_ct.txt").c_str(), "w");
  if (!facts) return false;
  std::fprintf(facts,
               "duration=%g\nsettle=%g\nwn=%g\nsteps=%ld\nrejected=%ld\nevaluations=%ld\nwall_ms=%.1f\n"
               "nominal_max=%.3e\nnominal_rms=%.3e\nno_c_max=%.3e\nno_c_rms=%.3e\npayload_max=%.3e\n"
               "payload_rms=%.3e\nmax_error_with_start=%.3e\n",
               settings.duration, settings.settle_time, settings.natural_frequency, nominal.steps,
               nominal.rejected, nominal.evaluations, 1e3 * seconds, nominal.max_error_settled,
               nominal.rms_error_settled, no_c.max_error_settled, no_c.rms_error_settled,
               payload.max_error_settled, payload.rms_error_settled, nominal.max_error);
  for (int i = 0; i < n; ++i)
    std::fprintf(facts, "max_tau%d=%.2f\nlimit_tau%d=%g\n", i + 1, nominal.max_torque[i], i + 1,
                 panda_ct::effort_limit[i]);
  std::fclose(facts);
  std::fprintf(summary,
               "panda computed torque,1 kHz ZOH,DOP853 plant,%g s,max |e| after %g s: exact model %.3e rad,"
               "no c %.3e rad,payload +20%% %.3e rad\n",
               settings.duration, settings.settle_time, nominal.max_error_settled, no_c.max_error_settled,
               payload.max_error_settled);
  std::printf("panda computed torque: max |e| after %g s %.3e rad (exact model), %.3e (no c), %.3e (payload +20%%); "
              "%ld plant steps per run, %.0f ms for the three runs\n",
              settings.settle_time, nominal.max_error_settled, no_c.max_error_settled, payload.max_error_settled,
              nominal.steps, 1e3 * seconds);
  return true;
}

// The UR5 (models/robots/ur5.urdf, 6 dof, the bundled `ur5` kernels) released at rest from a
// raised pose with no torque and no damping (the file's damping is 0: the model has no damping
// parameter), falling under gravity for 5 s; DOP853 at rtol = atol = 1e-12, the energy
// E = T + V checked at every accepted step (no interpolation).
bool simulate_ur5_fall(const std::filesystem::path& dir, std::FILE* summary) {
  using K = ur5::Kernels;
  constexpr int n = K::nq;
  using State = eom::StateOf<n>;
  auto p = K::parameter_values;
  for (int i = 0; i < K::np; ++i)
    if (K::parameter_names[i].ends_with("_damping")) p[i] = 0;  // damping off (none in ur5.urdf)
  const State x0{0.0, -0.6, 0.9, -1.2, 1.1, 0.4, 0, 0, 0, 0, 0, 0};  // at rest
  const std::array<double, n> u{};
  auto energy = [&](const State& x) {
    return K::kinetic_energy(x.data(), x.data() + n, p.data()) + K::potential_energy(x.data(), p.data());
  };
  const double E0 = energy(x0), t1 = 5.0;
  std::FILE* csv = std::fopen((dir / "ur5_fall.csv").c_str(), "w");
  if (!csv) return false;
  std::fprintf(csv, "t");
  for (int i = 1; i <= n; ++i) std::fprintf(csv, ",q%d", i);
  std::fprintf(csv, ",kinetic_energy,energy_error\n");
  double max_dE = 0, max_T = 0;
  std::array<double, n> max_rate{};
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = opt.atol = 1e-12;
  const auto start = std::chrono::steady_clock::now();
  const auto r = eom::integrate<K>(0.0, t1, x0, u.data(), p.data(), opt, [&](double t, const State& x) {
    const double T = K::kinetic_energy(x.data(), x.data() + n, p.data());
    const double dE = energy(x) - E0;
    max_dE = std::max(max_dE, std::abs(dE));
    max_T = std::max(max_T, T);
    for (int i = 0; i < n; ++i) max_rate[i] = std::max(max_rate[i], std::abs(x[n + i]));
    std::fprintf(csv, "%.6f", t);
    for (int i = 0; i < n; ++i) std::fprintf(csv, ",%.12f", x[i]);
    std::fprintf(csv, ",%.12e,%.6e\n", T, dE);
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fclose(csv);
  if (r.status != eom::Status::ok) {
    std::fprintf(stderr, "eom_demo: UR5 fall stopped at t = %g: %s\n", r.t, eom::to_string(r.status));
    return false;
  }
  std::FILE* facts = std::fopen((dir / "ur5_fall.txt").c_str(), "w");
  if (!facts) return false;
  std::fprintf(facts,
               "t1=%g\nsteps=%ld\nrejected=%ld\nevaluations=%ld\nwall_ms=%.1f\nE0=%.9f\nmax_T=%.6f\n"
               "max_abs_dE=%.3e\nrelative_dE=%.3e\n",
               t1, r.accepted, r.rejected, r.evaluations, 1e3 * seconds, E0, max_T, max_dE, max_dE / max_T);
  std::fprintf(facts, "q0=");
  for (int i = 0; i < n; ++i) std::fprintf(facts, "%s%g", i ? "," : "", x0[i]);
  std::fprintf(facts, "\nmax_rate=");
  for (int i = 0; i < n; ++i) std::fprintf(facts, "%s%.2f", i ? "," : "", max_rate[i]);
  std::fprintf(facts, "\n");
  std::fclose(facts);
  std::fprintf(summary, "ur5 free fall,DOP853 rtol=atol=1e-12,%g s,%ld steps,max |E(t)-E(0)|=%.3e J (%.1e of max T=%.3f J)\n",
               t1, r.accepted, max_dE, max_dE / max_T, max_T);
  std::printf("ur5 free fall: %ld DOP853 steps (%ld rejected) over %g s, %.0f ms; max |E(t) - E(0)| %.3e J, %.1e of "
              "the largest kinetic energy %.2f J\n",
              r.accepted, r.rejected, t1, 1e3 * seconds, max_dE, max_dE / max_T, max_T);
  return true;
}

// Where the robots' kernels come from, for the report: their operation counts per kernel.
bool write_robot_kernels(const std::filesystem::path& dir) {
  std::FILE* out = std::fopen((dir / "robot_kernels.csv").c_str(), "w");
  if (!out) return false;
  std::fprintf(out, "robot,kernel,operations\n");
  bool ok = write_operation_counts(out, "panda", EOM_PANDA_SOURCE);
  ok = write_operation_counts(out, "ur5", EOM_UR5_SOURCE) && ok;
  std::fclose(out);
  std::FILE* facts = std::fopen((dir / "robots.txt").c_str(), "w");
  if (!facts) return false;
  std::fprintf(facts, "panda_nq=%d\npanda_np=%d\nur5_nq=%d\nur5_np=%d\n", panda::nq, panda::np, ur5::nq, ur5::np);
  std::fclose(facts);
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: eom_demo <output directory>\n");
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  std::FILE* summary = std::fopen((dir / "summary.csv").c_str(), "w");
  if (ec || !summary) {
    std::fprintf(stderr, "eom_demo: cannot write to %s\n", dir.c_str());
    return 1;
  }
  bool ok = simulate_spring_pendulum<spring_pendulum::Kernels>(dir, summary);
  ok = simulate_deployment<chain10::Kernels>(dir, summary) && ok;
  ok = simulate_deployment_monte_carlo<chain10::Kernels>(dir, summary) && ok;
  ok = simulate_latched_deployment<chain10::Kernels>(dir, summary) && ok;
  ok = simulate_closed_chain<closed_chain5::Kernels>(dir, summary) && ok;
  ok = simulate_spacecraft<spacecraft_boom::Kernels>(dir, summary) && ok;
  ok = simulate_free_flight(dir, summary) && ok;
  ok = simulate_contacts(dir, summary) && ok;
  ok = simulate_trot(dir, summary) && ok;
#ifdef EOM_DEMO_CONTACT_SIMULATION
  ok = simulate_contact_simulation(dir, summary) && ok;
#endif
  ok = simulate_contact_quadruped(dir, summary) && ok;
  ok = simulate_panda(dir, summary) && ok;
  ok = simulate_ur5_fall(dir, summary) && ok;
  ok = write_robot_kernels(dir) && ok;
  std::fclose(summary);
  return ok ? 0 : 1;
}
