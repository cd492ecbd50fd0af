// Events in eom::integrate (eom/integration/events.hpp), every method, against closed forms: the impacts of a
// bouncing ball, the zero crossings of a pendulum (its period from the complete elliptic integral
// of the first kind), two crossings inside one Taylor step; initial-time, simultaneous and
// failing events; chattering. And every state the integrator hands out with projection — dense
// output, event states — on the constraints.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <vector>

#include <boost/math/special_functions/ellint_1.hpp>

#include <eom/integration/integrate.hpp>
#include <eom/reference/reference.hpp>

#include <models/cartesian_pendulum.hpp>
#include <models/chain.hpp>

#include "models.hpp"

namespace {

using Ball = eom::Reference<eom_events::Ball>;
using Pendulum = eom::Reference<eom_events::Pendulum>;
using eom::Method;

constexpr std::array all_methods{Method::rk4,    Method::dopri5,       Method::dop853,
                                 Method::radau5, Method::taylor,       Method::taylor_paper,
                                 Method::variational};

// Options for a method at (near) its best: tight tolerances, small fixed steps.
eom::IntegrationOptions tight(Method m) {
  eom::IntegrationOptions opt;
  opt.method = m;
  opt.rtol = opt.atol = m == Method::taylor || m == Method::taylor_paper ? 1e-15
                       : m == Method::radau5                                ? 1e-14
                                                                            : 1e-13;
  opt.step = m == Method::rk4 ? 5e-4 : m == Method::variational ? 1e-4 : 0;
  return opt;
}

// ---- the bouncing ball -------------------------------------------------------------------------

constexpr double restitution = 0.8, y0 = 1.2;

// y = 0 falling: the impact; the velocity flips and shrinks by e.
auto floor_height = [](double, const double* q, const double*) { return q[0]; };
auto bounce = [](double, double*, double* qd) {
  qd[0] *= -restitution;
  return true;
};

// Impact k (0-based) of the ball dropped from y0 at rest: t₀ = √(2y₀/g), v₀ = g t₀, and the
// flight between impacts k−1 and k lasts 2 eᵏ v₀ / g.
double impact_time(int k) {
  const double g = eom_events::Ball::parameter_values[1], t0 = std::sqrt(2 * y0 / g), v0 = g * t0;
  double t = t0;
  for (int j = 1; j <= k; ++j) t += 2 * std::pow(restitution, j) * v0 / g;
  return t;
}

TEST(Events, BouncingBallImpactsMatchTheClosedFormForEveryMethod) {
  const auto p = Ball::parameter_values;
  const eom::StateOf<1> x0{y0, 0};
  const eom::Event events[]{{.g = floor_height, .direction = eom::EventDirection::falling,
                             .action = eom::EventAction::reset, .reset = bounce}};
  const int impacts = 8;
  const double t1 = 0.5 * (impact_time(impacts - 1) + impact_time(impacts));
  const double v0 = p[1] * impact_time(0);
  for (Method m : all_methods) {
    SCOPED_TRACE(eom::to_string(m));
    auto opt = tight(m);
    if (eom::is_fixed_step(m)) opt.step = 0.01;
    std::array<eom::EventRecord<1>, 32> storage;
    eom::EventLog<1> log(storage);
    const auto r = eom::integrate<Ball>(0, t1, x0, nullptr, p.data(), opt, events, log);
    ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status);
    ASSERT_EQ(log.size(), static_cast<std::size_t>(impacts));
    double worst_t = 0, worst_y = 0, worst_v = 0;
    for (int k = 0; k < impacts; ++k) {
      const auto& e = log.records()[k];
      EXPECT_EQ(e.index, 0);
      worst_t = std::max(worst_t, std::abs(e.t - impact_time(k)));
      worst_y = std::max(worst_y, std::abs(e.x[0]));
      const double v = v0 * std::pow(restitution, k);  // speed at impact k
      worst_v = std::max({worst_v, std::abs(e.x[1] + v) / v0, std::abs(e.x_after[1] - restitution * v) / v0});
    }
    std::printf("  %-12s impacts: max |t - closed form| %.1e s, |y| %.1e m, velocity %.1e (rel.)\n",
                eom::to_string(m), worst_t, worst_y, worst_v);
    EXPECT_LE(worst_t, 1e-12);
    EXPECT_LE(worst_y, 1e-12);
    EXPECT_LE(worst_v, 1e-12);
    EXPECT_EQ(r.t, t1);
  }
}

// e < 1: the impacts accumulate at t∞ (Zeno). The reset rate passes any bound before t∞: the
// integration stops there with Status::event_chattering, naming the event, instead of hanging.
TEST(Events, ZenoBounceIsReportedAsChattering) {
  const auto p = Ball::parameter_values;
  const eom::StateOf<1> x0{y0, 0};
  const eom::Event events[]{{.g = floor_height, .direction = eom::EventDirection::falling,
                             .action = eom::EventAction::reset, .reset = bounce}};
  const double g = p[1], t0 = std::sqrt(2 * y0 / g), v0 = g * t0;
  const double t_zeno = t0 + 2 * restitution * v0 / (g * (1 - restitution));
  for (Method m : all_methods) {
    SCOPED_TRACE(eom::to_string(m));
    auto opt = tight(m);
    if (eom::is_fixed_step(m)) opt.step = 0.01;
    opt.event_settings.max_reset_rate = 1e3;
    eom::EventLog<1> log;  // no storage: every event dropped, still acted on
    const auto r = eom::integrate<Ball>(0, 10, x0, nullptr, p.data(), opt, events, log);
    EXPECT_EQ(r.status, eom::Status::event_chattering) << eom::to_string(r.status);
    EXPECT_EQ(r.event, 0);
    EXPECT_LT(r.t, t_zeno);
    EXPECT_GT(r.t, t_zeno - 0.05);
    EXPECT_EQ(log.size(), 0u);
    EXPECT_GT(log.dropped(), 10u);
    std::printf("  %-12s chattering reported at t = %.6f (t_zeno = %.6f) after %zu resets\n",
                eom::to_string(m), r.t, t_zeno, log.dropped());
  }
}

// ---- the pendulum ------------------------------------------------------------------------------

constexpr double amplitude = 1.0;

double omega() {
  const auto p = Pendulum::parameter_values;
  return std::sqrt(p[2] / p[1]);
}
// The period at amplitude A: T = 4 K(sin(A/2)) / ω.
double period() { return 4 * boost::math::ellint_1(std::sin(amplitude / 2)) / omega(); }

auto angle = [](double, const double* q, const double*) { return q[0]; };

TEST(Events, PendulumZeroCrossingsGiveThePeriodForEveryMethod) {
  const auto p = Pendulum::parameter_values;
  const eom::StateOf<1> x0{amplitude, 0};  // released at rest: crossings at T/4 + k T/2
  const double T = period();
  const eom::Event events[]{{.g = angle}};  // both directions, record
  for (Method m : all_methods) {
    SCOPED_TRACE(eom::to_string(m));
    const auto opt = tight(m);
    std::array<eom::EventRecord<1>, 16> storage;
    eom::EventLog<1> log(storage);
    const auto r = eom::integrate<Pendulum>(0, 2.2 * T, x0, nullptr, p.data(), opt, events, log);
    ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status);
    ASSERT_EQ(log.size(), 4u);
    double worst = 0;
    for (int k = 0; k < 4; ++k) {
      const auto& e = log.records()[k];
      worst = std::max(worst, std::abs(e.t - (0.25 + 0.5 * k) * T) / T);
      EXPECT_EQ(e.x[1] < 0, k % 2 == 0);  // falling first
    }
    const auto rec = log.records();
    const double measured = rec[2].t - rec[0].t;  // one full period between like crossings
    std::printf("  %-12s crossings: max |t - closed form| / T %.1e, period rel. error %.1e, %ld steps\n",
                eom::to_string(m), worst, std::abs(measured - T) / T, r.accepted);
    // The 2nd-order variational method at h = 0.1 ms: (hω)² ≈ 1.4e-7.
    const double bound = m == Method::variational ? 1e-6 : 1e-12;
    EXPECT_LE(worst, bound);
    EXPECT_LE(std::abs(measured - T) / T, bound);
  }
}

// θ = a just below the amplitude: two crossings, ~0.05 s apart around the turning point, inside
// one Taylor step (~0.1 s); both are found, at the times sin(θ/2) = k sn(ωt, k) gives.
TEST(Events, TwoCrossingsInsideOneTaylorStep) {
  const auto p = Pendulum::parameter_values;
  const double k = std::sin(amplitude / 2), w = omega();
  const eom::StateOf<1> x0{0, 2 * k * w};  // from the bottom: θ(t) reaches A at K(k)/ω
  const double level = amplitude - 0.002;
  auto above = [&](double, const double* q, const double*) { return q[0] - level; };
  const eom::Event events[]{{.g = above}};
  // Rising: ωt = F(φ, k), sin φ = sin(a/2)/k; falling: symmetric about the turning point.
  const double phi = std::asin(std::sin(level / 2) / k);
  const double rising = boost::math::ellint_1(k, phi) / w;
  const double falling = 2 * boost::math::ellint_1(k) / w - rising;
  eom::IntegrationOptions opt;
  opt.method = Method::taylor;
  opt.rtol = opt.atol = 1e-15;
  std::array<eom::EventRecord<1>, 8> storage;
  eom::EventLog<1> log(storage);
  std::vector<double> step_ends;
  const auto r = eom::integrate<Pendulum>(0, 0.8, x0, nullptr, p.data(), opt, events, log,
                                          [&](double t, const auto&) { step_ends.push_back(t); });
  ASSERT_EQ(r.status, eom::Status::ok);
  ASSERT_EQ(log.size(), 2u);
  const double a = log.records()[0].t, b = log.records()[1].t;
  // The same step holds both.
  const auto after_a = std::upper_bound(step_ends.begin(), step_ends.end(), a);
  ASSERT_NE(after_a, step_ends.end());
  ASSERT_NE(after_a, step_ends.begin());
  EXPECT_GT(*after_a, b) << "the two crossings fell into different steps: the test proves nothing";
  std::printf("  crossings %.15f %.15f (%.3f s apart) in the step [%.4f, %.4f]; errors %.1e %.1e\n",
              a, b, b - a, *(after_a - 1), *after_a, a - rising, b - falling);
  EXPECT_NEAR(a, rising, 1e-12);
  EXPECT_NEAR(b, falling, 1e-12);
  // With a single sample per step (its ends only) the pair is invisible: why steps are sampled.
  opt.event_settings.samples = 1;
  eom::EventLog<1> blind(storage);
  ASSERT_EQ(eom::integrate<Pendulum>(0, 0.8, x0, nullptr, p.data(), opt, events, blind).status,
            eom::Status::ok);
  EXPECT_EQ(blind.size(), 0u);
}

TEST(Events, TerminatingEventEndsTheIntegrationThere) {
  const auto p = Pendulum::parameter_values;
  const eom::StateOf<1> x0{amplitude, 0};
  const double T = period();
  const eom::Event events[]{{.g = angle, .direction = eom::EventDirection::rising},
                            {.g = angle, .direction = eom::EventDirection::falling,
                             .action = eom::EventAction::terminate}};
  for (Method m : all_methods) {
    SCOPED_TRACE(eom::to_string(m));
    const auto opt = tight(m);
    std::array<eom::EventRecord<1>, 4> storage;
    eom::EventLog<1> log(storage);
    double last_t = -1;
    eom::StateOf<1> last_x{};
    const auto r = eom::integrate<Pendulum>(0, 10, x0, nullptr, p.data(), opt, events, log,
                                            [&](double t, const auto& x) { last_t = t, last_x = x; });
    ASSERT_EQ(r.status, eom::Status::ok);
    EXPECT_EQ(r.event, 1);
    EXPECT_NEAR(r.t, T / 4, m == Method::variational ? 1e-6 : 1e-12);
    EXPECT_EQ(last_t, r.t);  // the observer's last call is the event
    EXPECT_EQ(last_x, r.x);
    ASSERT_EQ(log.size(), 1u);
    EXPECT_EQ(log.records()[0].t, r.t);
  }
}

// g(t0) = 0 is no event; it fires when g returns to 0 having taken a sign.
TEST(Events, AnEventFunctionThatVanishesAtTheStartDoesNotFireThere) {
  const auto p = Pendulum::parameter_values;
  const double k = std::sin(amplitude / 2), w = omega();
  const eom::StateOf<1> x0{0, 2 * k * w};
  const eom::Event events[]{{.g = angle}};
  std::array<eom::EventRecord<1>, 4> storage;
  eom::EventLog<1> log(storage);
  const auto r = eom::integrate<Pendulum>(0, 0.75 * period(), x0, nullptr, p.data(),
                                          tight(Method::dop853), events, log);
  ASSERT_EQ(r.status, eom::Status::ok);
  ASSERT_EQ(log.size(), 1u);
  EXPECT_NEAR(log.records()[0].t, period() / 2, 1e-12);
}

// Events at the same instant all fire there, in index order; a terminating one wins over a
// reset, and the state it returns is the one before any reset.
TEST(Events, SimultaneousEventsFireTogetherInIndexOrder) {
  const auto p = Pendulum::parameter_values;
  const eom::StateOf<1> x0{amplitude, 0};
  auto twice = [](double, const double* q, const double*) { return 2 * q[0]; };
  auto lift = [](double, double* q, double* qd) {  // to rest at 0.5 rad
    q[0] = 0.5;
    qd[0] = 0;
    return true;
  };
  const eom::Event together[]{{.g = twice}, {.g = angle, .action = eom::EventAction::reset, .reset = lift},
                              {.g = angle, .direction = eom::EventDirection::rising}};
  std::array<eom::EventRecord<1>, 8> storage;
  eom::EventLog<1> log(storage);
  const auto r = eom::integrate<Pendulum>(0, 0.6, x0, nullptr, p.data(), tight(Method::dopri5),
                                          together, log);
  ASSERT_EQ(r.status, eom::Status::ok);
  // At T/4 events 0 and 1 (falling) fire together, 2 (rising) does not; the reset lifts the
  // pendulum to 0.5 rad at rest, from where it does not reach the bottom before t = 0.6.
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log.records()[0].index, 0);
  EXPECT_EQ(log.records()[1].index, 1);
  EXPECT_EQ(log.records()[0].t, log.records()[1].t);
  EXPECT_NEAR(log.records()[0].t, period() / 4, 1e-12);
  // x_after: the state after all actions of the instant, for every event there.
  EXPECT_EQ(log.records()[0].x_after, (eom::StateOf<1>{0.5, 0.0}));
  EXPECT_EQ(log.records()[1].x_after, (eom::StateOf<1>{0.5, 0.0}));
  EXPECT_GT(r.x[0], 0);
  EXPECT_LT(r.x[0], 0.5);

  const eom::Event stop_first[]{{.g = angle, .action = eom::EventAction::reset, .reset = lift},
                                {.g = twice, .action = eom::EventAction::terminate}};
  eom::EventLog<1> log2(storage);
  const auto s = eom::integrate<Pendulum>(0, 1.0, x0, nullptr, p.data(), tight(Method::dopri5),
                                          stop_first, log2);
  ASSERT_EQ(s.status, eom::Status::ok);
  EXPECT_EQ(s.event, 1);
  ASSERT_EQ(log2.size(), 2u);
  EXPECT_LT(s.x[1], -1.0);  // the swing's speed: no reset applied
  EXPECT_EQ(log2.records()[0].x_after, log2.records()[0].x);
}

TEST(Events, NonFiniteEventsAndResetsAreReportedWithEventAndTime) {
  const auto p = Pendulum::parameter_values;
  const eom::StateOf<1> x0{amplitude, 0};
  auto breaks = [](double t, const double* q, const double*) {
    return t > 0.3 ? std::numeric_limits<double>::quiet_NaN() : q[0] + 5;
  };
  auto bad_reset = [](double, double*, double* qd) {
    qd[0] = std::numeric_limits<double>::infinity();
    return true;
  };
  auto refusing_reset = [](double, double*, double*) { return false; };
  for (Method m : all_methods) {
    SCOPED_TRACE(eom::to_string(m));
    const auto opt = tight(m);
    eom::EventLog<1> log;
    const eom::Event nan_event[]{{.g = angle}, {.g = breaks}};
    const auto r = eom::integrate<Pendulum>(0, 2, x0, nullptr, p.data(), opt, nan_event, log);
    EXPECT_EQ(r.status, eom::Status::event_not_finite);
    EXPECT_EQ(r.event, 1);
    EXPECT_GT(r.t, 0.3);
    EXPECT_LT(r.t, 0.6);
    for (auto reset : {eom::ResetMap(bad_reset), eom::ResetMap(refusing_reset)}) {
      const eom::Event resetting[]{{.g = angle, .action = eom::EventAction::reset, .reset = reset}};
      const auto s = eom::integrate<Pendulum>(0, 2, x0, nullptr, p.data(), opt, resetting, log);
      EXPECT_EQ(s.status, eom::Status::event_reset_failed);
      EXPECT_EQ(s.event, 0);
      EXPECT_NEAR(s.t, period() / 4, 1e-6);
      EXPECT_TRUE(std::isfinite(s.x[1]));  // the state before the reset
    }
  }
}

TEST(Events, BadEventsAreRefusedBeforeAnyStep) {
  const auto p = Pendulum::parameter_values;
  const eom::StateOf<1> x0{amplitude, 0};
  eom::EventLog<1> log;
  const eom::Event no_function[]{eom::Event{}};
  const eom::Event no_reset[]{{.g = angle, .action = eom::EventAction::reset}};
  eom::IntegrationOptions opt;
  for (auto events : {std::span<const eom::Event>(no_function), std::span<const eom::Event>(no_reset)}) {
    const auto r = eom::integrate<Pendulum>(0, 1, x0, nullptr, p.data(), opt, events, log);
    EXPECT_EQ(r.status, eom::Status::invalid_argument);
    EXPECT_EQ(r.evaluations, 0);
  }
  const eom::Event fine[]{{.g = angle}};
  opt.event_settings.samples = 0;
  EXPECT_EQ(eom::integrate<Pendulum>(0, 1, x0, nullptr, p.data(), opt, fine, log).status,
            eom::Status::invalid_argument);
}

// The log keeps at most its storage's size; events beyond it still act and are counted.
TEST(Events, TheLogKeepsItsStatedMaximum) {
  const auto p = Pendulum::parameter_values;
  const eom::StateOf<1> x0{amplitude, 0};
  const eom::Event events[]{{.g = angle}};
  std::array<eom::EventRecord<1>, 2> storage;
  eom::EventLog<1> log(storage);
  const auto r = eom::integrate<Pendulum>(0, 2.2 * period(), x0, nullptr, p.data(), {}, events, log);
  ASSERT_EQ(r.status, eom::Status::ok);
  EXPECT_EQ(log.size(), 2u);
  EXPECT_EQ(log.dropped(), 2u);
}

// Output times with events: exactly the requested ones up to a terminating event; the ones at
// or after a reset see the reset state.
TEST(Events, OutputTimesAroundEvents) {
  const auto p = Ball::parameter_values;
  const eom::StateOf<1> x0{y0, 0};
  const eom::Event events[]{{.g = floor_height, .direction = eom::EventDirection::falling,
                             .action = eom::EventAction::reset, .reset = bounce}};
  const double t_hit = impact_time(0), g = p[1], v0 = g * t_hit;
  std::vector<double> times;
  for (int i = 0; i <= 40; ++i) times.push_back(0.05 * i);
  for (Method m : all_methods) {
    SCOPED_TRACE(eom::to_string(m));
    auto opt = tight(m);
    if (eom::is_fixed_step(m)) opt.step = 0.01;
    opt.output_times = times;
    std::vector<double> seen;
    double worst = 0;
    eom::EventLog<1> log;
    const auto r = eom::integrate<Ball>(0, 2, x0, nullptr, p.data(), opt, events, log,
                                        [&](double t, const eom::StateOf<1>& x) {
                                          seen.push_back(t);
                                          // Closed form up to the second impact.
                                          if (t >= impact_time(1)) return;
                                          const double y = t < t_hit ? y0 - 0.5 * g * t * t
                                                                     : restitution * v0 * (t - t_hit) -
                                                                           0.5 * g * (t - t_hit) * (t - t_hit);
                                          worst = std::max(worst, std::abs(x[0] - y));
                                        });
    ASSERT_EQ(r.status, eom::Status::ok);
    EXPECT_EQ(seen, times);
    EXPECT_LT(worst, 1e-12);
  }
}

// ---- constrained models: every state handed out lies on the constraints ----------------------

template <class K, int n>
void expect_on_constraints(const char* name, const eom::StateOf<n>& x0, double t1, double bound) {
  const auto p = K::parameter_values;
  std::vector<double> times;
  for (int i = 0; i <= 997; ++i) times.push_back(t1 * i / 997.0);  // not step ends
  for (Method m : all_methods) {
    SCOPED_TRACE(eom::to_string(m));
    eom::IntegrationOptions opt;
    opt.method = m;
    opt.rtol = opt.atol = 1e-10;
    opt.step = m == Method::variational ? 2e-3 : m == Method::rk4 ? 5e-3 : 0;
    if (m != Method::variational) opt.stabilization.method = eom::Stabilization::Method::projection;
    opt.output_times = times;
    double worst_p = 0, worst_v = 0;
    long calls = 0;
    auto check = [&](double, const eom::StateOf<n>& x) {
      const auto res = eom::constraint_residuals<K>(x.data(), x.data() + n, p.data());
      worst_p = std::max(worst_p, res[0]);
      worst_v = std::max(worst_v, res[1]);
      ++calls;
    };
    const auto r = eom::integrate<K>(0, t1, x0, nullptr, p.data(), opt, check);
    ASSERT_EQ(r.status, eom::Status::ok) << eom::to_string(r.status);
    EXPECT_EQ(calls, static_cast<long>(times.size()));
    // Events on the same run: the located states too.
    auto first_coordinate = [](double, const double* q, const double*) { return q[0]; };
    const eom::Event events[]{{.g = first_coordinate}};
    std::array<eom::EventRecord<n>, 64> storage;
    eom::EventLog<n> log(storage);
    opt.output_times = {};
    const auto s = eom::integrate<K>(0, t1, x0, nullptr, p.data(), opt, events, log, check);
    ASSERT_EQ(s.status, eom::Status::ok) << eom::to_string(s.status);
    for (const auto& e : log.records()) check(e.t, e.x);
    std::printf("  %-16s %-12s max |φ| %.1e, max |C q̇| %.1e over %zu outputs and %zu events\n", name,
                eom::to_string(m), worst_p, worst_v, times.size(), log.size());
    EXPECT_LE(worst_p, bound);
    EXPECT_LE(worst_v, bound);
  }
}

TEST(ProjectedOutput, CartesianPendulumOutputsAndEventsLieOnTheConstraint) {
  using CP = eom::Reference<eom::models::CartesianPendulum>;
  const double l = CP::parameter_values[1];
  const eom::StateOf<2> x0{l * std::sin(0.3), -l * std::cos(0.3), 2.5 * std::cos(0.3), 2.5 * std::sin(0.3)};
  expect_on_constraints<CP, 2>("cartesian", x0, 3.0, 1e-12);
}

TEST(ProjectedOutput, ClosedChainOutputsAndEventsLieOnTheConstraints) {
  using CC = eom::Reference<eom::models::ClosedChain5>;
  eom::StateOf<5> x0{};
  for (int i = 0; i < 5; ++i) x0[i] = eom::models::ClosedChain5::initial_q[i];
  expect_on_constraints<CC, 5>("closed_chain5", x0, 1.0, 1e-12);
}

}  // namespace
