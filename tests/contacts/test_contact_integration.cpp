// Integrating on contact sets (eom/integration/contacts.hpp): Solo12 on a free base under a joint
// PD loop at 1 kHz (rk4, one step per period), its generated kernels (contact_solo12):
//   - held on its four feet for 10 s while the joints sway the body: every foot within 1e-9 of
//     where it stood (the figure); feet started 1 µm off their anchors pulled back by kp;
//   - dropped from 3 cm: the touchdown event fires at the free-fall time √(2h/g), the impulse
//     stops every foot (J v⁺ = 0) and balances momentum, and the feet then stay where they
//     touched;
//   - held on a diagonal pair (trot) until a third foot touches: the stance set takes over, the
//     pair keeping its anchors to the bit;
//   - bad parameters are refused (a set out of range: NaN and false).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include <contact_solo12.hpp>

#include <eom/integration/contacts.hpp>
#include <eom/integration/integrate.hpp>
#include <eom/model/free_joint.hpp>

namespace {

using K = contact_solo12::Kernels;
using C = eom::OnContacts<K>;
constexpr int nq = K::nq, nv = K::nv, nu = K::nu, joints = 12;
static_assert(nu == joints && nv == 6 + joints);
constexpr int stance = 0, trot = 1;  // tests/contacts/CMakeLists.txt: stance, trot, flat, all_flat
// Gains the 1 kHz sampled loop keeps stable in flight too (the legs alone are light: with
// 20 N·m/rad and 1 N·m·s/rad it diverges before touchdown).
constexpr double period = 1e-3, kp_joint = 5, kd_joint = 0.1;

// The standing posture: legs bent (front HFE 0.8, KFE −1.6; hind mirrored), level base, its
// height putting FL_FOOT on z = height; `tuck` bends FR's and HL's knees that much more (and
// their hips half of it), lifting those feet (the posture stays symmetric under a half turn
// about z).
std::array<double, nq> posture(double height, double tuck = 0) {
  std::array<double, nq> q{};
  q[3] = 1;  // qw
  for (int leg = 0; leg < 4; ++leg) {  // FL, FR, HL, HR
    const double front = leg < 2 ? 1.0 : -1.0, bend = leg == 1 || leg == 2 ? tuck : 0.0;
    q[7 + 3 * leg + 1] = (0.8 + bend / 2) * front, q[7 + 3 * leg + 2] = -(1.6 + bend) * front;
  }
  double x[3], R[9];
  K::frame_placement(0, q.data(), K::parameter_values.data(), x, R);
  q[2] = height - x[2];
  return q;
}

double foot_height(int f, const double* q) {
  double x[3], R[9];
  K::frame_placement(f, q, K::parameter_values.data(), x, R);
  return x[2];
}

// Joint torques toward the posture q_ref (with its joints swayed by `sway` rad on the HAA joints).
std::array<double, nu> pd(const eom::StateFor<C>& x, const std::array<double, nq>& q_ref, double sway) {
  std::array<double, nu> u;
  for (int j = 0; j < joints; ++j) {
    const double target = q_ref[7 + j] + (j % 3 == 0 ? sway : 0.0);
    u[j] = kp_joint * (target - x[7 + j]) - kd_joint * x[nq + 6 + j];
  }
  return u;
}

eom::IntegrationOptions rk4() {
  eom::IntegrationOptions opt;
  opt.method = eom::Method::rk4;
  opt.step = period;
  return opt;
}

// The largest distance of set s's feet from their anchors in p.
double foot_drift(int s, const double* q, const double* p) {
  std::array<double, C::max_rows> e{};
  C::placement_errors(s, q, p, e.data());
  double worst = 0;
  for (int i = 0; i < K::contact_rows[s]; ++i) worst = std::max(worst, std::abs(e[i]));
  return worst;
}

// `seconds` on four feet, the body swayed sideways at 0.5 Hz, the anchors first moved up by
// `offset`; the worst foot drift from `from` seconds on.
double stand(const eom::ContactGains& gains, double seconds = 10, double offset = 0, double from = 0) {
  const auto q0 = posture(0);
  eom::Touchdowns<C, 0> held(K::parameter_values, gains, stance, {}, 0, q0.data());
  for (int f = 0; f < 4; ++f) held.parameters[C::anchor_index + C::anchor_size * f + 2] += offset;
  const double* p = held.parameters.data();
  eom::StateFor<C> x{};
  std::copy(q0.begin(), q0.end(), x.begin());
  double worst = 0;
  const int steps = static_cast<int>(std::lround(seconds / period));
  for (int k = 0; k < steps; ++k) {
    const double t = k * period;
    const auto u = pd(x, q0, 0.15 * std::sin(M_PI * t));
    const auto r = eom::integrate<C>(t, t + period, x, u.data(), p, rk4());
    EXPECT_EQ(r.status, eom::Status::ok) << "at t = " << t;
    if (r.status != eom::Status::ok) return std::numeric_limits<double>::infinity();
    x = r.x;
    if (t >= from) worst = std::max(worst, foot_drift(stance, x.data(), p));
  }
  return worst;
}

TEST(ContactIntegration, FeetStayWhereTheyStoodForTenSeconds) {
  const double held = stand({.kd = 40, .kp = 400});
  const double velocity_only = stand({.kd = 40, .kp = 0});
  std::printf("Solo12 on four feet, 10 s at 1 kHz (rk4): worst foot drift %.2e m with kd = 40, "
              "kp = 400; %.2e m with kd = 40 alone\n", held, velocity_only);
  EXPECT_LE(held, 1e-9);
  EXPECT_LE(velocity_only, 1e-9);  // nothing to correct here: the truncation error is that small
}

// The position term: feet started 1 µm from their anchors reach them as ë + kd ė + kp e = 0
// says (critically damped at 20/s: e⁻²⁰·21 of 1 µm after 1 s, round-off in the last second);
// kd alone holds the velocity and leaves the 1 µm.
TEST(ContactIntegration, KpPullsTheFeetBackToTheirAnchors) {
  const double corrected = stand({.kd = 40, .kp = 400}, 2, 1e-6, 1);
  const double uncorrected = stand({.kd = 40, .kp = 0}, 2, 1e-6, 1);
  std::printf("feet started 1 µm off: %.2e m in the second second with kp = 400, %.2e m with kd "
              "alone\n", corrected, uncorrected);
  EXPECT_LE(corrected, 1e-12);
  EXPECT_NEAR(uncorrected, 1e-6, 1e-8);
}

TEST(ContactIntegration, TouchdownStopsTheFeetAtTheFreeFallTime) {
  constexpr double drop = 0.03;
  const auto q_ref = posture(0);
  const auto q0 = posture(drop);
  const int fl = 0;  // frame FL_FOOT: every foot is level with it, the legs mirrored
  eom::Touchdowns<C, 1> touch(K::parameter_values, {.kd = 40, .kp = 400}, -1,
                              {{{.set = stance, .frame = fl, .height = 0}}}, 0, q0.data());
  const double* p = touch.parameters.data();
  eom::StateFor<C> x{};
  std::copy(q0.begin(), q0.end(), x.begin());
  std::array<eom::EventRecord<nq, nv>, 4> storage;
  eom::EventLog<nq, nv> log(storage);
  const double g = K::parameter_values[0];
  const double t_touch = std::sqrt(2 * drop / g);
  double worst_after = 0, touched_at = -1;
  for (int k = 0; k < 2000; ++k) {
    const double t = k * period;
    const auto u = pd(x, q_ref, 0);
    const auto r = eom::integrate<C>(t, t + period, x, u.data(), p, rk4(), touch.events(), log);
    ASSERT_EQ(r.status, eom::Status::ok) << "at t = " << t;
    if (touched_at < 0 && log.records().size() == 1) {
      const auto& e = log.records()[0];
      touched_at = e.t;
      // Before: every joint still where the PD holds it in free fall; every foot at z = 0.
      for (int f = 0; f < 4; ++f) EXPECT_NEAR(foot_height(f, e.x.data()), 0, 1e-14) << f;
      // After: every foot at rest (J v⁺ = 0), the impulse's balance M(v⁺ − v⁻) = JᵀΛ.
      std::array<double, 6 * nv> J;
      std::array<double, nv * nv> M;
      K::mass_matrix(e.x.data(), p, M.data());
      std::array<double, nv> balance{};
      double momentum = 0;  // the largest |(M v⁻)ᵢ|, the scale of the balance
      for (int i = 0; i < nv; ++i) {
        double m = 0;
        for (int k2 = 0; k2 < nv; ++k2) {
          balance[i] += M[i + nv * k2] * (e.x_after[nq + k2] - e.x[nq + k2]);
          m += M[i + nv * k2] * e.x[nq + k2];
        }
        momentum = std::max(momentum, std::abs(m));
      }
      for (int f = 0; f < 4; ++f) {
        K::frame_jacobian(f, e.x.data(), p, J.data());
        for (int row = 0; row < 3; ++row) {
          double foot_v = 0;
          for (int k2 = 0; k2 < nv; ++k2) foot_v += J[row + 6 * k2] * e.x_after[nq + k2];
          EXPECT_NEAR(foot_v, 0, 1e-13) << "foot " << f << " row " << row;
          for (int i = 0; i < nv; ++i) balance[i] -= J[row + 6 * i] * touch.impulse()[3 * f + row];
        }
      }
      for (int i = 0; i < nv; ++i) EXPECT_NEAR(balance[i], 0, 1e-14 * momentum) << i;
      // e = 0 takes energy out, never puts it in.
      EXPECT_LT(K::kinetic_energy(e.x_after.data(), e.x_after.data() + nq, p),
                K::kinetic_energy(e.x.data(), e.x.data() + nq, p));
      EXPECT_EQ(touch.set(), stance);
    }
    x = r.x;
    if (touched_at >= 0) worst_after = std::max(worst_after, foot_drift(stance, x.data(), p));
  }
  ASSERT_EQ(log.records().size(), 1u);
  std::printf("Solo12 dropped from %.0f cm: touchdown at %.15f s (free fall %.15f s), feet then "
              "within %.2e m for %.2f s\n", drop * 100, touched_at, t_touch, worst_after, 2 - touched_at);
  // The free fall is quadratic in t, which rk4's cubic Hermite output reproduces exactly.
  EXPECT_NEAR(touched_at, t_touch, 1e-12);
  EXPECT_LE(worst_after, 1e-9);
  // The anchors are where the feet touched: on the ground.
  for (int f = 0; f < 4; ++f) EXPECT_NEAR(C::anchor(p, f)[2], 0, 1e-14) << f;
}

// From diagonal support to four feet: Solo12 held on FL and HR (the trot set), FR and HL tucked
// up; the legs give under the weight until FR touches, HL nearly with it (the posture's half-turn
// symmetry; the robot's own is not exact), and the touchdown switches to the stance set: FL and
// HR keep their anchors to the bit, FR and HL are anchored where they are, and all four then
// stay there.
TEST(ContactIntegration, TrotToStanceKeepsTheSharedAnchors) {
  const auto q0 = posture(0, 0.1);
  const double lift = foot_height(1, q0.data());
  ASSERT_GT(lift, 1e-3);
  ASSERT_NEAR(foot_height(2, q0.data()), lift, 1e-15);
  const int fr = 1;
  eom::Touchdowns<C, 1> touch(K::parameter_values, {.kd = 40, .kp = 400}, trot,
                              {{{.set = stance, .frame = fr, .height = 0}}}, 0, q0.data());
  const double* p = touch.parameters.data();
  const auto anchors = [&](int f) {
    std::array<double, C::anchor_size> a;
    std::copy_n(C::anchor(p, f), a.size(), a.begin());
    return a;
  };
  const auto fl = anchors(0), hr = anchors(3);
  eom::StateFor<C> x{};
  std::copy(q0.begin(), q0.end(), x.begin());
  std::array<eom::EventRecord<nq, nv>, 4> storage;
  eom::EventLog<nq, nv> log(storage);
  double worst_after = 0;
  for (int k = 0; k < 1000; ++k) {
    const double t = k * period;
    const auto u = pd(x, q0, 0);
    const auto r = eom::integrate<C>(t, t + period, x, u.data(), p, rk4(), touch.events(), log);
    ASSERT_EQ(r.status, eom::Status::ok) << "at t = " << t;
    x = r.x;
    if (touch.set() == stance) worst_after = std::max(worst_after, foot_drift(stance, x.data(), p));
  }
  ASSERT_EQ(log.records().size(), 1u);
  const auto& e = log.records()[0];
  std::printf("Solo12 on FL and HR, FR and HL %.2f mm up: they touch at %.6f s (HL at %.1e m), "
              "all four then within %.2e m\n", 1e3 * lift, e.t, foot_height(2, e.x.data()), worst_after);
  EXPECT_EQ(touch.set(), stance);
  EXPECT_EQ(anchors(0), fl);
  EXPECT_EQ(anchors(3), hr);
  double x_fr[3], x_hl[3], R[9];
  K::frame_placement(1, e.x.data(), p, x_fr, R);
  K::frame_placement(2, e.x.data(), p, x_hl, R);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(anchors(1)[i], x_fr[i]) << i;
    EXPECT_EQ(anchors(2)[i], x_hl[i]) << i;
  }
  EXPECT_NEAR(x_fr[2], 0, 1e-15);
  EXPECT_NEAR(x_hl[2], 0, 1e-4);
  EXPECT_LE(worst_after, 1e-9);
}

TEST(ContactIntegration, BadParametersAreRefused) {
  const auto q0 = posture(0);
  std::array<double, C::np> p = C::parameter_values;
  C::hold(stance, q0.data(), p.data());
  std::array<double, nv> v{}, vdot;
  std::array<double, nu> u{};
  p[C::set_index] = K::ncontact_sets;  // out of range
  EXPECT_FALSE(C::forward_dynamics(0, q0.data(), v.data(), u.data(), p.data(), vdot.data()));
  EXPECT_TRUE(std::isnan(vdot[0]));
  p[C::set_index] = 0.5;  // not an index
  EXPECT_FALSE(C::forward_dynamics(0, q0.data(), v.data(), u.data(), p.data(), vdot.data()));
  p[C::set_index] = stance;
  p[C::kp_index] = -1;
  EXPECT_FALSE(C::forward_dynamics(0, q0.data(), v.data(), u.data(), p.data(), vdot.data()));
  p[C::kp_index] = 0, p[C::kd_index] = -1;  // the kernel's own refusal
  EXPECT_FALSE(C::forward_dynamics(0, q0.data(), v.data(), u.data(), p.data(), vdot.data()));
  p[C::kd_index] = 0;
  EXPECT_TRUE(C::forward_dynamics(0, q0.data(), v.data(), u.data(), p.data(), vdot.data()));
}

}  // namespace
