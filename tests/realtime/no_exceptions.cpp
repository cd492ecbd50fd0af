// Built with -fno-exceptions -fno-rtti (see CMakeLists.txt), as embedded and real-time targets
// often are: every runtime header must compile so (the bundled models' generated sources are
// compiled with the same flags in their libraries, models/CMakeLists.txt),
// and the integrators must run over the generated kernels. Exits with 1 on a failed check.
#if defined(__cpp_exceptions) || defined(__GXX_RTTI)
#error "this test must be compiled with -fno-exceptions -fno-rtti"
#endif

#include <array>
#include <cmath>
#include <cstdio>

#include "all_runtime_headers.hpp"  // every runtime/include/eom/**/*.hpp

#include <cartesian_pendulum.hpp>  // the bundled models (generated/)
#include <chain10.hpp>
#include <closed_chain5.hpp>
#include <double_pendulum.hpp>
#include <spring_pendulum.hpp>

#include <models/chain.hpp>
#include <models/spring_pendulum.hpp>

namespace {

int failures = 0;
void check(bool ok, const char* what) {
  if (!ok) {
    std::printf("no_exceptions: FAILED: %s\n", what);
    ++failures;
  }
}

}  // namespace

int main() {
  const auto none = [](auto&&...) {};

  // RK4 on the spring pendulum: energy kept to the method's accuracy (1 ms steps, 1 s).
  using Spring = spring_pendulum::Kernels;
  const auto ps = Spring::parameter_values;
  const eom::StateOf<2> xs{0.55, 0.0, 0.01, 2.5};
  const auto energy = [&](const eom::StateOf<2>& x) {
    return Spring::kinetic_energy(x.data(), x.data() + 2, ps.data()) +
           Spring::potential_energy(x.data(), ps.data());
  };
  const auto fixed = eom::rk4<Spring>(0, 1, 1000, xs, nullptr, ps.data(), none);
  check(fixed.status == eom::Status::ok, "rk4 on spring_pendulum");
  check(std::abs(energy(fixed.x) - energy(xs)) <= 1e-9 * std::abs(energy(xs)), "rk4 energy drift");

  // The variational integrator on the same model.
  const auto symplectic = eom::variational<Spring>(0, 1, 1000, xs, nullptr, ps.data(), none);
  check(symplectic.status == eom::Status::ok, "variational on spring_pendulum");

  // DOPRI5 on the chaotic double pendulum.
  const auto pd = double_pendulum::parameter_values;
  const auto adaptive =
      eom::dopri5<double_pendulum::Kernels>(0, 1, {2.0, 2.5, 0, 0}, nullptr, pd.data(), {}, none);
  check(adaptive.status == eom::Status::ok, "dopri5 on double_pendulum");

  // DOP853 and Radau5 on the same; Radau5's Newton solves take the generated Jacobian. Both at
  // rtol 1e-8: they agree with each other to 1e-6 (measured 8e-8) after 1 s.
  using Double = double_pendulum::Kernels;
  const auto high_order = eom::dop853<Double>(0, 1, {2.0, 2.5, 0, 0}, nullptr, pd.data(), {}, none);
  const auto implicit = eom::radau5<Double>(0, 1, {2.0, 2.5, 0, 0}, nullptr, pd.data(), {}, none);
  check(high_order.status == eom::Status::ok, "dop853 on double_pendulum");
  check(implicit.status == eom::Status::ok, "radau5 on double_pendulum");
  for (int i = 0; i < 4; ++i)
    check(std::abs(high_order.x[i] - implicit.x[i]) <= 1e-6, "dop853 and radau5 agree");

  // The Taylor integrator over the generated coefficient kernel, allocating its workspace and
  // with a workspace of the caller's; identical results.
  static std::array<double, eom::taylor_workspace_capacity<Double>> workspace;
  eom::TaylorOptions own, given;
  given.workspace = workspace;
  const auto taylor_own =
      eom::taylor<Double>(0, 1, {2.0, 2.5, 0, 0}, nullptr, pd.data(), {}, own, none);
  const auto taylor_given =
      eom::taylor<Double>(0, 1, {2.0, 2.5, 0, 0}, nullptr, pd.data(), {}, given, none);
  check(taylor_own.status == eom::Status::ok && taylor_given.status == eom::Status::ok,
        "taylor on double_pendulum");
  check(taylor_own.x == taylor_given.x, "taylor with a caller's workspace");

  // eom::integrate, every method, on a regular swing of the double pendulum: all within 5e-5 of
  // DOP853 at rtol 1e-12 after 1 s (the 2nd-order variational method at h = 1 ms is the farthest:
  // measured 5.3e-6; the others 2.1e-7 and less).
  eom::IntegrationOptions tight;
  tight.method = eom::Method::dop853;
  tight.rtol = 1e-12, tight.atol = 1e-14;
  const eom::StateOf<2> swing{0.5, -0.3, 0, 0};
  const auto reference_end = eom::integrate<Double>(0, 1, swing, nullptr, pd.data(), tight);
  check(reference_end.status == eom::Status::ok, "integrate dop853 at rtol 1e-12");
  for (const eom::Method method :
       {eom::Method::rk4, eom::Method::dopri5, eom::Method::dop853, eom::Method::radau5,
        eom::Method::taylor, eom::Method::taylor_paper, eom::Method::variational}) {
    eom::IntegrationOptions opt;
    opt.method = method;
    opt.step = eom::is_fixed_step(method) ? 1e-3 : 0;
    const auto r = eom::integrate<Double>(0, 1, swing, nullptr, pd.data(), opt);
    bool close = r.status == eom::Status::ok;
    for (int i = 0; i < 4; ++i) close = close && std::abs(r.x[i] - reference_end.x[i]) <= 5e-5;
    if (!close) std::printf("no_exceptions: integrate %s: %s\n", eom::to_string(method),
                            eom::to_string(r.status));
    check(close, "integrate, every method, on double_pendulum");
  }

  // RK4 with projection on the closed chain; Baumgarte on the Cartesian pendulum.
  const auto pc = closed_chain5::parameter_values;
  eom::StateOf<5> xc{};
  for (int i = 0; i < 5; ++i) xc[i] = eom::models::ClosedChain5::initial_q[i];
  eom::Stabilization stab;
  stab.method = eom::Stabilization::Method::projection;
  const auto projected =
      eom::rk4<closed_chain5::Kernels>(0, 0.5, 100, xc, nullptr, pc.data(), none, stab);
  check(projected.status == eom::Status::ok, "rk4 with projection on closed_chain5");
  const auto pp = cartesian_pendulum::parameter_values;
  stab.method = eom::Stabilization::Method::baumgarte;
  const eom::StateOf<2> xp{0.8 * std::sin(0.3), -0.8 * std::cos(0.3), 1.2 * std::cos(0.3),
                           1.2 * std::sin(0.3)};
  const auto stabilized =
      eom::rk4<cartesian_pendulum::Kernels>(0, 1, 200, xp, nullptr, pp.data(), none, stab);
  check(stabilized.status == eom::Status::ok, "rk4 with Baumgarte on cartesian_pendulum");

  // chain10's sensitivities, and the run-time AD reference against the generated kernel.
  const auto p10 = chain10::parameter_values;
  std::array<double, 10> q10{}, qd10{};
  std::array<double, 100> dq, dqd;
  check(chain10::forward_dynamics_derivatives(0, q10.data(), qd10.data(), nullptr, p10.data(),
                                              dq.data(), dqd.data(), nullptr),
        "chain10 forward_dynamics_derivatives");
  double generated[2], reference[2];
  Spring::forward_dynamics(0, xs.data(), xs.data() + 2, nullptr, ps.data(), generated);
  eom::Reference<eom::models::SpringPendulum>::forward_dynamics(0, xs.data(), xs.data() + 2,
                                                                nullptr, ps.data(), reference);
  check(std::abs(generated[0] - reference[0]) <= 1e-13 * (1 + std::abs(reference[0])) &&
            std::abs(generated[1] - reference[1]) <= 1e-13 * (1 + std::abs(reference[1])),
        "the reference agrees with the generated forward dynamics");

  if (failures > 0) return 1;
  std::puts("no_exceptions: ok");
  return 0;
}
