// The paper's 10-link deployment with hinge latches (eom/integration/locks.hpp, models/chain_latches.hpp) on
// the generated chain10 kernels: each hinge 2..10 latches once when it comes straight, the
// kinetic energy lost at each latch equals the impulse-momentum formula, the momenta the latch
// impulse cannot change do not change, and a latched hinge stays straight to the end.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <tuple>
#include <vector>

#include <eom/integration/integrate.hpp>
#include <eom/integration/locks.hpp>
#include <eom/numeric/linalg.hpp>

#include <eom/reference/reference.hpp>

#include <chain10.hpp>
#include <models/chain.hpp>
#include <models/chain_latches.hpp>

namespace {

constexpr int n = 10, hinges = n - 1;
using Latched = eom::Locked<chain10::Kernels, eom::models::ChainHingeRows<n>>;
using Latches = eom::Latches<Latched>;
using State = eom::StateOf<n>;

State stowed() {
  const auto s = eom::models::stowed_accordion<n>(5.0 * std::numbers::pi / 180.0, -0.05);
  State x;
  std::copy(s.begin(), s.end(), x.begin());
  return x;
}

// The angular momentum of links m..n (1-based m) about joint m, from the links' positions and
// velocities (independent of the kernels): Σ mᵢ (rᵢ − Jₘ) × vᵢ + Iᵢ θ̇ᵢ.
double outboard_angular_momentum(const State& x, const double* p, int m) {
  double jx = 0, jy = 0, vx = 0, vy = 0, Jx = 0, Jy = 0, H = 0;  // joint i, its velocity, joint m
  for (int i = 0; i < n; ++i) {
    const double l = p[n + i], c = std::cos(x[i]), s = std::sin(x[i]), w = x[n + i];
    if (i == m - 1) Jx = jx, Jy = jy;
    if (i >= m - 1) {
      const double rx = jx + 0.5 * l * c - Jx, ry = jy + 0.5 * l * s - Jy;
      const double ux = vx - 0.5 * l * s * w, uy = vy + 0.5 * l * c * w;
      H += p[i] * (rx * uy - ry * ux) + p[2 * n + i] * w;
    }
    jx += l * c, jy += l * s, vx -= l * s * w, vy += l * c * w;
  }
  return H;
}

// The kinetic energy a perfectly inelastic latch of hinge h (2..n) removes, in the relative
// coordinates of the model with fewer coordinates (one rate per free hinge, the hinges in `free`
// before the latch): ½ r²/(M_r⁻¹)ₕₕ, M_r = ZᵀMZ, Z's columns the rigid rotations of the links
// outboard of each free hinge. Locked hinges' slots are identity (decoupled, never read).
// In long double with M from eom::Reference (not the generated kernels): M_r's entries are sums
// that cancel, and at the last latch (ΔT ≈ 1.7e-4 J of 0.011 J) the formula in double is off by
// ~2e-12 relative, more than the generated T⁻ − T⁺ it checks (~5e-15).
double latch_energy_formula(const State& x, const double* p, const std::array<bool, n>& free, int h) {
  using Real = long double;
  using Reference = eom::Reference<eom::models::Chain<n>, Real>;
  std::array<Real, 2 * n> xl;
  std::array<Real, 4 * n + 1> pl;
  std::copy(x.begin(), x.end(), xl.begin());
  std::copy(p, p + pl.size(), pl.begin());
  std::array<Real, n * n> M, Mr{};
  Reference::mass_matrix(xl.data(), pl.data(), M.data());
  auto outboard_sum = [&](int a, int b) {  // u_aᵀ M u_b, u_m = Σ_{k ≥ m} e_k (0-based slots)
    Real s = 0;
    for (int i = a; i < n; ++i)
      for (int k = b; k < n; ++k) s += M[i + n * k];
    return s;
  };
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      Mr[a + n * b] = free[a] && free[b] ? outboard_sum(a, b) : a == b ? Real(1) : Real(0);
  if (!eom::linalg::cholesky<Real, n>(Mr)) return NAN;
  std::array<Real, n> e{};
  e[h - 1] = 1;
  eom::linalg::cholesky_solve<Real, n>(Mr, e.data());
  const Real r = xl[n + h - 1] - xl[n + h - 2];
  return static_cast<double>(r * r / (2 * e[h - 1]));
}

struct Deployment {
  eom::IntegrationResult<n> result;
  std::vector<eom::EventRecord<n>> events;
  double worst_angle = 0, worst_rate = 0;  // latched hinges, every step end after their latch
  long checked = 0;
};

Deployment deploy(eom::Method method, double tol, double t1, double step = 0) {
  const State x0 = stowed();
  const auto targets = eom::models::chain_straight_targets<n>(x0.data());
  Latches latches(chain10::parameter_values, targets, x0);
  eom::IntegrationOptions opt;
  opt.method = method;
  opt.rtol = opt.atol = tol;
  opt.step = step;
  std::array<eom::EventRecord<n>, 32> storage;
  eom::EventLog<n> log(storage);
  Deployment run;
  // The observer sees the latch instant twice, (T, x⁻) then (T, x⁺) (events.hpp), the flag set
  // at both: the first look at a locked hinge is its state before the impulse, still moving.
  std::array<bool, hinges> seen{};
  auto watch = [&](double, const State& x) {
    for (int k = 0; k < hinges; ++k)
      if (latches.locked(k)) {
        run.worst_angle = std::max(run.worst_angle, std::abs(Latches::row(x.data(), k) - targets[k]));
        if (seen[k]) run.worst_rate = std::max(run.worst_rate, std::abs(Latches::row(x.data() + n, k)));
        seen[k] = true;
        ++run.checked;
      }
  };
  run.result = eom::integrate<Latched>(0, t1, x0, nullptr, latches.parameters.data(), opt,
                                       latches.events(), log, watch);
  run.events.assign(log.records().begin(), log.records().end());
  return run;
}

TEST(Latches, EveryHingeLatchesOnceInOrderAndStaysStraight) {
  for (auto [method, step] : {std::pair{eom::Method::dopri5, 0.0}, std::pair{eom::Method::dop853, 0.0},
                              std::pair{eom::Method::rk4, 1e-3}}) {
    SCOPED_TRACE(eom::to_string(method));
    const Deployment run = deploy(method, 1e-12, 10.0, step);  // the demo's 10 s
    ASSERT_EQ(run.result.status, eom::Status::ok) << eom::to_string(run.result.status);
    ASSERT_EQ(run.events.size(), static_cast<std::size_t>(hinges));
    const auto targets = eom::models::chain_straight_targets<n>(stowed().data());
    for (int k = 0; k < hinges; ++k) {
      const auto& e = run.events[k];
      std::printf("  hinge %2d latches at t = %.15f s\n", e.index + 2, e.t);
      EXPECT_EQ(e.index, k);  // hinge 2 first, then outwards
      if (k > 0) {
        EXPECT_GT(e.t, run.events[k - 1].t);
      }
      // Located on the straight position, and stopped there: every latched hinge's rate zero.
      EXPECT_LE(std::abs(Latches::row(e.x.data(), k) - targets[k]), 1e-12);
      for (int i = 0; i <= k; ++i) EXPECT_LE(std::abs(Latches::row(e.x_after.data() + n, i)), 1e-12);
    }
    std::printf("  %s after latching: max |angle - straight| %.1e rad, max |relative rate| %.1e rad/s "
                "over %ld checks\n", eom::to_string(method), run.worst_angle, run.worst_rate, run.checked);
    EXPECT_GT(run.checked, 1000);
    // Held exactly up to round-off: the locked rows' rates stay at round-off (~1e-13 rad/s), and
    // their integral over the 10 s is the angle's drift.
    EXPECT_LE(run.worst_angle, 1e-11);
    EXPECT_LE(run.worst_rate, 1e-12);
  }
}

TEST(Latches, EnergyLostAtEachLatchIsTheImpulseMomentumFormula) {
  const Deployment run = deploy(eom::Method::dopri5, 1e-12, 4.0);
  ASSERT_EQ(run.result.status, eom::Status::ok) << eom::to_string(run.result.status);
  ASSERT_EQ(run.events.size(), static_cast<std::size_t>(hinges));
  const auto& p = chain10::parameter_values;
  std::array<bool, n> free;
  free.fill(true);
  double worst_energy = 0, worst_of_T = 0, worst_momentum = 0, latched_change = 1e300;
  for (const auto& e : run.events) {
    const int h = e.index + 2;
    const double* q = e.x.data();
    const double* q_after = e.x_after.data();
    EXPECT_TRUE(std::equal(q, q + n, q_after));  // the latch moves nothing: V is continuous
    const double lost = chain10::kinetic_energy(q, q + n, p.data()) -
                        chain10::kinetic_energy(q_after, q_after + n, p.data());
    const double formula = latch_energy_formula(e.x, p.data(), free, h);
    const double before = chain10::kinetic_energy(q, q + n, p.data());
    const double rel = std::abs(lost - formula) / formula;
    worst_of_T = std::max(worst_of_T, std::abs(lost - formula) / before);
    // Where the latch takes a fair share of T (≥ 10%), relative to what it takes; everywhere,
    // relative to T⁻ (below). The impulse is computed in double at the scale of T⁻, so a small
    // ΔT = T⁻ − T⁺ carries that rounding: at the last latch (ΔT = 1.6% of T⁻) 2.3e-12 of ΔT,
    // 3.6e-14 of T⁻, while T⁻ − T⁺ itself agrees with long double T to 5e-15.
    if (formula >= 0.1 * before) worst_energy = std::max(worst_energy, rel);
    if (&e == &run.events.front()) {  // nothing locked yet: the plain ½ r²/(aᵀM⁻¹a), a = e₂ − e₁
      std::array<double, n * n> M;
      chain10::mass_matrix(q, p.data(), M.data());
      ASSERT_TRUE((eom::linalg::cholesky<double, n>(M)));
      std::array<double, n> a{};
      a[h - 2] = -1, a[h - 1] = 1;
      const auto Minv_a = [&] { auto v = a; eom::linalg::cholesky_solve<double, n>(M, v.data()); return v; }();
      const double r = q[n + h - 1] - q[n + h - 2], aMa = Minv_a[h - 1] - Minv_a[h - 2];
      EXPECT_LE(std::abs(lost - 0.5 * r * r / aMa), 1e-12 * lost);
    }
    free[h - 1] = false;
    // Every hinge still free (the root pin included): the angular momentum of the links outboard
    // of it about it is unchanged; about the latched hinge it is not (the latch torque acts).
    double scale = 0;
    for (int m = 1; m <= n; ++m) scale = std::max(scale, std::abs(outboard_angular_momentum(e.x, p.data(), m)));
    for (int m = 1; m <= n; ++m) {
      const double change = std::abs(outboard_angular_momentum(e.x_after, p.data(), m) -
                                     outboard_angular_momentum(e.x, p.data(), m)) / scale;
      if (free[m - 1]) worst_momentum = std::max(worst_momentum, change);
      if (m == h) latched_change = std::min(latched_change, change);
    }
    std::printf("  hinge %2d: T lost %.9e J, formula %.9e J, rel. difference %.1e\n", h, lost, formula, rel);
  }
  std::printf("  worst: energy %.1e (rel.; %.1e of T before the latch), momentum about free hinges %.1e (rel.); about the "
              "latched hinge it changes by >= %.1e\n", worst_energy, worst_of_T, worst_momentum, latched_change);
  EXPECT_LE(worst_energy, 2e-13);
  EXPECT_LE(worst_of_T, 1e-13);
  EXPECT_LE(worst_momentum, 1e-13);
  EXPECT_GT(latched_change, 1e-6);  // the check above can tell a change
}

// The latch times are a property of the motion, not of the method: dopri5, rk4 and dop853 at a
// tighter tolerance agree.
TEST(Latches, LatchTimesAgreeAcrossMethods) {
  const Deployment reference = deploy(eom::Method::dop853, 1e-14, 1.5);
  ASSERT_EQ(reference.result.status, eom::Status::ok);
  ASSERT_EQ(reference.events.size(), static_cast<std::size_t>(hinges));
  for (auto [method, tol, step, bound] : {std::tuple{eom::Method::dopri5, 1e-12, 0.0, 1e-10},
                                          std::tuple{eom::Method::rk4, 0.0, 1e-4, 1e-10}}) {
    SCOPED_TRACE(eom::to_string(method));
    const Deployment run = deploy(method, tol == 0 ? 1e-8 : tol, 1.5, step);
    ASSERT_EQ(run.result.status, eom::Status::ok);
    ASSERT_EQ(run.events.size(), static_cast<std::size_t>(hinges));
    double worst = 0;
    for (int k = 0; k < hinges; ++k) worst = std::max(worst, std::abs(run.events[k].t - reference.events[k].t));
    std::printf("  %-7s latch times within %.1e s of dop853 at 1e-14\n", eom::to_string(method), worst);
    EXPECT_LE(worst, bound);
  }
}

TEST(Latches, MethodsThatNeedMoreThanForwardDynamicsAreUnavailable) {
  for (eom::Method m : {eom::Method::radau5, eom::Method::taylor, eom::Method::variational}) {
    const Deployment run = deploy(m, 1e-10, 0.1, 1e-3);
    EXPECT_EQ(run.result.status, eom::Status::method_unavailable) << eom::to_string(m);
  }
}

// The reset must see the parameters it switches: an integration given a copy fails at the
// first latch instead of running on with the hinge free.
TEST(Latches, ALatchGivenOtherParametersFails) {
  const State x0 = stowed();
  Latches latches(chain10::parameter_values, eom::models::chain_straight_targets<n>(x0.data()), x0);
  const auto copy = latches.parameters;
  eom::IntegrationOptions opt;
  eom::EventLog<n> log;
  const auto r = eom::integrate<Latched>(0, 4.0, x0, nullptr, copy.data(), opt, latches.events(), log);
  EXPECT_EQ(r.status, eom::Status::event_reset_failed);
  EXPECT_EQ(r.event, 0);
}

}  // namespace
