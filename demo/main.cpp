// The demo: simulates the paper's examples with their generated kernels (models/CMakeLists.txt)
// and writes one CSV per example plus a summary that demo/plot.py turns into the report.
// Usage: eom_demo <output directory>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <eom/reference.hpp>
#include <eom/rk4.hpp>

#include <numbers>
#include <vector>

#include <eom/stabilization.hpp>

#include <chain10.hpp>  // generated kernels
#include <closed_chain5.hpp>
#include <models/chain.hpp>  // the models they were generated from (initial states)
#include <models/spring_pendulum.hpp>
#include <spring_pendulum.hpp>

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

// The 10-link inflated-beam deployment (paper Figure 5): stowed as an accordion hanging from the
// pin (odd links at −5°, even links at 185°, i.e. folded back on each other), released with
// θ̇1 = −0.05 rad/s; gravity and hinge damping. RK4, h = 1 ms, 10 s.
template <class K> bool simulate_deployment(const std::filesystem::path& dir, std::FILE* summary) {
  constexpr int n = 10;
  const auto p = K::parameter_values;
  eom::StateOf<n> x0{};
  const double fold = 5.0 * std::numbers::pi / 180.0;
  for (int i = 0; i < n; ++i) x0[i] = i % 2 == 0 ? -fold : std::numbers::pi + fold;
  x0[n] = -0.05;
  double length = 0;
  for (int i = 0; i < n; ++i) length += p[n + i];
  auto tip_fraction = [&](const eom::StateOf<n>& x) {
    double X = 0, Y = 0;
    for (int i = 0; i < n; ++i) X += p[n + i] * std::cos(x[i]), Y += p[n + i] * std::sin(x[i]);
    return std::hypot(X, Y) / length;
  };
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
  ok = simulate_closed_chain<closed_chain5::Kernels>(dir, summary) && ok;
  std::fclose(summary);
  return ok ? 0 : 1;
}
