// Integrating on contact sets (eom/integration/contacts.hpp): Solo12 on a free base under a joint
// PD loop at 1 kHz (rk4, one step per period), its generated kernels (contact_solo12):
//   - held on its four feet for 10 s while the joints sway the body: every foot within 1e-9 of
//     where it stood (the figure); feet started 1 µm off their anchors pulled back by kp;
//   - dropped from 3 cm: the touchdown event fires at the free-fall time √(2h/g), the impulse
//     stops every foot (J v⁺ = 0) and balances momentum, and the feet then stay where they
//     touched;
//   - held on a diagonal pair (trot) until a third foot touches: the stance set takes over, the
//     pair keeping its anchors to the bit;
//   - on four feet while the joints pull FR and HL up: the liftoff event fires where FR's normal
//     force falls to 0 (a torque held), or lift() at a new u (a 1 kHz PD), and switches to the
//     trot pair, v untouched, FL and HR keeping their anchors;
//   - a trot cycle: FR and HL pulled up (lift() onto the trot pair), let down (touchdown onto the
//     stance set), then FL and HR onto trot_b: the pairs switch, the feet that stay down keep
//     their anchors, every held foot within 1e-9 of its anchor;
//   - bad parameters are refused (a set out of range: NaN and false; a liftoff watching a frame
//     outside its set: event_not_finite).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <span>

#include <contact_solo12.hpp>

#include <eom/integration/contacts.hpp>
#include <eom/integration/integrate.hpp>
#include <eom/model/free_joint.hpp>

namespace {

using K = contact_solo12::Kernels;
using C = eom::OnContacts<K>;
constexpr int nq = K::nq, nv = K::nv, nu = K::nu, joints = 12;
static_assert(nu == joints && nv == 6 + joints);
constexpr int stance = 0, trot = 1, trot_b = 4;  // tests/contacts/CMakeLists.txt: stance, trot (FL, HR),
                                                 // flat, all_flat, trot_b (FR, HL)
// Gains the 1 kHz sampled loop keeps stable in flight too (the legs alone are light: with
// 20 N·m/rad and 1 N·m·s/rad it diverges before touchdown).
constexpr double period = 1e-3, kp_joint = 5, kd_joint = 0.1;

// The standing posture: legs bent (front HFE 0.8, KFE −1.6; hind mirrored), level base, its
// height putting the untucked feet on z = height; `tuck` bends FR's and HL's knees (FL's and
// HR's with `tuck_fl_hr`) that much more (and their hips half of it), lifting those feet (the
// posture stays symmetric under a half turn about z).
std::array<double, nq> posture(double height, double tuck = 0, bool tuck_fl_hr = false) {
  std::array<double, nq> q{};
  q[3] = 1;  // qw
  for (int leg = 0; leg < 4; ++leg) {  // FL, FR, HL, HR
    const bool tucked = tuck_fl_hr ? leg == 0 || leg == 3 : leg == 1 || leg == 2;
    const double front = leg < 2 ? 1.0 : -1.0, bend = tucked ? tuck : 0.0;
    q[7 + 3 * leg + 1] = (0.8 + bend / 2) * front, q[7 + 3 * leg + 2] = -(1.6 + bend) * front;
  }
  double x[3], R[9];
  K::frame_placement(tuck_fl_hr ? 1 : 0, q.data(), K::parameter_values.data(), x, R);
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

// From four feet to the diagonal pair: Solo12 stands half a second under the PD, then its joints
// are pulled toward the tucked posture (FR and HL up); the ground cannot hold a foot down, so
// where FR's normal force falls to 0 the liftoff switches to the trot set, v as it was, FL and HR
// keeping their anchors to the bit. The switch comes inside an integration by the event, located
// where the force is 0 (a torque held), or at a new u by lift() (a sampled loop: a new u can take
// the force below 0 at once).
struct Liftoffs {
  std::array<double, nq> q0 = posture(0), tucked = posture(0, 0.3);
  static constexpr int fr = 1;
  eom::Touchdowns<C, 0, 1> gait{K::parameter_values, {.kd = 40, .kp = 400}, stance, {}, 0, q0.data(),
                                {{{.set = stance, .frame = fr, .to = trot}}}};
  const double* p = gait.parameters.data();
  std::array<double, C::anchor_size> fl = anchor(0), hr = anchor(3);
  eom::StateFor<C> x{};

  Liftoffs() {  // half a second on the PD toward the standing posture
    std::copy(q0.begin(), q0.end(), x.begin());
    for (int k = 0; k < 500; ++k) {
      const auto u = pd(x, q0, 0);
      x = eom::integrate<C>(k * period, (k + 1) * period, x, u.data(), p, rk4()).x;
    }
  }
  std::array<double, C::anchor_size> anchor(int f) const {
    std::array<double, C::anchor_size> a;
    std::copy_n(C::anchor(p, f), a.size(), a.begin());
    return a;
  }
  // FR's normal force from OnContacts' dynamics with parameters `at`.
  static double normal(double t, const double* q, const double* v, const double* u, const double* at) {
    std::array<double, nv> vdot;
    std::array<double, C::max_rows> lambda;
    EXPECT_TRUE(C::dynamics(t, q, v, u, at, vdot.data(), lambda.data()));
    return lambda[3 + 2];
  }
  void expect_switched() const {
    EXPECT_EQ(gait.set(), trot);
    EXPECT_EQ(gait.last_liftoff(), 0);
    EXPECT_EQ(anchor(0), fl);
    EXPECT_EQ(anchor(3), hr);
  }
};

TEST(ContactIntegration, LiftoffWhereTheNormalForceVanishes) {
  Liftoffs s;
  ASSERT_EQ(decltype(s.gait)::row_of(stance, s.fr), 3);
  ASSERT_EQ(decltype(s.gait)::row_of(trot, s.fr), -1);
  // A torque a fifth of the way to the tucked posture's, held from 0.5 s.
  const auto standing = pd(s.x, s.q0, 0), pulling = pd(s.x, s.tucked, 0);
  std::array<double, nu> u;
  for (int j = 0; j < nu; ++j) u[j] = 0.8 * standing[j] + 0.2 * pulling[j];
  const double at_start = Liftoffs::normal(0.5, s.x.data(), s.x.data() + nq, u.data(), s.p);
  ASSERT_GT(at_start, 0);  // pressed still
  const std::array<double, C::np> before = s.gait.parameters;
  std::array<eom::EventRecord<nq, nv>, 4> storage;
  eom::EventLog<nq, nv> log(storage);
  const auto r = eom::integrate<C>(0.5, 1.0, s.x, u.data(), s.p, rk4(), s.gait.events(), log);
  ASSERT_EQ(r.status, eom::Status::ok);
  ASSERT_EQ(log.records().size(), 1u) << "FR never lifted";
  const auto& e = log.records()[0];
  const double there = Liftoffs::normal(e.t, e.x.data(), e.x.data() + nq, u.data(), before.data());
  std::printf("Solo12 on four feet, a torque pulling FR and HL up held from 0.5 s: FR lifts off at "
              "%.6f s (its normal force %.3f N at 0.5 s, %.1e N there)\n", e.t, at_start, there);
  EXPECT_NEAR(there, 0, 1e-8);  // N: located to rounding in t
  // No impulse: q and v go on (the quaternion put back on the unit sphere after a reset).
  for (int i = 0; i < nq + nv; ++i)
    EXPECT_NEAR(e.x_after[i], e.x[i], 1e-15) << i;
  s.expect_switched();
}

TEST(ContactIntegration, LiftoffAtANewInputByLift) {
  Liftoffs s;
  // The PD's target ramped to the tucked posture over 0.2 s from 0.5 s, a new u every period.
  double lifted_at = -1, there = 0, before = 0;
  for (int k = 500; k < 1000 && s.gait.set() == stance; ++k) {
    const double t = k * period, ramp = std::min((t - 0.5) / 0.2, 1.0);
    std::array<double, nq> target = s.q0;
    for (int j = 7; j < nq; ++j) target[j] += ramp * (s.tucked[j] - s.q0[j]);
    const auto u = pd(s.x, target, 0);
    const double now = Liftoffs::normal(t, s.x.data(), s.x.data() + nq, u.data(), s.p);
    if (s.gait.lift(t, s.x.data(), s.x.data() + nq, u.data()) == 0) {
      lifted_at = t, there = now;
      break;
    }
    EXPECT_GT(now, 0) << "lift() left a pulling foot held at t = " << t;
    const auto r = eom::integrate<C>(t, t + period, s.x, u.data(), s.p, rk4());
    ASSERT_EQ(r.status, eom::Status::ok) << "at t = " << t;
    s.x = r.x, before = now;
  }
  std::printf("Solo12 on four feet, FR and HL pulled up by a 1 kHz PD: lift() switches at %.3f s (FR's "
              "normal force %.3f N a period before, %.3f N at the new u)\n", lifted_at, before, there);
  ASSERT_GT(lifted_at, 0.5) << "never lifted";
  EXPECT_LE(there, 0);
  EXPECT_EQ(s.gait.lift(lifted_at, s.x.data(), s.x.data() + nq, pd(s.x, s.tucked, 0).data()), -1);  // nothing left
  s.expect_switched();
}

// A trot cycle through both diagonal pairs on the 1 kHz PD: from four feet, FR and HL are pulled
// up (lift() switches to the trot pair FL, HR), held tucked, then let down until one of them
// touches (the touchdown's impulse and the stance set take over); then FL and HR the same way onto
// trot_b. Each switch keeps the anchors of the feet that stay down to the bit; the swinging pair
// leaves the floor (both feet above it before its touchdowns are watched); every held foot stays
// within 1e-9 of its anchor throughout.
TEST(ContactIntegration, TrotCycleSwitchesThePairs) {
  struct Pair {
    std::array<int, 2> feet;  // frames, also the legs (FL, FR, HL, HR)
    int holds;                // the set of the other pair, which holds while this one swings
    bool fl_hr;
  };
  const std::array<Pair, 2> pairs{{{{1, 2}, trot, false}, {{0, 3}, trot_b, true}}};
  const auto q0 = posture(0);
  // Touchdowns 2P, 2P + 1: pair P's feet closing the stance set; liftoff P: pair P leaving it.
  eom::Touchdowns<C, 4, 2> gait(K::parameter_values, {.kd = 40, .kp = 400}, stance,
                                {{{.set = stance, .frame = 1}, {.set = stance, .frame = 2},
                                  {.set = stance, .frame = 0}, {.set = stance, .frame = 3}}},
                                0, q0.data(), {{{.set = stance, .frame = 1, .to = trot},
                                                {.set = stance, .frame = 0, .to = trot_b}}});
  const double* p = gait.parameters.data();
  eom::StateFor<C> x{};
  std::copy(q0.begin(), q0.end(), x.begin());
  std::array<eom::EventRecord<nq, nv>, 4> storage;
  eom::EventLog<nq, nv> log(storage);
  long k = 0;
  double worst = 0, lowest_base = x[2];
  // One period on u, the events `watch` armed.
  const auto advance = [&](const std::array<double, nu>& u, std::span<const eom::Event> watch) {
    log.clear();
    const auto r = eom::integrate<C>(k * period, (k + 1) * period, x, u.data(), p, rk4(), watch, log);
    EXPECT_EQ(r.status, eom::Status::ok) << "at t = " << k * period;
    x = r.x, ++k;
    if (gait.set() >= 0) worst = std::max(worst, foot_drift(gait.set(), x.data(), p));
    lowest_base = std::min(lowest_base, x[2]);
    return r.status == eom::Status::ok;
  };
  const auto anchor = [&](int f) {
    std::array<double, C::anchor_size> a;
    std::copy_n(C::anchor(p, f), a.size(), a.begin());
    return a;
  };
  for (int P = 0; P < 2; ++P) {
    const auto tucked = posture(0, 0.3, pairs[P].fl_hr);
    const auto& down = pairs[1 - P].feet;  // the feet that stay down
    for (int i = 0; i < 300; ++i) ASSERT_TRUE(advance(pd(x, q0, 0), {}));  // on four feet
    const auto down0 = anchor(down[0]), down1 = anchor(down[1]);
    // Pulled up over 0.2 s, lift() at each new u.
    int lifted = -1;
    for (int i = 0; i < 600 && lifted < 0; ++i) {
      const double ramp = std::min(i / 200.0, 1.0);
      std::array<double, nq> target = q0;
      for (int j = 7; j < nq; ++j) target[j] += ramp * (tucked[j] - q0[j]);
      const auto u = pd(x, target, 0);
      lifted = gait.lift(k * period, x.data(), x.data() + nq, u.data());
      ASSERT_TRUE(advance(u, {}));
    }
    ASSERT_EQ(lifted, P) << "pair " << P << " never lifted";
    EXPECT_EQ(gait.set(), pairs[P].holds);
    EXPECT_EQ(anchor(down[0]), down0);
    EXPECT_EQ(anchor(down[1]), down1);
    // Held tucked for 0.1 s: both feet leave the floor (never below it while no touchdown is
    // watched) and end up more than a millimetre above it.
    double lowest_swing = 1;
    for (int i = 0; i < 100; ++i) {
      ASSERT_TRUE(advance(pd(x, tucked, 0), {}));
      for (int f : pairs[P].feet) lowest_swing = std::min(lowest_swing, foot_height(f, x.data()));
    }
    const double up = std::min(foot_height(pairs[P].feet[0], x.data()), foot_height(pairs[P].feet[1], x.data()));
    EXPECT_GE(lowest_swing, 0);
    EXPECT_GT(up, 1e-3);
    EXPECT_EQ(gait.set(), pairs[P].holds);
    // Let down over 0.2 s, its touchdowns watched, until one fires.
    for (int i = 0; i < 500 && gait.set() != stance; ++i) {
      const double ramp = std::min(i / 200.0, 1.0);
      std::array<double, nq> target = tucked;
      for (int j = 7; j < nq; ++j) target[j] += ramp * (q0[j] - tucked[j]);
      ASSERT_TRUE(advance(pd(x, target, 0), gait.events().subspan(2 * P, 2)));
    }
    ASSERT_EQ(gait.set(), stance) << "pair " << P << " never touched down";
    const auto& e = log.records()[0];
    const int first = pairs[P].feet[gait.last() - 2 * P], other = pairs[P].feet[1 - (gait.last() - 2 * P)];
    std::printf("pair %s: lifted (feet %.2f mm up after 0.1 s, never below %.1e m), %s touched down at %.4f s "
                "(%s %.3f mm up), impulse %.4f N s\n", P == 0 ? "FR, HL" : "FL, HR", 1e3 * up, lowest_swing,
                K::frame_names[first].data(), e.t, K::frame_names[other].data(), 1e3 * foot_height(other, e.x.data()),
                gait.impulse()[decltype(gait)::row_of(stance, first) + 2]);
    EXPECT_NEAR(foot_height(first, e.x.data()), 0, 1e-14);
    EXPECT_GE(foot_height(other, e.x.data()), 0);  // the first of the two fires
    EXPECT_EQ(anchor(down[0]), down0);
    EXPECT_EQ(anchor(down[1]), down1);
  }
  for (int i = 0; i < 300; ++i) ASSERT_TRUE(advance(pd(x, q0, 0), {}));
  std::printf("trot cycle: %.2f s, every held foot within %.2e m of its anchor, base at least %.4f m up "
              "(%.4f standing)\n", k * period, worst, lowest_base, q0[2]);
  EXPECT_LE(worst, 1e-9);
  EXPECT_GT(lowest_base, 0.75 * q0[2]);  // the legs give on two feet under this soft PD, and recover
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
  // A liftoff watching FR while the trot pair (FL, HR) holds: no such force, the integration stops.
  eom::Touchdowns<C, 0, 1> odd(K::parameter_values, {.kd = 40}, trot, {}, 0, q0.data(),
                               {{{.set = trot, .frame = 1, .to = -1}}});
  eom::StateFor<C> x{};
  std::copy(q0.begin(), q0.end(), x.begin());
  std::array<eom::EventRecord<nq, nv>, 1> storage;
  eom::EventLog<nq, nv> log(storage);
  const auto r = eom::integrate<C>(0, period, x, u.data(), odd.parameters.data(), rk4(), odd.events(), log);
  EXPECT_EQ(r.status, eom::Status::event_not_finite);
}

}  // namespace
