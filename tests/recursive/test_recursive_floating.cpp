// Floating robots (Robot::floating, the free joint of tests/support/recursive_dynamics.hpp): the
// recursive algorithms against each other, and against a classical forward-kinematics pass written
// here link by link in world coordinates (ω, velocities and accelerations of points, no spatial
// algebra, the root's rotation from the quaternion sandwich q (0, x) q*): kinetic and potential
// energy, free fall, Newton–Euler for the whole robot, conservation of momentum, power balance.
#include "recursive_support.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <functional>
#include <map>

namespace {

using namespace rtest;
namespace rbd = eomtest::rbd;

template <class S>
using V3 = rbd::Vec3<S>;
template <class S>
using M3 = rbd::Mat3<S>;

template <class S>
struct Tol;  // tolerances (the measured figures are in each test's comment)
template <>
struct Tol<double> {
  static constexpr double tight = 1e-13;
  static constexpr double aba = 1e-12;  // ABA∘RNEA: κ(M) of the floating Panda-like arm
};
template <>
struct Tol<dd_real> {
  static constexpr double tight = 1e-28;
  static constexpr double aba = 1e-28;
};

template <class S>
class RecursiveFloating : public ::testing::Test {};
using Scalars = ::testing::Types<double, dd_real>;
TYPED_TEST_SUITE(RecursiveFloating, Scalars);

// ---- robots -----------------------------------------------------------------------------------
// One asymmetric body: mass centre off the root origin, non-diagonal inertia, non-zero inertial rpy.
Robot single_body() {
  Robot r;
  r.root = "hull";
  r.floating = true;
  r.links = {body("hull", 2.5, {0.13, -0.07, 0.21}, {0.4, -0.3, 0.7}, {0.11, 0.08, 0.06, 0.012, -0.007, 0.009})};
  return r;
}

// One rigid body made of three links: two fixed joints on the root (they ride on it), one of them
// to a massless link carrying a third.
Robot rigid_cluster() {
  Robot r;
  r.root = "core";
  r.floating = true;
  r.links = {body("core", 1.5, {0.02, 0.01, -0.03}, {0.2, 0.1, -0.4}, {0.03, 0.02, 0.025, 0.002, 0.001, -0.003}),
             massless("bracket"),
             body("pod", 0.75, {0.05, 0.1, 0.0}, {-0.3, 0.5, 0.2}, {0.004, 0.006, 0.005, -0.0005, 0.0003, 0.0004}),
             body("fin", 0.25, {0.0, 0.0, 0.15}, {0.0, 0.3, 0.0}, {0.002, 0.001, 0.0015, 0.0001, 0.0, 0.0002})};
  r.joints = {joint("bracket_mount", JointType::fixed, "core", "bracket", {0.3, -0.1, 0.05}, {0.3, -0.6, 0.9}),
              joint("pod_mount", JointType::fixed, "bracket", "pod", {0.0, 0.2, 0.1}, {1.1, 0.2, -0.4}),
              joint("fin_mount", JointType::fixed, "core", "fin", {-0.2, 0.0, 0.1}, {0.0, 0.0, 0.5})};
  return r;
}

Robot floating_branched() {
  Robot r = branched_robot();
  r.floating = true;
  return r;
}

// A 7-joint arm with Panda-like kinematics (all axes z, ±π/2 rolls between joints) and made-up
// inertials, a hand fixed to the last link; floating.
Robot panda_like() {
  const double h = 1.5707963267948966;
  Robot r;
  r.root = "link0";
  r.floating = true;
  r.links = {
      body("link0", 4.0, {-0.04, 0.0, 0.06}, {0, 0, 0}, {0.03, 0.04, 0.045, 0.001, 0.002, 0.0}),
      body("link1", 2.5, {0.0, -0.03, -0.07}, {0.1, 0, 0}, {0.07, 0.07, 0.01, -0.0001, 0.001, 0.002}),
      body("link2", 2.4, {0.0, -0.07, 0.03}, {0, 0.2, 0}, {0.008, 0.03, 0.03, 0.0002, 0.0001, -0.001}),
      body("link3", 2.2, {0.04, 0.03, -0.06}, {0, 0, 0.3}, {0.03, 0.03, 0.008, -0.004, -0.006, -0.004}),
      body("link4", 2.4, {-0.05, 0.1, 0.03}, {0.2, -0.1, 0}, {0.025, 0.02, 0.03, 0.007, -0.004, 0.003}),
      body("link5", 1.2, {0.0, 0.04, -0.11}, {0, 0, -0.2}, {0.035, 0.03, 0.007, -0.0002, 0.0002, -0.004}),
      body("link6", 1.7, {0.05, -0.01, 0.01}, {0.3, 0, 0.1}, {0.002, 0.004, 0.005, 0.0001, -0.001, 0.0003}),
      body("link7", 0.7, {0.01, 0.01, 0.08}, {0, 0.1, 0}, {0.01, 0.008, 0.005, -0.0004, 0.001, -0.0007}),
      body("hand", 0.73, {0.0, 0.0, 0.03}, {0, 0, 0}, {0.0025, 0.0005, 0.0024, 0.0, 0.0, 0.0}),
  };
  r.joints = {
      joint("joint1", JointType::revolute, "link0", "link1", {0, 0, 0.333}, {0, 0, 0}, {0, 0, 1}, 0.1),
      joint("joint2", JointType::revolute, "link1", "link2", {0, 0, 0}, {-h, 0, 0}, {0, 0, 1}, 0.1),
      joint("joint3", JointType::revolute, "link2", "link3", {0, -0.316, 0}, {h, 0, 0}, {0, 0, 1}, 0.05),
      joint("joint4", JointType::revolute, "link3", "link4", {0.0825, 0, 0}, {h, 0, 0}, {0, 0, 1}, 0.05),
      joint("joint5", JointType::revolute, "link4", "link5", {-0.0825, 0.384, 0}, {-h, 0, 0}, {0, 0, 1}, 0.02),
      joint("joint6", JointType::revolute, "link5", "link6", {0, 0, 0}, {h, 0, 0}, {0, 0, 1}, 0.02),
      joint("joint7", JointType::revolute, "link6", "link7", {0.088, 0, 0}, {h, 0, 0}, {0, 0, 1}, 0.0),
      joint("hand_mount", JointType::fixed, "link7", "hand", {0, 0, 0.107}, {0, 0, -0.7853981633974483}),
  };
  return r;
}

std::vector<Robot> robots() { return {single_body(), rigid_cluster(), floating_branched(), panda_like()}; }

// ---- states -----------------------------------------------------------------------------------
// q: root origin in [−1, 1]³, a random unit quaternion (normalized in S), joints in [−2, 2].
template <class S>
std::vector<S> random_q(std::mt19937& rng, int joints) {
  using std::sqrt;
  std::vector<S> q = convert<S>(uniform(rng, 7, 1.0));
  S n2(0.0);
  for (int i = 3; i < 7; ++i) n2 += q[i] * q[i];
  const S n = sqrt(n2);
  for (int i = 3; i < 7; ++i) q[i] /= n;
  for (const double x : uniform(rng, joints, 2.0)) q.push_back(S(x));
  return q;
}

template <class S>
std::vector<S> along(const std::vector<S>& x, const std::vector<S>& dx, const S& t) {
  std::vector<S> r(x);
  for (std::size_t i = 0; i < r.size(); ++i) r[i] += t * dx[i];
  return r;
}

// ---- classical forward kinematics, world coordinates ------------------------------------------
template <class S>
V3<S> sub(const V3<S>& a, const V3<S>& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}

template <class S>
using Quat = std::array<S, 4>;  // (w, x, y, z)

template <class S>
Quat<S> hamilton(const Quat<S>& a, const Quat<S>& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
          a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
          a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}

// The root's rotation by the sandwich: column k = vec(q ⊗ (0, e_k) ⊗ q*) (another route to the
// contract's R(q); equal for unit q).
template <class S>
M3<S> sandwich_rotation(const S& w, const S& x, const S& y, const S& z) {
  const Quat<S> q{w, x, y, z}, qc{w, -x, -y, -z};
  M3<S> R;
  for (int k = 0; k < 3; ++k) {
    Quat<S> e{S(0.0), S(0.0), S(0.0), S(0.0)};
    e[static_cast<std::size_t>(k + 1)] = S(1.0);
    const Quat<S> r = hamilton(hamilton(q, e), qc);
    for (int i = 0; i < 3; ++i) R[static_cast<std::size_t>(3 * i + k)] = r[static_cast<std::size_t>(i + 1)];
  }
  return R;
}

template <class S>
struct LinkMotion {  // world coordinates
  M3<S> R{};         // link axes
  V3<S> p{}, w{}, v{}, al{}, a{};  // origin; ω; velocity of the origin; ω̇; acceleration of the origin
};

// Every link's motion for (q, v, v̇) (v̇ empty: zero). Joints: child = parent · T(origin) ·
// motion(q); a revolute joint's child spins about the world axis e = R_J â, fixed in the parent,
// so d/dt(e q̇) = ω_λ × e q̇ + e q̈; a prismatic joint slides its origin along e.
template <class S>
std::vector<LinkMotion<S>> link_motion(const Robot& r, const std::vector<S>& q, const std::vector<S>& v,
                                       const std::vector<S>& vd) {
  using std::sqrt;
  const auto cross = [](const V3<S>& a, const V3<S>& b) { return rbd::cross(a, b); };
  const auto acc = [&](std::size_t i) { return vd.empty() ? S(0.0) : vd[i]; };
  std::map<std::string, std::size_t> index;
  for (std::size_t l = 0; l < r.links.size(); ++l) index[r.links[l].name] = l;
  std::vector<LinkMotion<S>> m(r.links.size());
  std::vector<bool> done(r.links.size(), false);
  LinkMotion<S>& root = m[index.at(r.root)];
  root.R = rbd::identity3<S>();
  root.p = root.w = root.v = root.al = root.a = V3<S>{S(0.0), S(0.0), S(0.0)};
  if (r.floating) {
    root.R = sandwich_rotation(q[3], q[4], q[5], q[6]);
    root.p = {q[0], q[1], q[2]};
    root.v = {v[0], v[1], v[2]};
    root.w = rbd::mul(root.R, V3<S>{v[3], v[4], v[5]});
    root.a = {acc(0), acc(1), acc(2)};
    // ω = R ω_b: ω̇ = R ω̇_b + R (ω_b × ω_b) = R ω̇_b
    root.al = rbd::mul(root.R, V3<S>{acc(3), acc(4), acc(5)});
  }
  done[index.at(r.root)] = true;
  std::vector<std::size_t> coordinate(r.joints.size(), 0);
  std::size_t k = r.floating ? 6 : 0;  // v index; q index = k + 1 when floating
  for (std::size_t j = 0; j < r.joints.size(); ++j)
    if (r.joints[j].type != JointType::fixed) coordinate[j] = k++;
  const std::size_t dq = r.floating ? 1 : 0;
  for (bool progress = true; progress;) {
    progress = false;
    for (std::size_t j = 0; j < r.joints.size(); ++j) {
      const Joint& jt = r.joints[j];
      const std::size_t pi = index.at(jt.parent), ci = index.at(jt.child);
      if (!done[pi] || done[ci]) continue;
      const LinkMotion<S>& P = m[pi];
      LinkMotion<S>& C = m[ci];
      const M3<S> RJ = rbd::mul(P.R, rbd::rpy_rotation<S>(jt.origin.rpy));
      const V3<S> pJ = rbd::add(P.p, rbd::mul(P.R, V3<S>{S(jt.origin.xyz[0]), S(jt.origin.xyz[1]), S(jt.origin.xyz[2])}));
      V3<S> ax{S(jt.axis[0]), S(jt.axis[1]), S(jt.axis[2])};
      ax = rbd::scale(S(1.0) / sqrt(rbd::dot3(ax, ax)), ax);
      const V3<S> e = rbd::mul(RJ, ax);
      S x(0.0), xd(0.0), xdd(0.0);
      if (jt.type != JointType::fixed) {
        x = q[coordinate[j] + dq];
        xd = v[coordinate[j]];
        xdd = acc(coordinate[j]);
      }
      C.R = RJ;
      C.p = pJ;
      C.w = P.w;
      C.al = P.al;
      V3<S> rel_v{S(0.0), S(0.0), S(0.0)}, rel_a = rel_v;  // the child origin's motion in the parent
      if (jt.type == JointType::prismatic) {
        C.p = rbd::add(pJ, rbd::scale(x, e));
        rel_v = rbd::scale(xd, e);
        rel_a = rbd::add(rbd::scale(xdd, e), rbd::scale(S(2.0) * xd, cross(P.w, e)));  // + Coriolis
      } else if (jt.type != JointType::fixed) {
        C.R = rbd::mul(RJ, rbd::axis_angle(ax, x));
        C.w = rbd::add(P.w, rbd::scale(xd, e));
        C.al = rbd::add(rbd::add(P.al, rbd::scale(xdd, e)), rbd::scale(xd, cross(P.w, e)));
      }
      const V3<S> d = sub(C.p, P.p);
      C.v = rbd::add(rbd::add(P.v, cross(P.w, d)), rel_v);
      C.a = rbd::add(rbd::add(rbd::add(P.a, cross(P.al, d)), cross(P.w, cross(P.w, d))), rel_a);
      done[ci] = true;
      progress = true;
    }
  }
  return m;
}

// Sums over the links with mass, world axes: energies, momenta (about the world origin), their
// rates, and the external wrench the motion needs (about the root origin).
template <class S>
struct Totals {
  S T{0.0}, V{0.0}, mass{0.0};
  V3<S> com{}, P{}, H{}, Pdot{}, Hdot{}, F{}, N{};
  double scale_Pdot = 0, scale_Hdot = 0;  // magnitudes of the terms (for relative errors)
};

template <class S>
double norm(const V3<S>& a) {
  using std::sqrt;
  return dbl(sqrt(rbd::dot3(a, a)));
}

template <class S>
Totals<S> totals(const Robot& r, const std::vector<LinkMotion<S>>& m, double g) {
  Totals<S> t;
  const V3<S> zero{S(0.0), S(0.0), S(0.0)};
  t.com = t.P = t.H = t.Pdot = t.Hdot = t.F = t.N = zero;
  const V3<S> ez{S(0.0), S(0.0), S(1.0)};
  V3<S> root_p = zero;
  for (std::size_t l = 0; l < r.links.size(); ++l)
    if (r.links[l].name == r.root) root_p = m[l].p;
  for (std::size_t l = 0; l < r.links.size(); ++l) {
    const Link& link = r.links[l];
    if (!link.has_inertial) continue;
    const LinkMotion<S>& L = m[l];
    const S mass(link.inertial.mass);
    const V3<S> cl{S(link.inertial.origin.xyz[0]), S(link.inertial.origin.xyz[1]), S(link.inertial.origin.xyz[2])};
    const V3<S> d = rbd::mul(L.R, cl);
    const V3<S> c = rbd::add(L.p, d);
    const V3<S> vc = rbd::add(L.v, rbd::cross(L.w, d));
    const V3<S> ac = rbd::add(rbd::add(L.a, rbd::cross(L.al, d)), rbd::cross(L.w, rbd::cross(L.w, d)));
    const auto& in = link.inertial.inertia;
    const M3<S> local{S(in[0]), S(in[3]), S(in[4]), S(in[3]), S(in[1]), S(in[5]), S(in[4]), S(in[5]), S(in[2])};
    const M3<S> Rc = rbd::mul(L.R, rbd::rpy_rotation<S>(link.inertial.origin.rpy));
    const M3<S> J = rbd::mul(Rc, rbd::mul(local, rbd::transpose(Rc)));
    const V3<S> Jw = rbd::mul(J, L.w);
    const V3<S> Hc_dot = rbd::add(rbd::mul(J, L.al), rbd::cross(L.w, Jw));  // d/dt (J ω)
    t.T += S(0.5) * (mass * rbd::dot3(vc, vc) + rbd::dot3(L.w, Jw));
    t.V += S(g) * mass * c[2];
    t.mass += mass;
    t.com = rbd::add(t.com, rbd::scale(mass, c));
    t.P = rbd::add(t.P, rbd::scale(mass, vc));
    t.H = rbd::add(t.H, rbd::add(rbd::scale(mass, rbd::cross(c, vc)), Jw));
    const V3<S> mac = rbd::scale(mass, ac);
    t.Pdot = rbd::add(t.Pdot, mac);
    t.Hdot = rbd::add(t.Hdot, rbd::add(rbd::cross(c, mac), Hc_dot));
    // (with ω²·1 m beside a_c: a lone body in free flight has a_c = 0 to rounding)
    const double w2 = dbl(rbd::dot3(L.w, L.w)), m_d = dbl(mass);
    t.scale_Pdot += norm(mac) + m_d * w2;
    t.scale_Hdot += norm(rbd::cross(c, mac)) + norm(Hc_dot) + norm(Jw) * norm(L.w) + m_d * (1 + norm(c)) * w2;
    // Newton–Euler: the wrench on the link is m(a_c + g e_z) at c plus d/dt(J ω)
    const V3<S> f = rbd::scale(mass, rbd::add(ac, rbd::scale(S(g), ez)));
    t.F = rbd::add(t.F, f);
    t.N = rbd::add(t.N, rbd::add(rbd::cross(sub(c, root_p), f), Hc_dot));
  }
  t.com = rbd::scale(S(1.0) / t.mass, t.com);
  return t;
}

template <class S>
M3<S> root_rotation(const Robot& r, const std::vector<LinkMotion<S>>& m) {
  for (std::size_t l = 0; l < r.links.size(); ++l)
    if (r.links[l].name == r.root) return m[l].R;
  return rbd::identity3<S>();
}

template <class S>
double max_abs(const V3<S>& a) {
  using std::abs;
  return std::max({dbl(abs(a[0])), dbl(abs(a[1])), dbl(abs(a[2]))});
}

// Fourth-order central differences in dd_real, h = 1e-6: truncation ~h⁴ = 1e-24, rounding
// ~1e-32/h = 1e-26, so good to ~1e-22 relative to O(1) quantities (a smaller h where the fifth
// derivative is large).
dd_real derivative(const std::function<dd_real(dd_real)>& f, double step = 1e-6) {
  const dd_real h(step);
  return (f(-2.0 * h) - 8.0 * f(-h) + 8.0 * f(h) - f(2.0 * h)) / (12.0 * h);
}
using DD = std::vector<dd_real>;

// ---- tests ------------------------------------------------------------------------------------
TEST(RecursiveFreeJoint, Sizes) {
  const std::vector<std::pair<int, int>> sizes{{7, 6}, {7, 6}, {13, 12}, {14, 13}};
  const auto rs = robots();
  for (std::size_t k = 0; k < rs.size(); ++k) {
    eomtest::RecursiveDynamics<double> model(rs[k]);
    EXPECT_TRUE(model.floating());
    EXPECT_EQ(model.nq(), sizes[k].first);
    EXPECT_EQ(model.nv(), sizes[k].second);
    ASSERT_EQ(model.damping().size(), static_cast<std::size_t>(model.nv()));
    for (int i = 0; i < 6; ++i) EXPECT_EQ(model.damping()[static_cast<std::size_t>(i)], 0.0);
  }
  eomtest::RecursiveDynamics<double> fixed(branched_robot());
  EXPECT_FALSE(fixed.floating());
  EXPECT_EQ(fixed.nq(), fixed.nv());
  EXPECT_EQ(floating_branched().joints.size(), branched_robot().joints.size());
  eomtest::RecursiveDynamics<double> fl(floating_branched());
  EXPECT_EQ(fl.coordinate_names(), fixed.coordinate_names());
  std::vector<double> q(13, 0.0), v(12, 0.0), wrong(13, 0.0), M(12 * 12);
  q[3] = 1;
  EXPECT_THROW(fl.kinetic_energy(q, wrong), std::invalid_argument);
  EXPECT_THROW(fl.kinetic_energy(v, v), std::invalid_argument);
  EXPECT_NO_THROW(fl.kinetic_energy(q, v));
  EXPECT_NO_THROW(fl.mass_matrix(q, M));
}

// The test's own kinematics against dd_real differences along q(t) = q + t G(q) v (G from
// configuration_rate), v(t) = v + t v̇: every link's origin, axes and angular velocity,
// ṗ = v, Ṙ = ω× R, v̇ = a, ω̇ = α. This ties the helper (and so the tests below) to the contract's
// meaning of v: ω in root axes, the linear part the world velocity of the root origin.
// Measured (worst, relative to the largest derivative): 1.1e-23.
TEST(RecursiveFreeJoint, KinematicsHelperAgainstDifferences) {
  double worst = 0;
  for (const Robot& r : robots()) {
    eomtest::RecursiveDynamics<dd_real> model(r);
    const int nv = model.nv(), nj = nv - 6;
    std::mt19937 rng(31);
    for (int s = 0; s < 3; ++s) {
      const DD q = random_q<dd_real>(rng, nj), v = convert<dd_real>(uniform(rng, nv, 1.5)),
               vd = convert<dd_real>(uniform(rng, nv, 3.0));
      DD qd(q.size());
      model.configuration_rate(q, v, qd);
      const auto m = link_motion(r, q, v, vd);
      for (std::size_t l = 0; l < r.links.size(); ++l) {
        const auto at = [&](const dd_real& t) { return link_motion(r, along(q, qd, t), along(v, vd, t), DD{})[l]; };
        std::vector<dd_real> got, expected;
        const M3<dd_real> wR = rbd::mul(rbd::skew(m[l].w), m[l].R);
        for (int i = 0; i < 3; ++i) {
          const auto ui = static_cast<std::size_t>(i);
          got.push_back(derivative([&](dd_real t) { return at(t).p[ui]; }));
          expected.push_back(m[l].v[ui]);
          got.push_back(derivative([&](dd_real t) { return at(t).v[ui]; }));
          expected.push_back(m[l].a[ui]);
          got.push_back(derivative([&](dd_real t) { return at(t).w[ui]; }));
          expected.push_back(m[l].al[ui]);
          for (int c = 0; c < 3; ++c) {
            const auto e = static_cast<std::size_t>(3 * i + c);
            got.push_back(derivative([&](dd_real t) { return at(t).R[e]; }));
            expected.push_back(wR[e]);
          }
        }
        worst = std::max(worst, normwise(got, expected));
      }
    }
  }
  std::printf("kinematics helper vs differences: %.2e\n", worst);
  EXPECT_LE(worst, 1e-20);
}

// 1. Column j of M (CRBA) = RNEA(q, 0, e_j) − RNEA(q, 0, 0); M exactly symmetric and positive
// definite; ABA(q, v, RNEA(q, v, v̇)) = v̇; the joint block of M is the fixed-root M (it does not
// depend on the root's pose), and with the root at rest, unaccelerated and upright (q = identity)
// the joint rows of τ are the fixed robot's τ.
// Measured (worst over the four robots): M vs RNEA columns double 4.9e-16, dd_real 4.0e-32;
// ABA∘RNEA double 4.8e-14, dd_real 6.5e-30; joint block / fixed τ: equal (the same operations).
TYPED_TEST(RecursiveFloating, MassMatrixAndInverses) {
  using S = TypeParam;
  double worst_cols = 0, worst_aba = 0, worst_fixed = 0;
  for (const Robot& r : robots()) {
    eomtest::RecursiveDynamics<S> model(r);
    Robot fixed_robot = r;
    fixed_robot.floating = false;
    eomtest::RecursiveDynamics<S> fixed(fixed_robot);
    const int nv = model.nv(), nj = nv - 6;
    const auto n = static_cast<std::size_t>(nv);
    std::mt19937 rng(7);
    for (int s = 0; s < 8; ++s) {
      const auto q = random_q<S>(rng, nj);
      const auto v = convert<S>(uniform(rng, nv, 1.5)), vd = convert<S>(uniform(rng, nv, 3.0));
      std::vector<S> M(n * n), g(n), col(n), zero(n, S(0.0)), e(n);
      model.mass_matrix(q, M);
      model.gravity_forces(q, g);
      for (std::size_t j = 0; j < n; ++j) {
        e.assign(n, S(0.0));
        e[j] = S(1.0);
        model.inverse_dynamics(q, zero, e, col);
        double err = 0, scale = 0;
        for (std::size_t i = 0; i < n; ++i) {
          EXPECT_EQ(dbl(M[i + n * j]), dbl(M[j + n * i]));
          err = std::max(err, std::abs(dbl(M[i + n * j] - (col[i] - g[i]))));
          scale = std::max(scale, std::abs(dbl(col[i])));
        }
        worst_cols = std::max(worst_cols, err / scale);
      }
      std::vector<double> L(n * n, 0.0);  // positive definite: Cholesky in double succeeds
      for (std::size_t j = 0; j < n; ++j) {
        double d = dbl(M[j + n * j]);
        for (std::size_t p = 0; p < j; ++p) d -= L[j + n * p] * L[j + n * p];
        ASSERT_GT(d, 0.0) << "M not positive definite";
        L[j + n * j] = std::sqrt(d);
        for (std::size_t i = j + 1; i < n; ++i) {
          double t = dbl(M[i + n * j]);
          for (std::size_t p = 0; p < j; ++p) t -= L[i + n * p] * L[j + n * p];
          L[i + n * j] = t / L[j + n * j];
        }
      }
      std::vector<S> tau(n), back(n);
      model.inverse_dynamics(q, v, vd, tau);
      model.articulated_body(q, v, tau, back);
      worst_aba = std::max(worst_aba, normwise(back, vd));
      if (nj == 0) continue;
      const auto m = static_cast<std::size_t>(nj);
      const std::vector<S> qj(q.begin() + 7, q.end()), vj(v.begin() + 6, v.end()), aj(vd.begin() + 6, vd.end());
      std::vector<S> Mf(m * m), block(m * m);
      fixed.mass_matrix(qj, Mf);
      for (std::size_t i = 0; i < m; ++i)
        for (std::size_t j = 0; j < m; ++j) block[i + m * j] = M[6 + i + n * (6 + j)];
      worst_fixed = std::max(worst_fixed, normwise(block, Mf));
      std::vector<S> q0(q), v0(v), a0(vd), tf(m);
      q0[0] = S(0.5), q0[1] = S(-0.25), q0[2] = S(2.0), q0[3] = S(1.0), q0[4] = q0[5] = q0[6] = S(0.0);
      for (int i = 0; i < 6; ++i) v0[static_cast<std::size_t>(i)] = a0[static_cast<std::size_t>(i)] = S(0.0);
      model.inverse_dynamics(q0, v0, a0, tau);
      fixed.inverse_dynamics(qj, vj, aj, tf);
      worst_fixed = std::max(worst_fixed, normwise(std::vector<S>(tau.begin() + 6, tau.end()), tf));
    }
  }
  std::printf("M vs RNEA columns %.2e, ABA(RNEA) %.2e, joint block vs fixed root %.2e\n", worst_cols,
              worst_aba, worst_fixed);
  EXPECT_LE(worst_cols, Tol<S>::tight);
  EXPECT_LE(worst_aba, Tol<S>::aba);
  EXPECT_LE(worst_fixed, Tol<S>::tight);
}

// 2. ½ vᵀ M v (CRBA) = kinetic_energy(q, v) = Σ ½(m|v_c|² + ωᵀ J ω) from the test's kinematics;
// potential_energy(q) = g Σ m z_c (every link moves, the root's own and those fixed to it too).
// Measured: double 1.6e-15, dd_real 1.9e-31.
TYPED_TEST(RecursiveFloating, EnergiesFromLinkVelocities) {
  using S = TypeParam;
  using std::abs;
  double worst = 0;
  for (const Robot& r : robots()) {
    eomtest::RecursiveDynamics<S> model(r);
    const int nv = model.nv();
    const auto n = static_cast<std::size_t>(nv);
    std::mt19937 rng(13);
    for (int s = 0; s < 10; ++s) {
      const auto q = random_q<S>(rng, nv - 6);
      const auto v = convert<S>(uniform(rng, nv, 1.5));
      std::vector<S> M(n * n);
      model.mass_matrix(q, M);
      S vMv(0.0);
      for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j) vMv += v[i] * M[i + n * j] * v[j];
      const Totals<S> t = totals(r, link_motion(r, q, v, {}), 9.81);
      worst = std::max(worst, normwise(std::vector<S>{S(0.5) * vMv, model.kinetic_energy(q, v)},
                                       std::vector<S>{t.T, t.T}));
      // V: relative to g Σ m |z_c| would be fairer, but the root is in [−1, 1]: use m g
      worst = std::max(worst, dbl(abs(model.potential_energy(q) - t.V) / (S(9.81) * t.mass)));
    }
  }
  std::printf("1/2 v'Mv and T vs link velocities, V vs link heights: %.2e\n", worst);
  EXPECT_LE(worst, Tol<S>::tight);
}

// 3. Free fall: with no input (the joint damping acts, but it is internal) the mass centre
// falls at (0, 0, −g) whatever the state, and the angular momentum about the world origin changes
// at the moment of gravity about it: Ḣ_O = c × (−m g e_z).
// Measured: a_c + g e_z double 3.6e-16 (relative to g), dd_real 2.0e-32; Ḣ_O double 1.6e-16,
// dd_real 1.7e-32 (relative to the terms' magnitudes).
TYPED_TEST(RecursiveFloating, FreeFall) {
  using S = TypeParam;
  double worst_P = 0, worst_H = 0;
  for (const Robot& r : robots()) {
    eomtest::RecursiveDynamics<S> model(r);
    const int nv = model.nv();
    std::mt19937 rng(17);
    for (int s = 0; s < 10; ++s) {
      const auto q = random_q<S>(rng, nv - 6);
      const auto v = convert<S>(uniform(rng, nv, 1.5));
      const std::vector<S> u(static_cast<std::size_t>(nv), S(0.0));
      std::vector<S> vd(static_cast<std::size_t>(nv));
      model.forward_dynamics(q, v, u, vd);
      const Totals<S> t = totals(r, link_motion(r, q, v, vd), 9.81);
      const V3<S> ac = rbd::scale(S(1.0) / t.mass, t.Pdot);
      worst_P = std::max(worst_P, max_abs(V3<S>{ac[0], ac[1], ac[2] + S(9.81)}) / 9.81);
      const V3<S> moment = rbd::cross(t.com, V3<S>{S(0.0), S(0.0), -S(9.81) * t.mass});
      worst_H = std::max(worst_H, max_abs(sub(t.Hdot, moment)) / (t.scale_Hdot + norm(moment)));
    }
  }
  std::printf("free fall: mass centre acceleration %.2e, angular momentum rate %.2e\n", worst_P, worst_H);
  EXPECT_LE(worst_P, Tol<S>::tight);
  EXPECT_LE(worst_H, Tol<S>::tight);
}

// 4. Power: d/dt (T + V) = τ·v − Σ d v² along the motion, for random τ (the free rows too):
// T + V from the test's kinematics, differenced in dd_real along q(t) = q + t G(q) v,
// v(t) = v + t v̇ with v̇ from forward_dynamics. Catches a free-row force in the wrong axes (the
// input power would be wrong) as well as any error in the ABA. h = 1e-7: the Panda-like wrist's
// large v̇ put the h⁴ truncation at 1.7e-21 with h = 1e-6.
// Measured: 6.6e-25 (relative to Σ|τᵢvᵢ| + Σ d v²).
TEST(RecursiveFreeJoint, PowerBalance) {
  double worst = 0;
  for (const Robot& r : robots()) {
    eomtest::RecursiveDynamics<dd_real> model(r);
    const int nv = model.nv();
    const auto n = static_cast<std::size_t>(nv);
    std::mt19937 rng(19);
    for (int s = 0; s < 5; ++s) {
      const DD q = random_q<dd_real>(rng, nv - 6), v = convert<dd_real>(uniform(rng, nv, 1.5)),
               u = convert<dd_real>(uniform(rng, nv, 5.0));
      DD vd(n), qd(q.size());
      model.forward_dynamics(q, v, u, vd);
      model.configuration_rate(q, v, qd);
      const dd_real dE = derivative([&](dd_real t) {
        const Totals<dd_real> tt = totals(r, link_motion(r, along(q, qd, t), along(v, vd, t), DD{}), 9.81);
        return tt.T + tt.V;
      }, 1e-7);
      dd_real power(0.0), scale(0.0);
      for (std::size_t i = 0; i < n; ++i) {
        power += v[i] * (u[i] - model.damping()[i] * v[i]);
        scale += abs(v[i] * u[i]) + model.damping()[i] * v[i] * v[i];
      }
      worst = std::max(worst, to_double(abs(dE - power) / scale));
    }
  }
  std::printf("power balance (dd_real differences): %.2e\n", worst);
  EXPECT_LE(worst, 1e-20);
}

// 5. The free rows of τ are the external wrench: RNEA(q, v, v̇) rows 0-2 = Σ m(a_c + g e_z) (world
// axes), rows 3-5 = Rᵀ Σ [(c − p_root) × m(a_c + g e_z) + d/dt(J ω)] (about the root origin, root
// axes), Newton–Euler for all links from the test's kinematics. And the converse for the single
// body: a pure world force F at the root origin, τ = [F; 0], gives m(a_c + g e_z) = F and
// d/dt(J ω) = (p_root − c) × F.
// Measured: RNEA double 1.1e-15, dd_real 1.0e-31; pure force double 1.0e-15, dd_real 4.3e-31.
TYPED_TEST(RecursiveFloating, FreeRowsAreTheExternalWrench) {
  using S = TypeParam;
  double worst = 0, worst_force = 0;
  for (const Robot& r : robots()) {
    eomtest::RecursiveDynamics<S> model(r);
    const int nv = model.nv();
    const auto n = static_cast<std::size_t>(nv);
    std::mt19937 rng(23);
    for (int s = 0; s < 10; ++s) {
      const auto q = random_q<S>(rng, nv - 6);
      const auto v = convert<S>(uniform(rng, nv, 1.5)), vd = convert<S>(uniform(rng, nv, 3.0));
      std::vector<S> tau(n);
      model.inverse_dynamics(q, v, vd, tau);
      const auto m = link_motion(r, q, v, vd);
      const Totals<S> t = totals(r, m, 9.81);
      const V3<S> Nb = rbd::mul_t(root_rotation(r, m), t.N);
      worst = std::max(worst, normwise(std::vector<S>(tau.begin(), tau.begin() + 6),
                                       std::vector<S>{t.F[0], t.F[1], t.F[2], Nb[0], Nb[1], Nb[2]}));
    }
  }
  const Robot r = single_body();
  eomtest::RecursiveDynamics<S> model(r);
  std::mt19937 rng(29);
  for (int s = 0; s < 10; ++s) {
    const auto q = random_q<S>(rng, 0);
    const auto v = convert<S>(uniform(rng, 6, 1.5)), F = convert<S>(uniform(rng, 3, 20.0));
    const std::vector<S> tau{F[0], F[1], F[2], S(0.0), S(0.0), S(0.0)};
    std::vector<S> vd(6);
    model.forward_dynamics(q, v, tau, vd);
    const Totals<S> t = totals(r, link_motion(r, q, v, vd), 9.81);
    // t.F = m(a_c + g e_z); t.N = (c − p) × t.F + d/dt(J ω) should be 0
    worst_force = std::max(worst_force, normwise(std::vector<S>{t.F[0], t.F[1], t.F[2], t.N[0], t.N[1], t.N[2]},
                                                 std::vector<S>{F[0], F[1], F[2], S(0.0), S(0.0), S(0.0)}));
  }
  std::printf("free rows vs Newton-Euler %.2e, pure world force %.2e\n", worst, worst_force);
  EXPECT_LE(worst, Tol<S>::tight);
  EXPECT_LE(worst_force, Tol<S>::tight);
}

// 6. Without gravity and input the total linear momentum and the angular momentum about the world
// origin are constant (the joint damping is internal): analytically, Σ m a_c = 0 and
// Σ [m c × a_c + d/dt(J ω)] = 0 at the state; and by dd_real differences of P and H_O (computed
// from the link velocities) along the motion.
// Measured: analytic double 3.3e-16, dd_real 5.8e-32 (relative to the terms' magnitudes, ω²·1 m
// among them); differences 2.7e-24.
TYPED_TEST(RecursiveFloating, MomentumConservedWithoutGravity) {
  using S = TypeParam;
  double worst = 0, worst_fd = 0;
  for (const Robot& r : robots()) {
    eomtest::RecursiveDynamics<S> model(r, 0.0);
    const int nv = model.nv();
    std::mt19937 rng(37);
    for (int s = 0; s < 10; ++s) {
      const auto q = random_q<S>(rng, nv - 6);
      const auto v = convert<S>(uniform(rng, nv, 1.5));
      const std::vector<S> u(static_cast<std::size_t>(nv), S(0.0));
      std::vector<S> vd(static_cast<std::size_t>(nv)), qd(q.size());
      model.forward_dynamics(q, v, u, vd);
      const Totals<S> t = totals(r, link_motion(r, q, v, vd), 0.0);
      worst = std::max(worst, max_abs(t.Pdot) / t.scale_Pdot);
      worst = std::max(worst, max_abs(t.Hdot) / t.scale_Hdot);
      if constexpr (std::is_same_v<S, dd_real>) {
        if (s >= 3) continue;
        model.configuration_rate(q, v, qd);
        for (int i = 0; i < 6; ++i) {
          const auto ui = static_cast<std::size_t>(i % 3);
          const dd_real rate = derivative([&](dd_real h) {
            const Totals<dd_real> th = totals(r, link_motion(r, along(q, qd, h), along(v, vd, h), DD{}), 0.0);
            return i < 3 ? th.P[ui] : th.H[ui];
          });
          worst_fd = std::max(worst_fd, to_double(abs(rate)) / (i < 3 ? t.scale_Pdot : t.scale_Hdot));
        }
      }
    }
  }
  std::printf("momentum rates without gravity: analytic %.2e, differences %.2e\n", worst, worst_fd);
  EXPECT_LE(worst, Tol<S>::tight);
  EXPECT_LE(worst_fd, 1e-20);
}

// q̇ = G(q) v: positions and joints copied, the quaternion rate ½ q ⊗ (0, ω) (tangent to the unit
// sphere: q·q̇ = 0); with the root fixed, q̇ = v.
TEST(RecursiveFreeJoint, ConfigurationRate) {
  eomtest::RecursiveDynamics<double> model(floating_branched());
  const std::vector<double> q{0.1, 0.2, 0.3, 0.5, 0.5, -0.5, 0.5, 1, 2, 3, 4, 5, 6};
  const std::vector<double> v{1, 2, 3, 0.5, -1.0, 2.0, 7, 8, 9, 10, 11, 12};
  std::vector<double> qd(13);
  model.configuration_rate(q, v, qd);
  // ½ (0.5, 0.5, −0.5, 0.5) ⊗ (0, 0.5, −1, 2)
  const std::vector<double> expected{1, 2, 3, -0.875, -0.125, -0.625, 0.375, 7, 8, 9, 10, 11, 12};
  EXPECT_EQ(qd, expected);
  double dot = 0;
  for (int i = 3; i < 7; ++i) dot += q[static_cast<std::size_t>(i)] * qd[static_cast<std::size_t>(i)];
  EXPECT_EQ(dot, 0.0);
  eomtest::RecursiveDynamics<double> fixed(branched_robot());
  const std::vector<double> qf(6, 0.5), vf{1, 2, 3, 4, 5, 6};
  std::vector<double> qdf(6);
  fixed.configuration_rate(qf, vf, qdf);
  EXPECT_EQ(qdf, vf);
}

}  // namespace
