// eom::contact_rollout (eom/contact/rollout.hpp) on the planar runner (models/mjcf/runner.xml: a
// leg with four actuators dropped onto the floor): bitwise the results of contact_step run case by
// case by hand, on 1 thread and on several, with per-step, per-case and shared inputs; a case with
// a NaN state fails alone; bad input refused with a message naming the argument.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <mjcf_runner.hpp>
#include <mjcf_runner_model.hpp>

#include <eom/contact/rollout.hpp>

namespace {

using K = mjcf_runner::Kernels;
using Model = eom::mjcf_models::mjcf_runner;
constexpr int nq = K::nq, nv = K::nv, nu = K::nu;
constexpr std::size_t cases = 7;
constexpr long steps = 300;  // 0.3 s: the foot reaches the floor after about 0.1 s

// Random drops: the torso 4 to 10 cm above the height where the foot touches, tilted, moving;
// random inputs for every case and step.
struct Drops {
  std::vector<double> q0, v0, u;
  Drops() {
    std::mt19937_64 rng(49);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    for (std::size_t c = 0; c < cases; ++c) {
      const std::array<double, nq> q{0.1 * unit(rng), 0.97 + 0.03 * unit(rng), 0.1 * unit(rng),
                                     0.3 * unit(rng), 0.3 * unit(rng), 0.3 * unit(rng)};
      q0.insert(q0.end(), q.begin(), q.end());
      for (int i = 0; i < nv; ++i) v0.push_back(0.5 * unit(rng));
    }
    for (std::size_t i = 0; i < cases * steps * nu; ++i) u.push_back(unit(rng));
  }
  eom::RolloutCases rollout_cases() const { return {q0, v0, u, K::parameter_values}; }
};

// Case c run alone by contact_step with a stepper of its own; the contacts met on the way.
struct ByHand {
  std::vector<double> q, v, states;
  double t = 0;
  eom::StepStatus status = eom::StepStatus::ok;
  long taken = 0;
  int contacts = 0;
};
ByHand by_hand(const Drops& d, std::size_t c, const double* u_of_case, std::size_t u_stride) {
  ByHand h;
  auto stepper = std::make_unique<eom::ContactStepper<K, Model>>();
  std::array<double, nq> q;
  std::array<double, nv> v;
  std::copy_n(d.q0.data() + c * nq, nq, q.begin());
  std::copy_n(d.v0.data() + c * nv, nv, v.begin());
  const auto keep = [&] {
    h.states.insert(h.states.end(), q.begin(), q.end());
    h.states.insert(h.states.end(), v.begin(), v.end());
  };
  keep();
  for (long k = 0; k < steps; ++k) {
    h.status = eom::contact_step<K, Model>(*stepper, h.t, q, v, u_of_case + k * u_stride,
                                           K::parameter_values.data());
    if (h.status != eom::StepStatus::ok) break;
    h.contacts += stepper->rows.ncontacts;
    ++h.taken;
    keep();
  }
  h.q.assign(q.begin(), q.end());
  h.v.assign(v.begin(), v.end());
  return h;
}

bool same_bits(std::span<const double> a, std::span<const double> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

// Everything of r bitwise equal to the hand loops (states recorded in r).
void expect_as_by_hand(const eom::RolloutResult& r, const std::vector<ByHand>& hand, const char* what) {
  ASSERT_TRUE(r.ok()) << r.error;
  ASSERT_EQ(r.cases.size(), hand.size());
  for (std::size_t c = 0; c < hand.size(); ++c) {
    SCOPED_TRACE(std::string(what) + ", case " + std::to_string(c));
    EXPECT_EQ(r.cases[c].status, hand[c].status);
    EXPECT_EQ(r.cases[c].steps, hand[c].taken);
    EXPECT_EQ(std::memcmp(&r.cases[c].t, &hand[c].t, sizeof(double)), 0);
    EXPECT_TRUE(same_bits(r.final_q(c), hand[c].q));
    EXPECT_TRUE(same_bits(r.final_v(c), hand[c].v));
    for (long k = 0; k <= hand[c].taken; ++k)
      ASSERT_TRUE(same_bits(r.state(c, k), std::span(hand[c].states).subspan(k * (nq + nv), nq + nv)))
          << "step " << k;
  }
}

TEST(contact_rollout, BitwiseAsContactStepByHandForAnyThreadCount) {
  const Drops d;
  std::vector<ByHand> hand;
  int contacts = 0;
  for (std::size_t c = 0; c < cases; ++c) {
    hand.push_back(by_hand(d, c, d.u.data() + c * steps * nu, nu));
    ASSERT_EQ(hand.back().status, eom::StepStatus::ok) << c;
    contacts += hand.back().contacts;
  }
  EXPECT_GT(contacts, 100 * static_cast<int>(cases));  // every case lands and stays in contact
  for (unsigned threads : {1u, 2u, 3u, 0u}) {
    const auto r = eom::contact_rollout<K, Model>(d.rollout_cases(),
                                                  {.steps = steps, .threads = threads, .record = true});
    expect_as_by_hand(r, hand, ("threads " + std::to_string(threads)).c_str());
  }
  // Without record, the same final states.
  const auto quiet = eom::contact_rollout<K, Model>(d.rollout_cases(), {.steps = steps, .threads = 2});
  ASSERT_TRUE(quiet.ok()) << quiet.error;
  EXPECT_TRUE(quiet.states.empty());
  for (std::size_t c = 0; c < cases; ++c) EXPECT_TRUE(same_bits(quiet.final_v(c), hand[c].v)) << c;
  std::printf("contact_rollout: %zu runner drops of %ld steps (%d contacts on the way) bitwise as "
              "contact_step by hand on 1, 2, 3 and all threads\n",
              cases, steps, contacts);
}

TEST(contact_rollout, HeldInputsPerCaseAndShared) {
  const Drops d;
  std::vector<double> per_case(d.u.begin(), d.u.begin() + cases * nu);
  std::vector<ByHand> hand_per_case, hand_shared;
  for (std::size_t c = 0; c < cases; ++c) {
    hand_per_case.push_back(by_hand(d, c, per_case.data() + c * nu, 0));
    hand_shared.push_back(by_hand(d, c, per_case.data(), 0));
  }
  auto held = d.rollout_cases();
  held.u = per_case;
  expect_as_by_hand(eom::contact_rollout<K, Model>(held, {.steps = steps, .threads = 2, .record = true}),
                    hand_per_case, "one row per case");
  held.u = std::span(per_case).first(nu);
  expect_as_by_hand(eom::contact_rollout<K, Model>(held, {.steps = steps, .threads = 2, .record = true}),
                    hand_shared, "one row shared");
  EXPECT_FALSE(same_bits(hand_per_case[1].v, hand_shared[1].v));  // the inputs do reach the step
}

TEST(contact_rollout, ANaNStateFailsItsCaseAlone) {
  const Drops d;
  Drops bad = d;
  bad.q0[2 * nq + 1] = std::numeric_limits<double>::quiet_NaN();  // case 2's height
  const auto good = eom::contact_rollout<K, Model>(d.rollout_cases(), {.steps = steps, .threads = 2});
  const auto r = eom::contact_rollout<K, Model>(bad.rollout_cases(), {.steps = steps, .threads = 2, .record = true});
  ASSERT_TRUE(r.ok()) << r.error;  // the ensemble runs; its case fails
  EXPECT_NE(r.cases[2].status, eom::StepStatus::ok);
  std::printf("a NaN height: the case stops with status %d at step %ld\n",
              static_cast<int>(r.cases[2].status), r.cases[2].steps);
  EXPECT_EQ(r.cases[2].steps, 0);  // at its first step
  EXPECT_EQ(r.cases[2].t, 0.0);
  EXPECT_TRUE(std::isnan(r.final_q(2)[1]));  // its state as it was
  EXPECT_TRUE(same_bits(r.final_v(2), std::span(bad.v0).subspan(2 * nv, nv)));
  EXPECT_TRUE(std::isnan(r.state(2, 1)[0]));  // nothing recorded past the failure
  EXPECT_EQ(r.failed(), 1u);
  for (std::size_t c = 0; c < cases; ++c) {
    if (c == 2) continue;
    EXPECT_EQ(r.cases[c].status, eom::StepStatus::ok) << c;
    EXPECT_EQ(r.cases[c].steps, steps) << c;
    EXPECT_TRUE(same_bits(r.final_q(c), good.final_q(c))) << c;
    EXPECT_TRUE(same_bits(r.final_v(c), good.final_v(c))) << c;
  }
}

// The message of a refused rollout: it names the argument; nothing is run.
std::string refused(const eom::RolloutCases& cases, long steps = 10) {
  const auto r = eom::contact_rollout<K, Model>(cases, {.steps = steps, .threads = 2});
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(r.cases.empty());
  return r.error;
}

TEST(contact_rollout, BadInputIsRefusedWithWhy) {
  const Drops d;
  const auto ok = d.rollout_cases();
  using ::testing::HasSubstr;
  auto c = ok;
  c.q0 = {}, c.v0 = {}, c.u = {};
  EXPECT_THAT(refused(c), HasSubstr("no cases"));
  c = ok;
  c.q0 = std::span(d.q0).first(2 * nq + 1);
  EXPECT_THAT(refused(c), HasSubstr("q0 has 13 values, not a multiple of nq = 6"));
  c = ok;
  c.v0 = std::span(d.v0).first(nv);
  EXPECT_THAT(refused(c), HasSubstr("v0 has 6 values; 7 cases (q0) need N·nv = 42"));
  c = ok;
  c.u = std::span(d.u).first(5);
  EXPECT_THAT(refused(c), HasSubstr("u has 5 values; expected nu = 4 (held by all cases), N·nu = 28 "
                                    "(one held per case) or N·steps·nu = 280 (per case and step)"));
  c = ok;
  c.u = {};
  EXPECT_THAT(refused(c), HasSubstr("u has 0 values"));
  c = ok;
  c.p = {};
  EXPECT_THAT(refused(c, steps), HasSubstr("p has 0 values; expected np = 1 (shared) or N·np = 7"));
  EXPECT_THAT(refused(ok, -1), HasSubstr("steps must be >= 0, given -1"));
  // Zero steps: the initial states back.
  c = ok;
  c.u = std::span(d.u).first(nu);
  const auto none = eom::contact_rollout<K, Model>(c, {.steps = 0, .record = true});
  ASSERT_TRUE(none.ok()) << none.error;
  EXPECT_TRUE(same_bits(none.q, d.q0));
  EXPECT_TRUE(same_bits(none.state(3, 0).first(nq), std::span(d.q0).subspan(3 * nq, nq)));
}

}  // namespace
