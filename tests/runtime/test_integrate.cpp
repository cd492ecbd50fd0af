// The one integration API (eom/integration/integrate.hpp): it dispatches to each method with the same
// result as the method's own function, adds dense output to the fixed-step methods at their
// order, refuses bad input before any step, and says when a method's kernels are missing.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <eom/integration/integrate.hpp>
#include <eom/reference/reference.hpp>

#include <models/cartesian_pendulum.hpp>
#include <models/spring_pendulum.hpp>

namespace {

using SP = eom::Reference<eom::models::SpringPendulum>;
constexpr eom::StateOf<2> x0{0.55, 0.0, 0.01, 2.5};
const auto p = SP::parameter_values;
auto none = [](double, const auto&) {};

// Only what eom::Dynamics asks for: no mass matrix, so no variational integrator.
struct DynamicsOnly {
  static constexpr int nq = SP::nq, np = SP::np, nu = SP::nu, nc = SP::nc;
  static bool forward_dynamics(double t, const double* q, const double* qd, const double* u,
                               const double* p, double* qdd) noexcept {
    return SP::forward_dynamics(t, q, qd, u, p, qdd);
  }
  static double kinetic_energy(const double* q, const double* qd, const double* p) noexcept {
    return SP::kinetic_energy(q, qd, p);
  }
  static double potential_energy(const double* q, const double* p) noexcept {
    return SP::potential_energy(q, p);
  }
};

TEST(Integrate, DispatchesToEachMethodWithItsOwnResult) {
  eom::IntegrationOptions opt;
  opt.method = eom::Method::rk4;
  opt.step = 0.01;
  const auto a = eom::integrate<SP>(0, 1, x0, nullptr, p.data(), opt);
  const auto b = eom::rk4<SP>(0, 1, 100, x0, nullptr, p.data(), none);
  ASSERT_EQ(a.status, eom::Status::ok);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.accepted, 100);
  EXPECT_EQ(a.evaluations, 400);

  opt.method = eom::Method::dopri5;
  opt.step = 0;
  opt.rtol = opt.atol = 1e-9;
  const auto c = eom::integrate<SP>(0, 1, x0, nullptr, p.data(), opt);
  eom::AdaptiveOptions ad;
  ad.rtol = ad.atol = 1e-9;
  const auto d = eom::dopri5<SP>(0, 1, x0, nullptr, p.data(), ad, none);
  ASSERT_EQ(c.status, eom::Status::ok);
  EXPECT_EQ(c.x, d.x);
  EXPECT_EQ(c.accepted, d.accepted);
  EXPECT_EQ(c.evaluations, d.evaluations);

  opt.method = eom::Method::dop853;
  const auto g = eom::integrate<SP>(0, 1, x0, nullptr, p.data(), opt);
  const auto h = eom::dop853<SP>(0, 1, x0, nullptr, p.data(), ad, none);
  ASSERT_EQ(g.status, eom::Status::ok);
  EXPECT_EQ(g.x, h.x);
  EXPECT_EQ(g.evaluations, h.evaluations);

  opt.method = eom::Method::radau5;
  const auto i = eom::integrate<SP>(0, 1, x0, nullptr, p.data(), opt);
  const auto j = eom::radau5<SP>(0, 1, x0, nullptr, p.data(), ad, none);
  ASSERT_EQ(i.status, eom::Status::ok);
  EXPECT_EQ(i.x, j.x);
  EXPECT_EQ(i.evaluations, j.evaluations);

  for (auto [method, scheme] : {std::pair{eom::Method::taylor, eom::TaylorOptions::Scheme::jorba_zou},
                                std::pair{eom::Method::taylor_paper, eom::TaylorOptions::Scheme::paper}}) {
    opt.method = method;
    eom::TaylorOptions t;
    t.scheme = scheme;
    const auto k = eom::integrate<SP>(0, 1, x0, nullptr, p.data(), opt);
    const auto l = eom::taylor<SP>(0, 1, x0, nullptr, p.data(), ad, t, none);
    ASSERT_EQ(k.status, eom::Status::ok);
    EXPECT_EQ(k.x, l.x);
    EXPECT_EQ(k.evaluations, l.evaluations);
  }

  opt.method = eom::Method::variational;
  opt.step = 0.01;
  const auto e = eom::integrate<SP>(0, 1, x0, nullptr, p.data(), opt);
  const auto f = eom::variational<SP>(0, 1, 100, x0, nullptr, p.data(), none);
  ASSERT_EQ(e.status, eom::Status::ok);
  EXPECT_EQ(e.x, f.x);
  EXPECT_EQ(e.evaluations, f.evaluations);
}

// A step that does not divide the span is shortened so that whole steps end exactly at t1.
TEST(Integrate, FixedStepEndsExactlyAtTheEndTime) {
  eom::IntegrationOptions opt;
  opt.method = eom::Method::rk4;
  opt.step = 0.3;
  double last_t = 0;
  long calls = 0;
  const auto r = eom::integrate<SP>(0, 1, x0, nullptr, p.data(), opt, [&](double t, const auto&) {
    last_t = t;
    ++calls;
  });
  ASSERT_EQ(r.status, eom::Status::ok);
  EXPECT_EQ(r.accepted, 4);  // ceil(1 / 0.3) steps of 0.25
  EXPECT_EQ(calls, 5);
  EXPECT_EQ(last_t, 1.0);
}

// Dense output of a fixed-step method: the observer sees exactly the requested times, and the
// error there (integration and interpolation together) shrinks at the 4th order of RK4.
TEST(Integrate, FixedStepDenseOutputIsFourthOrder) {
  // Thirds are never step ends of the dyadic steps below, so every one is interpolated.
  const std::vector<double> times{0.0, 1.0 / 3, 2.0 / 3, 1.0};
  // The truth: RK4 with 2¹⁴ steps straight to each time (error ~1e-14).
  std::vector<eom::StateOf<2>> truth{x0};
  for (std::size_t k = 1; k < times.size(); ++k)
    truth.push_back(eom::rk4<SP>(0, times[k], 1 << 14, x0, nullptr, p.data(), none).x);

  auto worst_error = [&](double step) {
    eom::IntegrationOptions opt;
    opt.method = eom::Method::rk4;
    opt.step = step;
    opt.output_times = times;
    std::vector<double> seen;
    double worst = 0;
    const auto r = eom::integrate<SP>(0, 1, x0, nullptr, p.data(), opt, [&](double t, const auto& x) {
      const std::size_t k = seen.size();
      seen.push_back(t);
      for (int i = 0; i < 4; ++i) worst = std::max(worst, std::abs(x[i] - truth[k][i]));
    });
    EXPECT_EQ(r.status, eom::Status::ok);
    EXPECT_EQ(seen, times);
    return worst;
  };
  const double e1 = worst_error(1.0 / 32), e2 = worst_error(1.0 / 64), e3 = worst_error(1.0 / 128);
  const double order1 = std::log2(e1 / e2), order2 = std::log2(e2 / e3);
  std::printf("  dense rk4 errors %.2e %.2e %.2e, orders %.2f %.2f\n", e1, e2, e3, order1, order2);
  EXPECT_NEAR(order2, 4.0, 0.3);
}

TEST(Integrate, RefusesBadInputBeforeAnyStep) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto run = [&](double t0, double t1, eom::StateOf<2> x, eom::IntegrationOptions opt) {
    long calls = 0;
    const auto r = eom::integrate<SP>(t0, t1, x, nullptr, p.data(), opt, [&](double, const auto&) { ++calls; });
    EXPECT_EQ(r.evaluations, 0);
    EXPECT_EQ(calls, 0);
    // every refusal says which argument and why (not the fallback that names none)
    if (r.status == eom::Status::invalid_argument) {
      EXPECT_NE(r.message, nullptr);
      if (r.message) {
        EXPECT_EQ(std::string(r.message).find("found no reason"), std::string::npos) << r.message;
      }
    } else {
      EXPECT_EQ(r.message, nullptr);
    }
    return r.status;
  };
  for (auto method : {eom::Method::rk4, eom::Method::dopri5, eom::Method::dop853,
                      eom::Method::radau5, eom::Method::taylor, eom::Method::taylor_paper,
                      eom::Method::variational}) {
    SCOPED_TRACE(eom::to_string(method));
    eom::IntegrationOptions good;
    good.method = method;
    good.step = eom::is_fixed_step(method) ? 0.01 : 0.0;
    auto o = good;
    EXPECT_EQ(run(1, 0, x0, good), eom::Status::invalid_argument);    // end before start
    EXPECT_EQ(run(0, 0, x0, good), eom::Status::invalid_argument);    // empty span
    EXPECT_EQ(run(0, nan, x0, good), eom::Status::invalid_argument);  // non-finite end
    auto bad_x = x0;
    bad_x[2] = nan;
    EXPECT_EQ(run(0, 1, bad_x, good), eom::Status::invalid_argument);
    o.rtol = 0;
    EXPECT_EQ(run(0, 1, x0, o), eom::Status::invalid_argument);
    o = good;
    o.atol = -1;
    EXPECT_EQ(run(0, 1, x0, o), eom::Status::invalid_argument);
    o = good;
    o.step = -0.01;
    EXPECT_EQ(run(0, 1, x0, o), eom::Status::invalid_argument);
    o.step = nan;
    EXPECT_EQ(run(0, 1, x0, o), eom::Status::invalid_argument);
    const std::vector<double> descending{0.5, 0.2}, outside{0.5, 2.0};
    o = good;
    o.output_times = descending;
    EXPECT_EQ(run(0, 1, x0, o), eom::Status::invalid_argument);
    o.output_times = outside;
    EXPECT_EQ(run(0, 1, x0, o), eom::Status::invalid_argument);
    if (eom::is_fixed_step(method)) {
      o = good;
      o.step = 0;  // a fixed-step method needs its step
      EXPECT_EQ(run(0, 1, x0, o), eom::Status::invalid_argument);
      o.step = 1e-3;
      o.max_steps = 10;  // 1000 steps needed: refused up front
      EXPECT_EQ(run(0, 1, x0, o), eom::Status::step_limit);
    }
  }
}

// An invalid_argument result names the argument and why (IntegrationResult::message).
TEST(Integrate, AnInvalidArgumentSaysWhichAndWhy) {
  auto message = [&](double t0, double t1, const eom::IntegrationOptions& opt) {
    const auto r = eom::integrate<SP>(t0, t1, x0, nullptr, p.data(), opt);
    EXPECT_EQ(r.status, eom::Status::invalid_argument);
    return std::string(r.message ? r.message : "(none)");
  };
  eom::IntegrationOptions opt;
  opt.method = eom::Method::rk4;  // no step
  EXPECT_EQ(message(0, 1, opt).rfind("step: rk4 takes a fixed step: give step > 0", 0), 0u) << message(0, 1, opt);
  opt.method = eom::Method::dopri5;
  EXPECT_EQ(message(1, 0, opt).rfind("t1: must be greater than t0", 0), 0u);
  opt.rtol = -1;
  EXPECT_EQ(message(0, 1, opt), "rtol: must be finite and > 0");
  opt.rtol = 1e-8;
  opt.stabilization.method = eom::Stabilization::Method::projection;  // no constraints
  EXPECT_EQ(message(0, 1, opt).rfind("stabilization: the model has no constraints", 0), 0u);
  opt.stabilization.method = eom::Stabilization::Method::none;
  opt.method = eom::Method::taylor;
  opt.taylor_order = 1;
  EXPECT_EQ(message(0, 1, opt).rfind("taylor_order: taylor takes 0", 0), 0u) << message(0, 1, opt);
  opt.method = eom::Method::dopri5;
  opt.taylor_order = 0;
  EXPECT_EQ(eom::integrate<SP>(0, 1, x0, nullptr, p.data(), opt).message, nullptr);  // ok: none
  EXPECT_EQ(eom::integration_argument_problem<SP>(0, 1, x0, opt), nullptr);
}

TEST(Integrate, SaysWhenTheKernelsOfAMethodAreMissing) {
  eom::IntegrationOptions opt;
  opt.method = eom::Method::variational;
  opt.step = 0.01;
  const auto r = eom::integrate<DynamicsOnly>(0, 1, x0, nullptr, p.data(), opt);
  EXPECT_EQ(r.status, eom::Status::method_unavailable);
  EXPECT_EQ(r.evaluations, 0);
  for (auto method : {eom::Method::radau5, eom::Method::taylor, eom::Method::taylor_paper}) {
    opt.method = method;  // needs forward_dynamics_derivatives / taylor_coefficients
    EXPECT_EQ(eom::integrate<DynamicsOnly>(0, 1, x0, nullptr, p.data(), opt).status,
              eom::Status::method_unavailable);
  }
  opt.method = eom::Method::rk4;  // the explicit methods need forward_dynamics only
  EXPECT_EQ(eom::integrate<DynamicsOnly>(0, 1, x0, nullptr, p.data(), opt).status, eom::Status::ok);
}

// The variational integrator keeps the constraints itself; asking it to stabilize as well is an
// error, not silently ignored.
TEST(Integrate, VariationalRefusesAStabilizationRequest) {
  using CP = eom::Reference<eom::models::CartesianPendulum>;
  const auto pc = CP::parameter_values;
  const eom::StateOf<2> xc{0.0, -0.8, 1.0, 0.0};
  eom::IntegrationOptions opt;
  opt.method = eom::Method::variational;
  opt.step = 0.01;
  opt.stabilization.method = eom::Stabilization::Method::projection;
  EXPECT_EQ(eom::integrate<CP>(0, 1, xc, nullptr, pc.data(), opt).status, eom::Status::invalid_argument);
  opt.stabilization.method = eom::Stabilization::Method::none;
  EXPECT_EQ(eom::integrate<CP>(0, 1, xc, nullptr, pc.data(), opt).status, eom::Status::ok);
}

}  // namespace
