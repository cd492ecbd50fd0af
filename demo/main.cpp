// The demo: simulates the paper's examples and writes one CSV per example plus a summary that
// demo/plot.py turns into the report. Usage: eom_demo <output directory>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <eom/reference.hpp>
#include <eom/rk4.hpp>

#include "spring_pendulum.hpp"

namespace {

// The spring pendulum (paper Figures 2 and 3): RK4, h = 1 ms, 10 s, from (0.55, 0, 0.01, 2.5).
template <class K> bool spring_pendulum(const std::filesystem::path& dir, std::FILE* summary) {
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
  bool ok = spring_pendulum<eom::Reference<eom::models::SpringPendulum>>(dir, summary);
  std::fclose(summary);
  return ok ? 0 : 1;
}
