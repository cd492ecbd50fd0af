// tests/support/free_rigid_body.hpp, the closed-form torque-free asymmetric rigid body, against an
// independent integration of Euler's equations: a Taylor series in double-double (qd's dd_real,
// order 30, step 1/32 s, whose own error is checked against step 1/64 s to < 1e-26) over 20 s, at
// the step points and inside the steps. Both sides of the separatrix (the polhode about the axis
// of the largest and of the smallest moment), two bodies, the axes in every kind of order (even and
// odd permutations), starts at and away from the turning points; T and |Jω| conserved by the
// closed form, ω(0) = ω0, the period, the refused and the constant cases.
#include <gtest/gtest.h>

#include <qd/dd_real.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "free_rigid_body.hpp"

namespace {

using eomtest::FreeRigidBody;
using Vec = std::array<double, 3>;
using DVec = std::array<dd_real, 3>;

constexpr double kEnd = 20.0;          // s
constexpr double kStep = 1.0 / 32.0;   // s, exact in binary
constexpr double kInside = 0.375;      // the point inside each step, as a fraction of it (exact)
constexpr int kOrder = 30;

// Samples of ω at t = n h and t = (n + kInside) h, n = 0 .. steps − 1 (and t = end).
struct Samples {
  std::vector<double> t;
  std::vector<DVec> w;
};

// Euler's equations in the given (unsorted) axis order, ω̇_i = c_i ω_j ω_k with (i, j, k) cyclic
// and c_i = (J_j − J_k) / J_i, integrated by Taylor series: the coefficients w[i][n] of
// ω_i(t0 + s) = Σ w[i][n] sⁿ obey (n + 1) w[i][n + 1] = c_i Σ_{m ≤ n} w[j][m] w[k][n − m].
Samples taylor_reference(const Vec& J, const Vec& w0, double h, int order) {
  DVec c;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    c[i] = (dd_real(J[j]) - dd_real(J[k])) / dd_real(J[i]);
  }
  const int steps = int(std::lround(kEnd / h));
  Samples out;
  std::vector<std::array<dd_real, 3>> a(std::size_t(order) + 1);
  DVec x{dd_real(w0[0]), dd_real(w0[1]), dd_real(w0[2])};
  auto horner = [&](const dd_real& s) {
    DVec v;
    for (int i = 0; i < 3; ++i) {
      dd_real p = a[std::size_t(order)][std::size_t(i)];
      for (int n = order - 1; n >= 0; --n) p = p * s + a[std::size_t(n)][std::size_t(i)];
      v[std::size_t(i)] = p;
    }
    return v;
  };
  for (int step = 0; step < steps; ++step) {
    a[0] = x;
    for (int n = 0; n < order; ++n) {
      for (int i = 0; i < 3; ++i) {
        const int j = (i + 1) % 3, k = (i + 2) % 3;
        dd_real sum = 0.0;
        for (int m = 0; m <= n; ++m)
          sum += a[std::size_t(m)][std::size_t(j)] * a[std::size_t(n - m)][std::size_t(k)];
        a[std::size_t(n + 1)][std::size_t(i)] = c[std::size_t(i)] * sum / double(n + 1);
      }
    }
    out.t.push_back(step * h);
    out.w.push_back(x);
    out.t.push_back((step + kInside) * h);
    out.w.push_back(horner(dd_real(kInside * h)));
    x = horner(dd_real(h));
  }
  out.t.push_back(steps * h);
  out.w.push_back(x);
  return out;
}

double max_abs(const Vec& v) {
  return std::max({std::abs(v[0]), std::abs(v[1]), std::abs(v[2])});
}

struct Measured {
  double omega_abs = 0;      // max |ω_closed − ω_ref|, rad/s
  double omega_rel = 0;      // the same over max |ω0_i|
  double energy_rel = 0;     // max |T(t) − T(0)| / T(0), closed form
  double momentum_rel = 0;   // max ||Jω(t)| − |Jω0|| / |Jω0|, closed form
  double start_ulps = 0;     // max |ω(0) − ω0| in units of ε max |ω0_i|
  double period_rel = 0;     // max |ω(t + period) − ω(t)| over max |ω0_i|
};

// The closed form against the Taylor reference, in the given axis order.
Measured measure(const Vec& J, const Vec& w0, const char* name) {
  const FreeRigidBody body(J, w0);
  EXPECT_FALSE(body.constant());
  const Samples ref = taylor_reference(J, w0, kStep, kOrder);
  const double scale = max_abs(w0);
  Measured m;
  auto invariants = [&](const Vec& w) {
    long double t2 = 0, h2 = 0;
    for (int i = 0; i < 3; ++i) {
      const long double jw = (long double)J[std::size_t(i)] * w[std::size_t(i)];
      t2 += jw * w[std::size_t(i)];
      h2 += jw * jw;
    }
    return std::array<long double, 2>{t2, std::sqrt(h2)};
  };
  const auto inv0 = invariants(w0);
  const double period = body.period();
  for (std::size_t s = 0; s < ref.t.size(); ++s) {
    const Vec w = body.omega(ref.t[s]);
    for (std::size_t i = 0; i < 3; ++i)
      m.omega_abs = std::max(m.omega_abs, std::abs(to_double(dd_real(w[i]) - ref.w[s][i])));
    const auto inv = invariants(w);
    m.energy_rel = std::max(m.energy_rel, double(std::abs(inv[0] - inv0[0]) / inv0[0]));
    m.momentum_rel = std::max(m.momentum_rel, double(std::abs(inv[1] - inv0[1]) / inv0[1]));
    if (s % 16 == 0) {
      const Vec wp = body.omega(ref.t[s] + period);
      for (int i = 0; i < 3; ++i)
        m.period_rel = std::max(m.period_rel,
                                std::abs(wp[std::size_t(i)] - w[std::size_t(i)]) / scale);
    }
  }
  m.omega_rel = m.omega_abs / scale;
  const Vec start = body.omega(0.0);
  for (int i = 0; i < 3; ++i)
    m.start_ulps = std::max(m.start_ulps, std::abs(start[std::size_t(i)] - w0[std::size_t(i)]) /
                                              (std::numeric_limits<double>::epsilon() * scale));
  std::printf("[ measured ] %-34s %s k^2=%.3f lambda=%.3f: |dw|=%.2e (rel %.2e)  dT/T=%.1e  "
              "d|Jw|/|Jw|=%.1e  w(0)-w0=%.0f ulp  period %.1e\n",
              name, body.circles_largest_axis() ? "largest " : "smallest", body.modulus_squared(),
              body.frequency(), m.omega_abs, m.omega_rel, m.energy_rel, m.momentum_rel,
              m.start_ulps, m.period_rel);
  return m;
}

void expect_accurate(const Vec& J, const Vec& w0, const char* name, bool about_largest) {
  SCOPED_TRACE(name);
  EXPECT_EQ(FreeRigidBody(J, w0).circles_largest_axis(), about_largest);
  const Measured m = measure(J, w0, name);
  EXPECT_LE(m.omega_abs, 1e-12);       // the brief's bound
  EXPECT_LE(m.omega_rel, 1e-14);       // what the closed form claims
  EXPECT_LE(m.energy_rel, 1e-14);
  EXPECT_LE(m.momentum_rel, 1e-14);
  EXPECT_LE(m.start_ulps, 2.0);
  EXPECT_LE(m.period_rel, 1e-14);
}

Vec permute(const Vec& v, const std::array<int, 3>& p) {  // out[i] = v[p[i]]
  return {v[std::size_t(p[0])], v[std::size_t(p[1])], v[std::size_t(p[2])]};
}

const Vec kBody1{1.0, 2.0, 3.5};
const Vec kBody2{0.02, 0.035, 0.05};

TEST(FreeRigidBody, ReferenceIsConverged) {
  // The Taylor reference at 1/32 s against itself at 1/64 s, at the common points.
  const Vec w0{0.3, -0.5, 1.2};
  const Samples a = taylor_reference(kBody1, w0, kStep, kOrder);
  const Samples b = taylor_reference(kBody1, w0, kStep / 2, kOrder);
  double diff = 0;
  for (std::size_t s = 0; s < a.t.size(); s += 2) {
    ASSERT_EQ(a.t[s], b.t[2 * s]);
    for (int i = 0; i < 3; ++i)
      diff = std::max(diff, std::abs(to_double(a.w[s][std::size_t(i)] -
                                               b.w[2 * s][std::size_t(i)])));
  }
  std::printf("[ measured ] Taylor reference, step 1/32 vs 1/64 s: %.1e\n", diff);
  EXPECT_LE(diff, 1e-26);
}

TEST(FreeRigidBody, AboutLargestAxis) {
  expect_accurate(kBody1, {0.3, -0.5, 1.2}, "J=(1,2,3.5) w0=(0.3,-0.5,1.2)", true);
  expect_accurate(kBody1, {-1.1, 2.2, 1.7}, "J=(1,2,3.5) w0=(-1.1,2.2,1.7)", true);
  expect_accurate(kBody2, {0.2, 0.3, -0.4}, "J=(.02,.035,.05) w0=(0.2,0.3,-0.4)", true);
  expect_accurate(kBody2, {-0.9, -2.1, 1.6}, "J=(.02,.035,.05) w0=(-0.9,-2.1,1.6)", true);
}

TEST(FreeRigidBody, AboutSmallestAxis) {
  expect_accurate(kBody1, {2.0, 0.6, -0.3}, "J=(1,2,3.5) w0=(2,0.6,-0.3)", false);
  expect_accurate(kBody1, {2.6, -1.2, 0.4}, "J=(1,2,3.5) w0=(2.6,-1.2,0.4)", false);
  expect_accurate(kBody2, {-1.5, 1.0, 0.5}, "J=(.02,.035,.05) w0=(-1.5,1,0.5)", false);
  expect_accurate(kBody2, {2.8, 0.4, -0.7}, "J=(.02,.035,.05) w0=(2.8,0.4,-0.7)", false);
}

TEST(FreeRigidBody, TurningPointsAndAmplitudeQuadrants) {
  // ω2 = 0 with cn = ±1 (u0 = 0 and u0 = 2K), ω_cn = 0 (u0 = ±K), both signs of σ.
  expect_accurate(kBody1, {0.3, 0.0, 1.2}, "J=(1,2,3.5) w0=(0.3,0,1.2)", true);
  expect_accurate(kBody1, {-0.3, 0.0, 1.2}, "J=(1,2,3.5) w0=(-0.3,0,1.2)", true);
  expect_accurate(kBody1, {0.0, 0.8, -1.0}, "J=(1,2,3.5) w0=(0,0.8,-1)", true);
  expect_accurate(kBody1, {0.0, -0.8, 1.0}, "J=(1,2,3.5) w0=(0,-0.8,1)", true);
  expect_accurate(kBody1, {-2.0, 0.0, 0.3}, "J=(1,2,3.5) w0=(-2,0,0.3)", false);
  expect_accurate(kBody1, {2.0, 0.0, -0.3}, "J=(1,2,3.5) w0=(2,0,-0.3)", false);
  expect_accurate(kBody1, {2.0, 0.6, 0.0}, "J=(1,2,3.5) w0=(2,0.6,0)", false);
  expect_accurate(kBody1, {-2.0, -0.6, 0.0}, "J=(1,2,3.5) w0=(-2,-0.6,0)", false);
}

TEST(FreeRigidBody, AnyAxisOrder) {
  // Every permutation of the axes (three even, three odd), both regimes, checked against the
  // reference integrated in that order; the even ones are bitwise the sorted solution permuted.
  const std::array<std::array<int, 3>, 6> perms{
      {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {1, 0, 2}, {0, 2, 1}, {2, 1, 0}}};
  const std::array<Vec, 2> starts{Vec{0.3, -0.5, 1.2}, Vec{2.0, 0.6, -0.3}};
  for (const auto& w0 : starts) {
    const FreeRigidBody sorted(kBody1, w0);
    for (std::size_t p = 1; p < perms.size(); ++p) {
      const Vec J = permute(kBody1, perms[p]), w = permute(w0, perms[p]);
      const std::string name = "J=(" + std::to_string(J[0]).substr(0, 3) + "," +
                               std::to_string(J[1]).substr(0, 3) + "," +
                               std::to_string(J[2]).substr(0, 3) + ") permuted";
      expect_accurate(J, w, name.c_str(), w0[2] == 1.2);
      if (p < 3) {  // even: the same computation
        const FreeRigidBody body(J, w);
        for (double t : {0.0, 0.7, 3.3, 19.9})
          EXPECT_EQ(body.omega(t), permute(sorted.omega(t), perms[p])) << "t = " << t;
      }
    }
  }
  // The second body, reversed (an odd permutation).
  expect_accurate({0.05, 0.035, 0.02}, {0.5, 1.0, -1.5}, "J=(.05,.035,.02) reversed", false);
  expect_accurate({0.05, 0.035, 0.02}, {-0.4, 0.3, 0.2}, "J=(.05,.035,.02) reversed", true);
}

TEST(FreeRigidBody, NearSeparatrix) {
  // k'² about 1e-4 and 1e-6: the accuracy degrades like ε_ld/k'² (reported, looser bound).
  for (double gap : {1e-4, 1e-6}) {
    // S = C(C−B) ω3² − A(B−A) ω1² = gap · A(B−A) ω1² with ω1 = 1.
    const double w3 = std::sqrt((1.0 + gap) / (3.5 * 1.5));
    const Vec w0{1.0, 0.5, w3};
    const FreeRigidBody body(kBody1, w0);
    const std::string name = "near separatrix k'^2=" + std::to_string(
                                 body.complementary_modulus_squared()).substr(0, 8);
    const Measured m = measure(kBody1, w0, name.c_str());
    EXPECT_LE(m.omega_abs, 1e-12);
  }
}

TEST(FreeRigidBody, ConstantSolutions) {
  for (const Vec& w0 : {Vec{0, 0, 0}, Vec{1.3, 0, 0}, Vec{0, -1.3, 0}, Vec{0, 0, 2.1}}) {
    const FreeRigidBody body(kBody1, w0);
    EXPECT_TRUE(body.constant());
    for (double t : {0.0, 1.0, 7.3, -2.0, 20.0}) EXPECT_EQ(body.omega(t), w0);
  }
}

TEST(FreeRigidBody, Refusals) {
  auto refused = [](const Vec& J, const Vec& w0, const char* what) {
    try {
      FreeRigidBody(J, w0);
      ADD_FAILURE() << "not refused: " << what;
    } catch (const std::invalid_argument& e) {
      std::printf("[ refused  ] %s: %s\n", what, e.what());
    }
  };
  const Vec w0{0.3, -0.5, 1.2};
  refused({1.0, 1.0, 2.0}, w0, "J1 = J2");
  refused({1.0, 2.0, 2.0}, w0, "J2 = J3");
  refused({2.0, 1.0, 2.0}, w0, "J1 = J3");
  refused({0.0, 1.0, 2.0}, w0, "J1 = 0");
  refused({-1.0, 1.0, 2.0}, w0, "J1 < 0");
  refused({std::nan(""), 1.0, 2.0}, w0, "J1 NaN");
  refused(kBody1, {0.3, std::numeric_limits<double>::infinity(), 1.2}, "w0 infinite");
  // J = (3, 5, 6): S = 6·1·ω3² − 3·2·ω1² = 0 at ω1 = ω3 (exactly, in any axis order).
  refused({3.0, 5.0, 6.0}, {1.0, 0.7, 1.0}, "on the separatrix");
  refused({6.0, 3.0, 5.0}, {-1.0, 1.0, 0.7}, "on the separatrix, permuted");
}

}  // namespace
