// eom/multibody/momentum.hpp: the angular momentum of spatial body-form models, against a hand-written
// rigid body, and its conservation along free trajectories of the spacecraft-boom model (no
// external torque: H about the hub's fixed mass centre is constant, dampers or not).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <eom/integration/integrate.hpp>
#include <eom/multibody/momentum.hpp>
#include <eom/multibody/spatial.hpp>
#include <eom/reference/reference.hpp>
#include <models/spacecraft_boom.hpp>
#include <random>
#include <span>
#include <vector>

namespace {

// One free rigid body: attitude roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll)), mass centre at
// (x, y, z), a full inertia tensor.
struct TumblingBody {
  static constexpr std::array coordinates{"roll", "pitch", "yaw", "x", "y", "z"};
  static constexpr std::array parameters{"m", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"};
  static constexpr std::array parameter_values{2.0, 1.0, 1.5, 2.0, 0.1, -0.2, 0.15};
  static constexpr int body_count = 1;
  template <class S>
  static void bodies(eom::In<S> q, eom::In<S> p, eom::Out<eom::SpatialBody<S>> b) {
    const auto frame =
        eom::translation<S>({q[3], q[4], q[5]}) * eom::rotation(eom::rpy(q[0], q[1], q[2]));
    b[0] = eom::rigid_body(frame, p[0], {p[1], p[2], p[3], p[4], p[5], p[6]});
  }
  template <class S> static S potential_energy(eom::In<S>, eom::In<S>) { return S(0); }
};

using Vec = std::array<double, 3>;
double norm(const Vec& v) { return std::hypot(v[0], v[1], v[2]); }
Vec minus(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

// H by hand: the body rates of roll-pitch-yaw angles (φ, θ, ψ),
//   ω = (φ̇ − sin θ ψ̇,  cos φ θ̇ + sin φ cos θ ψ̇,  −sin φ θ̇ + cos φ cos θ ψ̇),
// then H = m r × v + R J ω.
Vec angular_momentum_by_hand(const std::array<double, 6>& q, const std::array<double, 6>& qd,
                             const std::array<double, 7>& p) {
  const double phi = q[0], theta = q[1], psi = q[2];
  const double dphi = qd[0], dtheta = qd[1], dpsi = qd[2];
  const Vec w{dphi - std::sin(theta) * dpsi,
              std::cos(phi) * dtheta + std::sin(phi) * std::cos(theta) * dpsi,
              -std::sin(phi) * dtheta + std::cos(phi) * std::cos(theta) * dpsi};
  const double J[3][3] = {{p[1], p[4], p[5]}, {p[4], p[2], p[6]}, {p[5], p[6], p[3]}};
  Vec Jw{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) Jw[i] += J[i][j] * w[j];
  const auto R = eom::rpy<double>(phi, theta, psi);  // column-major
  Vec H{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) H[i] += R[i + 3 * j] * Jw[j];
  const double m = p[0];
  const Vec r{q[3], q[4], q[5]}, v{qd[3], qd[4], qd[5]};
  H[0] += m * (r[1] * v[2] - r[2] * v[1]);
  H[1] += m * (r[2] * v[0] - r[0] * v[2]);
  H[2] += m * (r[0] * v[1] - r[1] * v[0]);
  return H;
}

TEST(AngularMomentum, SpinAboutAFixedAxis) {
  // Spinning at 2 rad/s about the world z axis, principal inertia (1, 2, 3): H = (0, 0, 6). The
  // mass centre at the origin: no orbital part.
  const std::array<double, 6> q{0, 0, 0.7, 0, 0, 0}, qd{0, 0, 2, 0, 0, 0};
  const std::array<double, 7> p{2.0, 1.0, 2.0, 3.0, 0, 0, 0};
  const auto H = eom::angular_momentum_of<TumblingBody>(q, qd, p);
  EXPECT_NEAR(H[0], 0.0, 1e-15);
  EXPECT_NEAR(H[1], 0.0, 1e-15);
  EXPECT_NEAR(H[2], 6.0, 1e-15);
}

TEST(AngularMomentum, TumblingBodyMatchesTheHandFormula) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> U(-2, 2), pitch(-1.3, 1.3);
  const auto p = TumblingBody::parameter_values;
  double worst = 0;
  for (int trial = 0; trial < 100; ++trial) {
    std::array<double, 6> q, qd;
    for (auto& x : q) x = U(rng);
    for (auto& x : qd) x = U(rng);
    q[1] = pitch(rng);
    const Vec H = eom::angular_momentum_of<TumblingBody>(q, qd, p);
    const Vec want = angular_momentum_by_hand(q, qd, p);
    worst = std::max(worst, norm(minus(H, want)) / std::max(1.0, norm(want)));
    // T = ½ (m|v|² + ωᵀJω) from the same pass as eom::kinetic_energy_of.
    const auto motion = eom::body_motions_of<TumblingBody>(q, qd, p)[0];
    const auto& w = motion.angular_velocity;
    const double J[3][3] = {{p[1], p[4], p[5]}, {p[4], p[2], p[6]}, {p[5], p[6], p[3]}};
    double wJw = 0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) wJw += w[i] * J[i][j] * w[j];
    const double v2 = qd[3] * qd[3] + qd[4] * qd[4] + qd[5] * qd[5];
    const double T = eom::kinetic_energy_of<TumblingBody, double>(q, qd, p);
    EXPECT_NEAR(0.5 * (p[0] * v2 + wJw), T, 1e-13);
  }
  std::printf("  H against the hand formula: max relative error %.2e\n", worst);
  EXPECT_LE(worst, 1e-14);
}

using Boom = eom::models::SpacecraftBoom;
using BoomRef = eom::Reference<Boom>;
constexpr int nq = BoomRef::nq;

std::array<double, 3> momentum(const eom::StateOf<nq>& x, const double* p) {
  return eom::angular_momentum_of<Boom>(std::span<const double>(x.data(), nq),
                                        std::span<const double>(x.data() + nq, nq),
                                        std::span<const double>(p, BoomRef::np));
}

// The sum of the bodies' |H|: the size of the momentum being exchanged among them.
double exchanged(const eom::StateOf<nq>& x, const double* p) {
  double s = 0;
  for (const auto& b : eom::body_motions_of<Boom>(std::span<const double>(x.data(), nq),
                                                  std::span<const double>(x.data() + nq, nq),
                                                  std::span<const double>(p, BoomRef::np)))
    s += norm(b.angular_momentum());
  return s;
}

// Along the free motion from a random state (hub spinning, hinges swinging): max |H(t) − H(0)|
// relative to |H(0)|, over `seconds` of DOP853 at rtol 1e-12.
double momentum_drift(double damping, double seconds, unsigned seed) {
  auto p = BoomRef::parameter_values;
  p[9] = damping;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> angle(-1, 1), rate(-0.5, 0.5);
  eom::StateOf<nq> x0{};
  for (int i = 0; i < nq; ++i) x0[i] = angle(rng), x0[nq + i] = rate(rng);
  const auto H0 = momentum(x0, p.data());
  eom::IntegrationOptions opt;
  opt.method = eom::Method::dop853;
  opt.rtol = 1e-12;
  opt.atol = 1e-12;
  double worst = 0;
  const auto r = eom::integrate<BoomRef>(
      0.0, seconds, x0, nullptr, p.data(), opt, [&](double, const eom::StateOf<nq>& x) {
        worst = std::max(worst, norm(minus(momentum(x, p.data()), H0)));
      });
  EXPECT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status);
  EXPECT_GT(r.accepted, 20);
  std::printf(
      "  c = %g: |H(0)| = %.3f N·m·s, max |H(t) - H(0)| / |H(0)| = %.2e over %g s (%ld steps)\n",
      damping, norm(H0), worst / norm(H0), seconds, r.accepted);
  return worst / norm(H0);
}

TEST(AngularMomentum, ConservedAlongTheUndampedBoom) {
  EXPECT_LE(momentum_drift(0.0, 4.0, 7), 1e-9);
}

// The hinge dampers act on the relative rate of the two bodies they join, with equal and opposite
// torques: internal, so H stays constant while the energy drains.
TEST(AngularMomentum, ConservedWithTheHingeDampers) {
  EXPECT_LE(momentum_drift(8.0, 4.0, 8), 1e-9);
}

// dH/dt = 0 at each state, by a central difference along the flow (q, q̇) ± ε (q̇, q̈): zero to the
// difference's own error, while the bodies' momenta themselves change at rates of order one.
TEST(AngularMomentum, RateIsZeroAtRandomStates) {
  const auto p = BoomRef::parameter_values;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(-1.2, 1.2), rate(-1, 1);
  double worst = 0, hub_rate = 0;
  for (int trial = 0; trial < 20; ++trial) {
    eom::StateOf<nq> x{};
    for (int i = 0; i < nq; ++i) x[i] = angle(rng), x[nq + i] = rate(rng);
    std::array<double, nq> qdd;
    ASSERT_TRUE(
        BoomRef::forward_dynamics(0.0, x.data(), x.data() + nq, nullptr, p.data(), qdd.data()));
    const double eps = 1e-5;
    eom::StateOf<nq> ahead = x, behind = x;
    for (int i = 0; i < nq; ++i) {
      ahead[i] += eps * x[nq + i], behind[i] -= eps * x[nq + i];
      ahead[nq + i] += eps * qdd[i], behind[nq + i] -= eps * qdd[i];
    }
    const Vec dH = minus(momentum(ahead, p.data()), momentum(behind, p.data()));
    worst = std::max(worst, norm(dH) / (2 * eps) / exchanged(x, p.data()));
    auto hub = [&](const eom::StateOf<nq>& s) {
      return eom::body_motions_of<Boom>(std::span<const double>(s.data(), nq),
                                        std::span<const double>(s.data() + nq, nq), p)[0]
          .angular_momentum();
    };
    hub_rate = std::max(hub_rate,
                        norm(minus(hub(ahead), hub(behind))) / (2 * eps) / exchanged(x, p.data()));
  }
  std::printf("  |dH/dt| / sum |H_i| <= %.2e (the hub's own |dH_hub/dt| / sum |H_i| up to %.2f)\n",
              worst, hub_rate);
  EXPECT_LE(worst, 1e-7);
  EXPECT_GE(hub_rate, 1e-2);  // the check can see a change: the hub's share does change
}

// The hinge coordinate is the relative rate the damper acts on: the world angular velocities of
// link k and its parent differ by q̇ₖ about the hinge axis.
TEST(SpacecraftBoom, HingeRatesAreTheRelativeRatesOfTheBodies) {
  const auto p = BoomRef::parameter_values;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-3, 3), rate(-2, 2);
  double worst = 0;
  for (int trial = 0; trial < 50; ++trial) {
    std::array<double, nq> q, qd;
    for (auto& v : q) v = angle(rng);
    for (auto& v : qd) v = rate(rng);
    q[1] = std::clamp(q[1], -1.4, 1.4);
    const auto bodies = eom::body_motions_of<Boom>(q, qd, p);
    for (int k = 0; k < Boom::links; ++k) {
      const Vec relative =
          minus(bodies[k + 1].world_angular_velocity(), bodies[k].world_angular_velocity());
      const auto axis = Boom::hinge_axis(k);  // in the parent's (and the link's) frame
      const auto& R = bodies[k + 1].rotation;
      for (int i = 0; i < 3; ++i) {
        const double want = qd[3 + k] * (R[i] * axis[0] + R[i + 3] * axis[1] + R[i + 6] * axis[2]);
        worst = std::max(worst, std::abs(relative[i] - want));
      }
    }
  }
  EXPECT_LE(worst, 1e-13);
}

}  // namespace
