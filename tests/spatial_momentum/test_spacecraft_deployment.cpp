// The spacecraft-boom deployment on the generated kernels (the demo's run): from the stowed
// accordion at rest, 60 s of DOP853 at rtol 1e-10. The boom must end straight and at rest, the
// angular momentum must stay zero (no external torque), the energy the dampers took must match the
// energy lost, and the hub's attitude must move (the boom pushes it) but stay far from the Euler
// angles' singularity.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <eom/integration/integrate.hpp>
#include <eom/multibody/momentum.hpp>
#include <models/spacecraft_boom.hpp>
#include <numbers>
#include <spacecraft_boom.hpp>  // generated
#include <span>
#include <vector>

namespace {

using K = spacecraft_boom::Kernels;
using Boom = eom::models::SpacecraftBoom;
constexpr int nq = K::nq;
using State = eom::StateOf<nq>;
constexpr double deg = std::numbers::pi / 180.0;

struct Figures {
  eom::Status status = eom::Status::ok;
  State x_end{};
  double energy0 = 0, energy_end = 0, damper_work = 0;  // E(0), E(T), ∫ Σ c q̇ₖ² dt
  double max_H = 0, max_hub_H = 0;                      // max |H(t)|, max |H_hub(t)|
  double max_attitude[3]{};                             // max |hub_z|, |hub_x|, |hub_y|
  double tip_distance_end = 0;                          // |tip − root| at T
};

Figures deploy(double t1, double dt) {
  const auto p = K::parameter_values;
  const double c = p[9];
  State x0{};
  for (int i = 0; i < nq; ++i) x0[i] = Boom::initial_q[i];
  auto energy = [&](const State& x) {
    return K::kinetic_energy(x.data(), x.data() + nq, p.data()) +
           K::potential_energy(x.data(), p.data());
  };
  auto bodies = [&](const State& x) {
    return eom::body_motions_of<Boom>(std::span<const double>(x.data(), nq),
                                      std::span<const double>(x.data() + nq, nq), p);
  };
  std::vector<double> times;
  const long n = std::lround(t1 / dt);  // even: Simpson's rule over the dense output
  for (long k = 0; k <= n; ++k) times.push_back(static_cast<double>(k) * dt);
  std::vector<double> power;
  Figures f;
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = 1e-10;
  opt.atol = 1e-12;
  opt.output_times = times;
  const auto r =
      eom::integrate<K>(0.0, t1, x0, nullptr, p.data(), opt, [&](double, const State& x) {
        double P = 0;
        for (int k = 0; k < Boom::links; ++k) P += c * x[nq + 3 + k] * x[nq + 3 + k];
        power.push_back(P);
        const auto b = bodies(x);
        const auto H = eom::angular_momentum(b);
        const auto hub = b[0].angular_momentum();
        f.max_H = std::max(f.max_H, std::hypot(H[0], H[1], H[2]));
        f.max_hub_H = std::max(f.max_hub_H, std::hypot(hub[0], hub[1], hub[2]));
        for (int i = 0; i < 3; ++i) f.max_attitude[i] = std::max(f.max_attitude[i], std::abs(x[i]));
      });
  f.status = r.status;
  f.x_end = r.x;
  f.energy0 = energy(x0);
  f.energy_end = energy(r.x);
  for (std::size_t k = 0; k + 2 < power.size(); k += 2)
    f.damper_work += dt / 3 * (power[k] + 4 * power[k + 1] + power[k + 2]);
  const auto b = bodies(r.x);
  const double l = p[6];
  const auto& R = b.back().rotation;
  std::array<double, 3> tip;  // the far end of link 6, mid-link + l/2 along its x axis
  for (int i = 0; i < 3; ++i) tip[i] = b.back().position[i] + 0.5 * l * R[i];
  const auto& Rh = b[0].rotation;  // the root hinge at r_root along the hub's x axis
  f.tip_distance_end =
      std::hypot(tip[0] - p[4] * Rh[0], tip[1] - p[4] * Rh[1], tip[2] - p[4] * Rh[2]);
  return f;
}

TEST(SpacecraftBoomDeployment, DeploysConservesMomentumAndDissipatesWhatTheDampersTake) {
  const auto p = K::parameter_values;
  const Figures f = deploy(60.0, 0.001);
  ASSERT_EQ(f.status, eom::Status::ok) << eom::to_string(f.status);
  std::printf("  tip %.6f m from the root (6 links of %.1f m); hinges at 60 s within %.2e rad\n",
              f.tip_distance_end, p[6], [&] {
                double m = 0;
                for (int k = 0; k < Boom::links; ++k) m = std::max(m, std::abs(f.x_end[3 + k]));
                return m;
              }());
  std::printf("  hub attitude: max |hub_z| %.3f deg, |hub_x| %.3f deg, |hub_y| %.3f deg\n",
              f.max_attitude[0] / deg, f.max_attitude[1] / deg, f.max_attitude[2] / deg);
  std::printf("  max |H(t)| = %.2e N·m·s (H(0) = 0) against max |H_hub(t)| = %.3f N·m·s\n", f.max_H,
              f.max_hub_H);
  const double lost = f.energy0 - f.energy_end;
  std::printf("  E(0) = %.9f J, E(60) = %.3e J, lost %.9f J, damper work %.9f J (rel. diff %.2e)\n",
              f.energy0, f.energy_end, lost, f.damper_work, std::abs(lost - f.damper_work) / lost);

  // Deployed: straight (every hinge within 2°) and at rest (under 0.1% of the stowed energy).
  const double length = Boom::links * p[6];
  EXPECT_GE(f.tip_distance_end, 0.9999 * length);
  for (int k = 0; k < Boom::links; ++k)
    EXPECT_LE(std::abs(f.x_end[3 + k]), 2 * deg) << "hinge " << k + 1;
  EXPECT_LE(f.energy_end, 1e-3 * f.energy0);
  // No external torque: H stays at its initial 0 to integration accuracy, while the hub and the
  // boom exchange momenta many orders larger.
  EXPECT_GE(f.max_hub_H, 0.1);
  EXPECT_LE(f.max_H, 1e-8 * f.max_hub_H);
  // The energy lost is the dampers' work, ∫ Σ c q̇ₖ² dt.
  EXPECT_LE(std::abs(lost - f.damper_work), 1e-7 * lost);
  // The hub turns by degrees, and its middle Euler angle stays far from ±90°.
  EXPECT_GE(std::max(f.max_attitude[0], f.max_attitude[2]), 2 * deg);
  EXPECT_LE(f.max_attitude[1], 10 * deg);
}

}  // namespace
