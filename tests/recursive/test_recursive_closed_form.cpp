// (a) The recursive algorithms against closed forms: a single pendulum, a planar double
// pendulum, a mass on a tilted rail, a rotating arm with a radial slider, and a fixed joint
// against the one combined link it stands for.
#include "recursive_support.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <limits>

namespace {

using namespace rtest;

template <class S>
double epsilon() {
  if constexpr (std::is_same_v<S, dd_real>)
    return 4.93e-32;  // 2^-104
  else
    return static_cast<double>(std::numeric_limits<S>::epsilon());
}

template <class S>
const char* name() {
  if constexpr (std::is_same_v<S, dd_real>)
    return "dd_real";
  else if constexpr (std::is_same_v<S, long double>)
    return "long double";
  else
    return "double";
}

template <class S>
class RecursiveClosedForm : public ::testing::Test {};
using Scalars = ::testing::Types<double, long double, dd_real>;
TYPED_TEST_SUITE(RecursiveClosedForm, Scalars);

// Single pendulum about the (unnormalized) axis (0, 2, 0) of a joint frame yawed by 0.5 and
// raised to z = 1: mass 1.5 at (0, 0, −0.75), I_yy = 1/16 about the mass centre (the other
// entries, off-diagonal ones too, do not act on a fixed axis). Every input is a dyadic number
// except the yaw, the angle q and g; the yaw cancels out, so in dd_real the answers must match
// the closed forms to a few dd ulps, which fails if any cos/sin is taken in double.
// M = I_yy + m l² = 0.90625, ∂V/∂q = m g l sin q, c = 0, V = m g (1 − l cos q).
// Measured (max relative error over the checks): double 2.0e-16, long double 8.6e-20,
// dd_real 1.1e-32.
TYPED_TEST(RecursiveClosedForm, SinglePendulum) {
  using S = TypeParam;
  using std::cos, std::sin;
  Robot r;
  r.root = "base";
  r.links = {massless("base"),
             body("arm", 1.5, {0, 0, -0.75}, {0, 0, 0}, {0.125, 0.0625, 0.03125, 0.015625, -0.0078125, 0.01})};
  r.joints = {joint("swing", JointType::revolute, "base", "arm", {0.25, -0.5, 1.0}, {0, 0, 0.5},
                    {0, 2, 0}, 0.25)};
  eomtest::RecursiveDynamics<S> model(r);
  ASSERT_EQ(model.nq(), 1);
  const S m(1.5), l(0.75), g(9.81), Mexp(0.90625), d(0.25);
  double worst = 0;
  const auto check = [&](const S& got, const S& expected, const char* what) {
    using std::abs;
    const double err = dbl(abs(got - expected) / abs(expected));
    worst = std::max(worst, err);
    EXPECT_LE(err, 8 * epsilon<S>()) << what << " got " << dbl(got) << " expected " << dbl(expected);
  };
  for (const double qv : {0.5, -1.25, 2.75}) {
    const std::vector<S> q{S(qv)}, qd{S(-0.75)}, u{S(0.375)}, qdd{S(1.5)};
    std::vector<S> M(1), out(1);
    model.mass_matrix(q, M);
    check(M[0], Mexp, "M");
    model.gravity_forces(q, out);
    check(out[0], m * g * l * sin(q[0]), "dV/dq");
    model.bias_forces(q, qd, out);
    check(out[0], m * g * l * sin(q[0]), "c + dV/dq");
    model.inverse_dynamics(q, qd, qdd, out);
    check(out[0], Mexp * qdd[0] + m * g * l * sin(q[0]), "tau");
    model.forward_dynamics(q, qd, u, out);
    check(out[0], (u[0] - d * qd[0] - m * g * l * sin(q[0])) / Mexp, "qdd");
    check(model.kinetic_energy(q, qd), S(0.5) * Mexp * qd[0] * qd[0], "T");
    check(model.potential_energy(q), m * g * (S(1.0) - l * cos(q[0])), "V");
  }
  EXPECT_EQ(dbl(model.damping()[0]), 0.25);
  std::printf("single pendulum, %s: worst relative error %.2e\n", name<S>(), worst);
}

// Planar double pendulum (relative angles, both axes y):
//   M11 = I1 + I2 + m1 a1² + m2 (l1² + a2² + 2 l1 a2 cos q2), M12 = I2 + m2 (a2² + l1 a2 cos q2),
//   M22 = I2 + m2 a2²;  c1 = −m2 l1 a2 sin q2 (2 q̇1 q̇2 + q̇2²),  c2 = m2 l1 a2 sin q2 q̇1²;
//   ∂V/∂q1 = (m1 a1 + m2 l1) g sin q1 + m2 a2 g sin(q1 + q2),  ∂V/∂q2 = m2 a2 g sin(q1 + q2).
// Measured: double 5.3e-16, long double 1.3e-19, dd_real 1.2e-31.
TYPED_TEST(RecursiveClosedForm, DoublePendulum) {
  using S = TypeParam;
  using std::cos, std::sin, std::abs;
  const DoublePendulum p;
  eomtest::RecursiveDynamics<S> model(p.robot());
  const S m1(p.m1), m2(p.m2), l1(p.l1), a1(p.a1), a2(p.a2), I1(p.I1), I2(p.I2), g(9.81);
  double worst = 0;
  for (const auto& state : {std::array<double, 4>{0.5, -1.25, 0.75, -0.5},
                            std::array<double, 4>{2.5, 1.75, -1.5, 2.0}}) {
    const std::vector<S> q{S(state[0]), S(state[1])}, qd{S(state[2]), S(state[3])};
    const S c2 = cos(q[1]), s2 = sin(q[1]);
    const S M11 = I1 + I2 + m1 * a1 * a1 + m2 * (l1 * l1 + a2 * a2 + S(2.0) * l1 * a2 * c2);
    const S M12 = I2 + m2 * (a2 * a2 + l1 * a2 * c2), M22 = I2 + m2 * a2 * a2;
    const S G1 = (m1 * a1 + m2 * l1) * g * sin(q[0]) + m2 * a2 * g * sin(q[0] + q[1]);
    const S G2 = m2 * a2 * g * sin(q[0] + q[1]);
    const S C1 = -m2 * l1 * a2 * s2 * (S(2.0) * qd[0] * qd[1] + qd[1] * qd[1]);
    const S C2 = m2 * l1 * a2 * s2 * qd[0] * qd[0];
    std::vector<S> M(4), out(2);
    model.mass_matrix(q, M);
    const double eM = normwise(M, std::vector<S>{M11, M12, M12, M22});
    model.gravity_forces(q, out);
    const double eG = normwise(out, std::vector<S>{G1, G2});
    model.bias_forces(q, qd, out);
    const double eB = normwise(out, std::vector<S>{C1 + G1, C2 + G2});
    // q̈ = M⁻¹(τ − c − ∂V/∂q) by Cramer's rule, τ = (0.5, −0.25)
    const S r1 = S(0.5) - C1 - G1, r2 = S(-0.25) - C2 - G2, det = M11 * M22 - M12 * M12;
    model.articulated_body(q, qd, std::vector<S>{S(0.5), S(-0.25)}, out);
    const double eA = normwise(out, std::vector<S>{(M22 * r1 - M12 * r2) / det, (M11 * r2 - M12 * r1) / det});
    for (const double e : {eM, eG, eB, eA}) {
      worst = std::max(worst, e);
      EXPECT_LE(e, 32 * epsilon<S>());
    }
  }
  std::printf("double pendulum, %s: worst relative error %.2e\n", name<S>(), worst);
}

// A mass on a rail: prismatic axis (3, 0, 4)/5 in a joint frame yawed by 0.7 (yaw keeps the
// axis' z component 0.8): M = m, c = 0, ∂V/∂q = 0.8 m g, V = m g (0.3 + 0.8 q + 0.05).
// Measured: double 3.2e-16, long double 0, dd_real 2.2e-32.
TYPED_TEST(RecursiveClosedForm, MassOnTiltedRail) {
  using S = TypeParam;
  using std::abs;
  Robot r;
  r.root = "ground";
  r.links = {massless("ground"),
             body("slider", 2.5, {0.1, -0.2, 0.05}, {0.4, 0.5, 0.6}, {0.3, 0.2, 0.1, 0.01, 0.02, 0.03})};
  r.joints = {joint("rail", JointType::prismatic, "ground", "slider", {0.1, 0.2, 0.3}, {0, 0, 0.7},
                    {3, 0, 4}, 0.5)};
  eomtest::RecursiveDynamics<S> model(r);
  const S m(2.5), g(9.81), d(0.5), ez = S(4.0) / S(5.0);  // 4/5 in S, not the double 0.8
  const std::vector<S> q{S(0.625)}, qd{S(-1.5)}, u{S(4.0)};
  std::vector<S> M(1), out(1);
  double worst = 0;
  const auto check = [&](const S& got, const S& expected) {
    const double err = dbl(abs(got - expected) / abs(expected));
    worst = std::max(worst, err);
    EXPECT_LE(err, 8 * epsilon<S>()) << dbl(got) << " vs " << dbl(expected);
  };
  model.mass_matrix(q, M);
  check(M[0], m);
  model.bias_forces(q, qd, out);
  check(out[0], ez * m * g);
  model.forward_dynamics(q, qd, u, out);
  check(out[0], (u[0] - d * qd[0]) / m - ez * g);
  check(model.kinetic_energy(q, qd), S(0.5) * m * qd[0] * qd[0]);
  check(model.potential_energy(q), m * g * (S(0.3) + ez * q[0] + S(0.05)));
  std::printf("rail, %s: worst relative error %.2e\n", name<S>(), worst);
}

// The rpy convention: a rail along the joint frame's y axis, the frame turned by rpy =
// (r, p, y) = (0.3, −0.4, 0.5). With R = Rz·Ry·Rx the rail's world z component is
// R_zy = cos p sin r, so ∂V/∂q = m g cos p sin r (the order Rx·Ry·Rz gives a yaw-dependent
// R_zy and fails here: checked by mutating rpy_rotation).
// Measured: exact (0) in all three scalars (same operations as the closed form).
TYPED_TEST(RecursiveClosedForm, RailThroughRollPitchYaw) {
  using S = TypeParam;
  using std::abs, std::cos, std::sin;
  Robot r;
  r.root = "ground";
  r.links = {massless("ground"), body("slider", 2.0, {0, 0, 0}, {0, 0, 0}, {0.1, 0.1, 0.1, 0, 0, 0})};
  r.joints = {joint("rail", JointType::prismatic, "ground", "slider", {0, 0, 0}, {0.3, -0.4, 0.5},
                    {0, 1, 0})};
  eomtest::RecursiveDynamics<S> model(r);
  const std::vector<S> q{S(0.25)};
  std::vector<S> out(1);
  model.gravity_forces(q, out);
  const S expected = S(2.0) * S(9.81) * cos(S(-0.4)) * sin(S(0.3));
  const double err = dbl(abs(out[0] - expected) / abs(expected));
  std::printf("rail through rpy, %s: %.2e\n", name<S>(), err);
  EXPECT_LE(err, 8 * epsilon<S>());
}

// A horizontal arm turning about z (inertia J about the axis) with a slider moving along it
// (point-like mass m at radius r, I_zz = K about its centre): M = diag(J + K + m r², m),
// c = (2 m r ṙ θ̇, −m r θ̇²), no gravity torque (the motion is horizontal). This exercises the
// Coriolis and centripetal terms through a prismatic joint.
// Measured: exact (0) in all three scalars at this dyadic state.
TYPED_TEST(RecursiveClosedForm, ArmWithRadialSlider) {
  using S = TypeParam;
  Robot r;
  r.root = "ground";
  r.links = {massless("ground"), body("arm", 3.0, {0, 0, 0}, {0, 0, 0}, {0.5, 0.5, 0.75, 0, 0, 0}),
             body("slider", 1.25, {0, 0, 0}, {0, 0, 0}, {0.1, 0.2, 0.125, 0, 0, 0})};
  r.joints = {joint("theta", JointType::continuous, "ground", "arm", {0, 0, 0.5}, {0, 0, 0}, {0, 0, 1}),
              joint("r", JointType::prismatic, "arm", "slider", {0, 0, 0}, {0, 0, 0}, {1, 0, 0})};
  eomtest::RecursiveDynamics<S> model(r);
  const S J(0.75), K(0.125), m(1.25);
  const std::vector<S> q{S(1.25), S(0.375)}, qd{S(-0.5), S(1.5)};
  std::vector<S> M(4), out(2);
  model.mass_matrix(q, M);
  const double eM = normwise(M, std::vector<S>{J + K + m * q[1] * q[1], S(0.0), S(0.0), m});
  model.bias_forces(q, qd, out);
  const double eB = normwise(out, std::vector<S>{S(2.0) * m * q[1] * qd[1] * qd[0], -m * q[1] * qd[0] * qd[0]});
  EXPECT_LE(eM, 8 * epsilon<S>());
  EXPECT_LE(eB, 8 * epsilon<S>());
  std::printf("arm with slider, %s: M %.2e, c %.2e\n", name<S>(), eM, eB);
}

// ---- a fixed joint equals the one combined link -------------------------------------------
// Written independently of the header: rotations in double, parallel-axis theorem by hand.
using M3 = std::array<double, 9>;
M3 mat(const M3& a, const M3& b) {
  M3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[3 * i + j] += a[3 * i + k] * b[3 * k + j];
  return c;
}
M3 tr(const M3& a) { return {a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8]}; }
P3 apply(const M3& a, const P3& v) {
  return {a[0] * v[0] + a[1] * v[1] + a[2] * v[2], a[3] * v[0] + a[4] * v[1] + a[5] * v[2],
          a[6] * v[0] + a[7] * v[1] + a[8] * v[2]};
}
M3 rpy(const P3& a) {  // Rz(yaw) Ry(pitch) Rx(roll)
  const double cr = std::cos(a[0]), sr = std::sin(a[0]), cp = std::cos(a[1]), sp = std::sin(a[1]),
               cy = std::cos(a[2]), sy = std::sin(a[2]);
  const M3 Rx{1, 0, 0, 0, cr, -sr, 0, sr, cr}, Ry{cp, 0, sp, 0, 1, 0, -sp, 0, cp},
      Rz{cy, -sy, 0, sy, cy, 0, 0, 0, 1};
  return mat(Rz, mat(Ry, Rx));
}
M3 tensor(const Tensor& t) { return {t[0], t[3], t[4], t[3], t[1], t[5], t[4], t[5], t[2]}; }

// Robot A: j1 → l1 —fixed (xyz pf, yaw 0.7)→ l2, and j3 (in l2: xyz pj, yaw −0.4) → l3.
// Robot B: j1 → one link carrying l1 + l2 (mass centre and inertia combined by hand), and j3 in
// it at pf + Rz(0.7) pj with yaw 0.3. Both must give the same dynamics.
// Measured: max normwise difference 3.6e-16 over M, c + ∂V/∂q, q̈, T, V at 5 random states.
TEST(RecursiveFixedJoint, EqualsCombinedLink) {
  const double m1 = 1.2, m2 = 0.7;
  const P3 c1{0.05, -0.1, 0.2}, r1{0.2, -0.3, 0.4}, c2{0.1, 0.03, -0.05}, r2{-0.5, 0.6, 0.25};
  const Tensor T1{0.02, 0.03, 0.025, 0.002, -0.001, 0.0015}, T2{0.01, 0.008, 0.012, -0.001, 0.0005, 0.0008};
  const P3 pf{0.1, 0.2, -0.3}, pj{0.3, -0.1, 0.05};
  const Link l3 = body("l3", 0.9, {0.1, 0.1, -0.2}, {0.1, 0.2, 0.3}, {0.01, 0.02, 0.015, 0.001, 0.002, -0.001});
  const auto j1 = [](const char* child) {
    return joint("j1", JointType::revolute, "base", child, {0, 0.1, 0.5}, {0.3, 0.2, 0.1}, {0.3, 1, 0.2}, 0.1);
  };

  Robot a;
  a.root = "base";
  a.links = {massless("base"), body("l1", m1, c1, r1, T1), body("l2", m2, c2, r2, T2), l3};
  a.joints = {j1("l1"), joint("f", JointType::fixed, "l1", "l2", pf, {0, 0, 0.7}),
              joint("j3", JointType::revolute, "l2", "l3", pj, {0, 0, -0.4}, {1, 1, 0}, 0.2)};

  // Combined link in l1's frame.
  const M3 Rf = rpy({0, 0, 0.7});
  const P3 c2f = [&] { P3 x = apply(Rf, c2); for (int i = 0; i < 3; ++i) x[i] += pf[i]; return x; }();
  const double m = m1 + m2;
  P3 c;
  for (int i = 0; i < 3; ++i) c[i] = (m1 * c1[i] + m2 * c2f[i]) / m;
  const M3 R1 = rpy(r1), R2 = mat(Rf, rpy(r2));
  const M3 I1 = mat(R1, mat(tensor(T1), tr(R1))), I2 = mat(R2, mat(tensor(T2), tr(R2)));
  M3 I{};
  const auto shifted = [&](double mk, const P3& ck, const M3& Ik) {  // parallel axes to c
    const P3 dk{ck[0] - c[0], ck[1] - c[1], ck[2] - c[2]};
    const double d2 = dk[0] * dk[0] + dk[1] * dk[1] + dk[2] * dk[2];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) I[3 * i + j] += Ik[3 * i + j] + mk * ((i == j ? d2 : 0) - dk[i] * dk[j]);
  };
  shifted(m1, c1, I1);
  shifted(m2, c2f, I2);
  const P3 pj1 = [&] { P3 x = apply(Rf, pj); for (int i = 0; i < 3; ++i) x[i] += pf[i]; return x; }();
  Robot b;
  b.root = "base";
  b.links = {massless("base"), body("l12", m, c, {0, 0, 0}, {I[0], I[4], I[8], I[1], I[2], I[5]}), l3};
  b.joints = {j1("l12"), joint("j3", JointType::revolute, "l12", "l3", pj1, {0, 0, 0.3}, {1, 1, 0}, 0.2)};

  eomtest::RecursiveDynamics<double> A(a), B(b);
  ASSERT_EQ(A.nq(), 2);
  ASSERT_EQ(B.nq(), 2);
  std::mt19937 rng(7);
  double worst = 0;
  for (int k = 0; k < 5; ++k) {
    const auto q = uniform(rng, 2, 2.0), qd = uniform(rng, 2, 1.5), u = uniform(rng, 2, 1.0);
    std::vector<double> MA(4), MB(4), xA(2), xB(2);
    A.mass_matrix(q, MA);
    B.mass_matrix(q, MB);
    worst = std::max(worst, normwise(MA, MB));
    A.bias_forces(q, qd, xA);
    B.bias_forces(q, qd, xB);
    worst = std::max(worst, normwise(xA, xB));
    A.forward_dynamics(q, qd, u, xA);
    B.forward_dynamics(q, qd, u, xB);
    worst = std::max(worst, normwise(xA, xB));
    worst = std::max(worst, std::abs(A.kinetic_energy(q, qd) / B.kinetic_energy(q, qd) - 1));
    worst = std::max(worst, std::abs(A.potential_energy(q) - B.potential_energy(q)) /
                                std::abs(B.potential_energy(q)));
  }
  std::printf("fixed joint vs combined link: worst difference %.2e\n", worst);
  EXPECT_LE(worst, 1e-14);
}

}  // namespace
