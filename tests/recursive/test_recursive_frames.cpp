// Task space of the recursive implementation (tests/support/recursive_dynamics.hpp: frame
// placements, Jacobians, biases J̇v, the mass centre, its Jacobian, the centroidal momentum matrix)
// on the bundled URDF robots (Panda, UR5, the branched robot fixed; Solo12, Panda and the branched
// robot floating), in dd_real, against what they are defined by: differences of the placements
// along each velocity direction (the free joint moved by the exponential map), differences of
// J v along the motion at v̇ = 0, the mass centre and momenta summed link by link here.
#include "recursive_support.hpp"

#include <eomgen/urdf.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>

namespace {

using namespace rtest;
namespace rbd = eomtest::rbd;
using DD = std::vector<dd_real>;
using Model = eomtest::RecursiveDynamics<dd_real>;
using V3 = rbd::Vec3<dd_real>;
using M3 = rbd::Mat3<dd_real>;  // row-major, as rbd's

struct Case {
  const char* file;
  bool floating;
};
const Case cases[] = {{"panda.urdf", false},    {"ur5.urdf", false},  {"branched.urdf", false},
                      {"solo12.urdf", true},    {"panda.urdf", true}, {"branched.urdf", true}};

Robot load(const Case& c) { return eom::urdf::read(std::string(EOM_ROBOTS_DIR) + "/" + c.file, c.floating); }
std::string label(const Case& c) { return std::string(c.file) + (c.floating ? " (floating)" : ""); }

// ---- states and the tangent-space move ----------------------------------------------------------
// q: root origin in [−1, 1]³ and a random unit quaternion (normalized in dd_real) when floating;
// joints in [−2, 2] (the prismatic one too: metres). v in [−1.5, 1.5].
DD random_q(std::mt19937& rng, const Model& m) {
  using std::sqrt;
  const int joints = m.nq() - (m.floating() ? 7 : 0);
  DD q;
  if (m.floating()) {
    q = convert<dd_real>(uniform(rng, 7, 1.0));
    dd_real n2(0.0);
    for (int i = 3; i < 7; ++i) n2 += q[i] * q[i];
    const dd_real n = sqrt(n2);
    for (int i = 3; i < 7; ++i) q[i] /= n;
  }
  for (const double x : uniform(rng, joints, 2.0)) q.push_back(dd_real(x));
  return q;
}

// q ⊕ t d for d in v-space: the free joint by the exponential map (position + t d_lin, quaternion
// q ⊗ exp(t ω/2) for the body-axes rotation ω = d_ang), joints + t d. With d = v held constant
// this is the motion at v̇ = 0 exactly (constant world velocity, constant body-axes ω).
DD displace(const Model& m, const DD& q, const DD& d, const dd_real& t) {
  using std::cos, std::sin, std::sqrt;
  DD r(q);
  if (!m.floating()) {
    for (std::size_t i = 0; i < r.size(); ++i) r[i] += t * d[i];
    return r;
  }
  for (std::size_t i = 0; i < 3; ++i) r[i] += t * d[i];
  const dd_real n = sqrt(d[3] * d[3] + d[4] * d[4] + d[5] * d[5]);
  if (n > dd_real(0.0)) {
    const dd_real c = cos(0.5 * t * n), s = sin(0.5 * t * n) / n;
    const std::array<dd_real, 4> a{q[3], q[4], q[5], q[6]}, e{c, s * d[3], s * d[4], s * d[5]};
    r[3] = a[0] * e[0] - a[1] * e[1] - a[2] * e[2] - a[3] * e[3];
    r[4] = a[0] * e[1] + a[1] * e[0] + a[2] * e[3] - a[3] * e[2];
    r[5] = a[0] * e[2] - a[1] * e[3] + a[2] * e[0] + a[3] * e[1];
    r[6] = a[0] * e[3] + a[1] * e[2] - a[2] * e[1] + a[3] * e[0];
  }
  for (std::size_t i = 6; i < d.size(); ++i) r[i + 1] += t * d[i];
  return r;
}

DD unit(const Model& m, int k) {
  DD e(static_cast<std::size_t>(m.nv()), dd_real(0.0));
  e[static_cast<std::size_t>(k)] = dd_real(1.0);
  return e;
}

// Fourth-order central differences of a vector function, h = 1e-6: truncation ~h⁴ = 1e-24,
// rounding ~1e-32/h = 1e-26.
DD derivative(const std::function<DD(dd_real)>& f, double step = 1e-6) {
  const dd_real h(step);
  const DD a = f(-2.0 * h), b = f(-h), c = f(h), d = f(2.0 * h);
  DD r(a.size());
  for (std::size_t i = 0; i < r.size(); ++i) r[i] = (a[i] - 8.0 * b[i] + 8.0 * c[i] - d[i]) / (12.0 * h);
  return r;
}

double err(const dd_real& a, const dd_real& b) { return dbl(abs(a - b)); }

// ---- what the robot file says -----------------------------------------------------------------
struct Frame {
  V3 p{};
  M3 R{};  // row-major
};

Frame placement(Model& m, const std::string& link, const DD& q) {
  dd_real p[3], R[9];
  m.frame_placement(link, q.data(), p, R);
  Frame f;
  for (std::size_t i = 0; i < 3; ++i) {
    f.p[i] = p[i];
    for (std::size_t j = 0; j < 3; ++j) f.R[3 * i + j] = R[i + 3 * j];  // column-major in
  }
  return f;
}

DD jacobian(Model& m, const std::string& link, const DD& q) {
  DD J(6 * static_cast<std::size_t>(m.nv()));
  m.frame_jacobian(link, q.data(), J.data());
  return J;
}

// J v (6).
DD times(const DD& J, const DD& v) {
  DD r(J.size() / v.size(), dd_real(0.0));
  for (std::size_t k = 0; k < v.size(); ++k)
    for (std::size_t i = 0; i < r.size(); ++i) r[i] += J[i + r.size() * k] * v[k];
  return r;
}

// The links that move with q: every link of a floating robot; on a fixed one those with a moving
// joint between them and the root (read off the file's joints, not the model).
std::map<std::string, bool> moving_links(const Robot& r) {
  std::map<std::string, const eom::urdf::Joint*> into;
  for (const auto& j : r.joints) into[j.child] = &j;
  std::map<std::string, bool> moves;
  for (const auto& l : r.links) {
    bool m = r.floating;
    for (std::string n = l.name; !m && into.count(n); n = into[n]->parent)
      m = into[n]->type != JointType::fixed;
    moves[l.name] = m;
  }
  return moves;
}

// ---- tests ------------------------------------------------------------------------------------
// Rows 0–2 of J against differences of the frame origin along q ⊕ ε e_k; rows 3–5 against the
// skew part of Ṙ Rᵀ, Ṙ differenced likewise (its symmetric part must vanish too). Every link of
// every robot, 3 states. Measured: 7.2e-26 (absolute; entries are metres and 1).
TEST(RecursiveFrames, JacobianAgainstDifferences) {
  std::mt19937 rng(2024);
  double worst = 0.0;
  for (const Case& c : cases) {
    const Robot r = load(c);
    Model m(r);
    for (int trial = 0; trial < 3; ++trial) {
      const DD q = random_q(rng, m);
      for (const auto& link : r.links) {
        const DD J = jacobian(m, link.name, q);
        const Frame f = placement(m, link.name, q);
        double e = 0.0;
        for (int k = 0; k < m.nv(); ++k) {
          const DD ek = unit(m, k);
          const DD d = derivative([&](dd_real t) {  // (ẋ; Ṙ row-major)
            const Frame g = placement(m, link.name, displace(m, q, ek, t));
            DD x(g.p.begin(), g.p.end());
            x.insert(x.end(), g.R.begin(), g.R.end());
            return x;
          });
          const V3 pd{d[0], d[1], d[2]};
          M3 Rd;
          for (std::size_t i = 0; i < 9; ++i) Rd[i] = d[3 + i];
          const M3 W = rbd::mul(Rd, rbd::transpose(f.R));  // [ω]×
          const V3 w{0.5 * (W[7] - W[5]), 0.5 * (W[2] - W[6]), 0.5 * (W[3] - W[1])};
          const auto col = static_cast<std::size_t>(6 * k);
          for (std::size_t i = 0; i < 3; ++i) {
            e = std::max({e, err(J[col + i], pd[i]), err(J[col + 3 + i], w[i])});
            for (std::size_t j = 0; j < 3; ++j) e = std::max(e, dbl(abs(W[3 * i + j] + W[3 * j + i])));
          }
        }
        EXPECT_LE(e, 1e-20) << label(c) << " " << link.name;
        worst = std::max(worst, e);
      }
    }
  }
  std::printf("frame Jacobians against differences: %.2e\n", worst);
}

// a = J̇ v against d/dε [J(q ⊕ ε v) v] (v held: the motion at v̇ = 0). Measured: 4.2e-23
// (absolute, |v| ≤ 1.5 per entry).
TEST(RecursiveFrames, BiasAgainstDifferences) {
  std::mt19937 rng(7);
  double worst = 0.0;
  for (const Case& c : cases) {
    const Robot r = load(c);
    Model m(r);
    for (int trial = 0; trial < 3; ++trial) {
      const DD q = random_q(rng, m), v = convert<dd_real>(uniform(rng, m.nv(), 1.5));
      for (const auto& link : r.links) {
        DD a(6);
        m.frame_acceleration_bias(link.name, q.data(), v.data(), a.data());
        const DD d = derivative([&](dd_real t) { return times(jacobian(m, link.name, displace(m, q, v, t)), v); });
        double e = 0.0;
        for (std::size_t i = 0; i < 6; ++i) e = std::max(e, err(a[i], d[i]));
        EXPECT_LE(e, 1e-20) << label(c) << " " << link.name;
        worst = std::max(worst, e);
      }
    }
  }
  std::printf("frame biases against differences of J v: %.2e\n", worst);
}

// The root link: the identity when fixed (J = 0, a = 0), the free joint's placement when floating
// (J = [1 −[x − x₀]×R; 0 R] for its own origin: [1 0; 0 R]); every link behind a fixed joint:
// its parent's frame · the joint origin (panda_link8, the flange, is link7 · joint8's origin).
// Measured: 3.7e-32.
TEST(RecursiveFrames, RootAndFixedJointFrames) {
  std::mt19937 rng(11);
  double worst = 0.0;
  for (const Case& c : cases) {
    const Robot r = load(c);
    Model m(r);
    const DD q = random_q(rng, m), v = convert<dd_real>(uniform(rng, m.nv(), 1.5));
    const Frame root = placement(m, r.root, q);
    const DD J = jacobian(m, r.root, q);
    DD a(6);
    m.frame_acceleration_bias(r.root, q.data(), v.data(), a.data());
    Frame expected{{dd_real(0.0), dd_real(0.0), dd_real(0.0)}, rbd::identity3<dd_real>()};
    if (c.floating) {
      expected.p = {q[0], q[1], q[2]};
      expected.R = rbd::quaternion_rotation(q[3], q[4], q[5], q[6]);
    }
    double e = 0.0;
    for (std::size_t i = 0; i < 3; ++i) {
      e = std::max(e, err(root.p[i], expected.p[i]));
      for (std::size_t j = 0; j < 3; ++j) e = std::max(e, err(root.R[3 * i + j], expected.R[3 * i + j]));
    }
    for (std::size_t k = 0; k < static_cast<std::size_t>(m.nv()); ++k)
      for (std::size_t i = 0; i < 6; ++i) {
        dd_real x(0.0);  // the free joint's columns at the root origin
        if (c.floating && k < 3) x = i == k ? 1.0 : 0.0;
        if (c.floating && k >= 3 && k < 6 && i >= 3) x = expected.R[3 * (i - 3) + (k - 3)];
        e = std::max(e, err(J[i + 6 * k], x));
      }
    for (const dd_real& x : a) e = std::max(e, dbl(abs(x)));  // a fixed or free-flying root: 0
    EXPECT_LE(e, 1e-30) << label(c) << " root";
    worst = std::max(worst, e);

    int fixed = 0;
    for (const auto& j : r.joints) {
      if (j.type != JointType::fixed) continue;
      ++fixed;
      const Frame parent = placement(m, j.parent, q), child = placement(m, j.child, q);
      const rbd::Pose<dd_real> want = rbd::compose(rbd::Pose<dd_real>{parent.R, parent.p}, rbd::pose_of<dd_real>(j.origin));
      double ef = 0.0;
      for (std::size_t i = 0; i < 3; ++i) {
        ef = std::max(ef, err(child.p[i], want.p[i]));
        for (std::size_t k = 0; k < 3; ++k) ef = std::max(ef, err(child.R[3 * i + k], want.R[3 * i + k]));
      }
      EXPECT_LE(ef, 1e-30) << label(c) << " " << j.child;
      worst = std::max(worst, ef);
    }
    EXPECT_GT(fixed, 0) << label(c);
  }
  std::printf("root and fixed-joint frames: %.2e\n", worst);
}

// The mass centre against Σ m_i c_i / Σ m_i over the moving links, c_i from the link placements
// and inertial origins (on the fixed UR5 the 4 kg base_link_inertia, welded to the root, is left
// out); its Jacobian against differences; A_G: linear rows m·J_G, and A_G against the sum over the
// links of (m_i ċ_i; (c_i − G) × m_i ċ_i + R_i I_i R_iᵀ ω_i) with ċ_i, ω_i from each link's
// frame Jacobian moved to its mass centre. Measured: mass centre and A_G 6.2e-32 (relative),
// Jacobian vs differences 2.7e-26 (absolute).
TEST(RecursiveFrames, MassCentreAndCentroidalMomentum) {
  std::mt19937 rng(99);
  double worst = 0.0, worst_fd = 0.0;
  for (const Case& c : cases) {
    const Robot r = load(c);
    Model m(r);
    const auto moves = moving_links(r);
    const auto N = static_cast<std::size_t>(m.nv());
    for (int trial = 0; trial < 3; ++trial) {
      const DD q = random_q(rng, m);
      dd_real G[3];
      m.center_of_mass(q.data(), G);
      DD JG(3 * N), A(6 * N);
      m.center_of_mass_jacobian(q.data(), JG.data());
      m.centroidal_momentum_matrix(q.data(), A.data());

      // Link by link.
      dd_real mass(0.0);
      V3 h{dd_real(0.0), dd_real(0.0), dd_real(0.0)};
      struct Part {
        dd_real m;
        V3 c;
        M3 I;    // about c, world axes
        DD Jc;   // 6×nv: ċ; ω
      };
      std::vector<Part> parts;
      int left_out = 0;
      for (const auto& link : r.links) {
        if (!link.has_inertial) continue;
        if (!moves.at(link.name)) {
          ++left_out;
          continue;
        }
        const Frame f = placement(m, link.name, q);
        const auto& in = link.inertial;
        const rbd::Pose<dd_real> com = rbd::compose(rbd::Pose<dd_real>{f.R, f.p}, rbd::pose_of<dd_real>(in.origin));
        const auto& t = in.inertia;
        const M3 local{dd_real(t[0]), dd_real(t[3]), dd_real(t[4]), dd_real(t[3]), dd_real(t[1]),
                       dd_real(t[5]), dd_real(t[4]), dd_real(t[5]), dd_real(t[2])};
        Part p{dd_real(in.mass), com.p, rbd::mul(com.R, rbd::mul(local, rbd::transpose(com.R))),
               jacobian(m, link.name, q)};
        // ċ = ẋ + ω × (c − x): J_c = J_x − [c − x]× J_ω
        const V3 r_c{com.p[0] - f.p[0], com.p[1] - f.p[1], com.p[2] - f.p[2]};
        for (std::size_t k = 0; k < N; ++k) {
          const V3 w{p.Jc[6 * k + 3], p.Jc[6 * k + 4], p.Jc[6 * k + 5]};
          const V3 d = rbd::cross(w, r_c);
          for (std::size_t i = 0; i < 3; ++i) p.Jc[6 * k + i] += d[i];
        }
        mass += p.m;
        h = rbd::add(h, rbd::scale(p.m, p.c));
        parts.push_back(p);
      }
      if (std::string(c.file) == "ur5.urdf" && !c.floating) {
        EXPECT_EQ(left_out, 1);
      }
      if (c.floating) {
        EXPECT_EQ(left_out, 0);
      }

      double e = 0.0;
      for (std::size_t i = 0; i < 3; ++i) e = std::max(e, err(G[i], h[i] / mass));
      DD Ae(6 * N, dd_real(0.0));
      for (const Part& p : parts)
        for (std::size_t k = 0; k < N; ++k) {
          const V3 cd{p.Jc[6 * k], p.Jc[6 * k + 1], p.Jc[6 * k + 2]};
          const V3 w{p.Jc[6 * k + 3], p.Jc[6 * k + 4], p.Jc[6 * k + 5]};
          const V3 rc{p.c[0] - G[0], p.c[1] - G[1], p.c[2] - G[2]};
          const V3 n = rbd::add(rbd::scale(p.m, rbd::cross(rc, cd)), rbd::mul(p.I, w));
          for (std::size_t i = 0; i < 3; ++i) {
            Ae[6 * k + i] += p.m * cd[i];
            Ae[6 * k + 3 + i] += n[i];
          }
        }
      e = std::max(e, normwise(A, Ae));
      DD mJ(3 * N), Alin(3 * N);
      for (std::size_t k = 0; k < N; ++k)
        for (std::size_t i = 0; i < 3; ++i) {
          mJ[3 * k + i] = mass * JG[3 * k + i];
          Alin[3 * k + i] = A[6 * k + i];
        }
      e = std::max(e, normwise(mJ, Alin));
      EXPECT_LE(e, 1e-28) << label(c);
      worst = std::max(worst, e);

      double efd = 0.0;
      for (std::size_t k = 0; k < N; ++k) {
        const DD ek = unit(m, static_cast<int>(k));
        const DD d = derivative([&](dd_real t) {
          DD g(3);
          m.center_of_mass(displace(m, q, ek, t).data(), g.data());
          return g;
        });
        for (std::size_t i = 0; i < 3; ++i) efd = std::max(efd, err(JG[3 * k + i], d[i]));
      }
      EXPECT_LE(efd, 1e-20) << label(c);
      worst_fd = std::max(worst_fd, efd);
    }
  }
  std::printf("mass centre and A_G: link sums %.2e, Jacobian vs differences %.2e\n", worst, worst_fd);
}

// The double model agrees with the dd_real one (the oracle is also used in double). Measured:
// 1.2e-15 (relative to max(1, |x|)).
TEST(RecursiveFrames, DoubleAgreesWithDdReal) {
  std::mt19937 rng(5);
  double worst = 0.0;
  for (const Case& c : cases) {
    const Robot r = load(c);
    Model md(r);
    eomtest::RecursiveDynamics<double> m(r);
    const auto N = static_cast<std::size_t>(m.nv());
    const DD q = random_q(rng, md), v = convert<dd_real>(uniform(rng, m.nv(), 1.5));
    std::vector<double> qq, vv;
    for (const dd_real& x : q) qq.push_back(to_double(x));  // the double state, taken exact
    for (const dd_real& x : v) vv.push_back(to_double(x));
    const DD q2 = convert<dd_real>(qq);
    const auto compare = [&](const std::vector<double>& a, const DD& b) {  // relative to max(1, |b|)
      dd_real num(0.0), den(1.0);
      for (std::size_t i = 0; i < a.size(); ++i) {
        num = std::max(num, abs(dd_real(a[i]) - b[i]));
        den = std::max(den, abs(b[i]));
      }
      const double e = dbl(num / den);
      worst = std::max(worst, e);
      EXPECT_LE(e, 1e-13) << label(c);
    };
    for (const auto& link : r.links) {
      std::vector<double> p(3), R(9), J(6 * N), a(6);
      DD pd(3), Rd(9), Jd(6 * N), ad(6);
      m.frame_placement(link.name, qq.data(), p.data(), R.data());
      md.frame_placement(link.name, q2.data(), pd.data(), Rd.data());
      m.frame_jacobian(link.name, qq.data(), J.data());
      md.frame_jacobian(link.name, q2.data(), Jd.data());
      m.frame_acceleration_bias(link.name, qq.data(), vv.data(), a.data());
      md.frame_acceleration_bias(link.name, q2.data(), v.data(), ad.data());
      compare(p, pd);
      compare(R, Rd);
      compare(J, Jd);
      compare(a, ad);
    }
    std::vector<double> G(3), JG(3 * N), A(6 * N);
    DD Gd(3), JGd(3 * N), Ad(6 * N);
    m.center_of_mass(qq.data(), G.data());
    md.center_of_mass(q2.data(), Gd.data());
    m.center_of_mass_jacobian(qq.data(), JG.data());
    md.center_of_mass_jacobian(q2.data(), JGd.data());
    m.centroidal_momentum_matrix(qq.data(), A.data());
    md.centroidal_momentum_matrix(q2.data(), Ad.data());
    compare(G, Gd);
    compare(JG, JGd);
    compare(A, Ad);
  }
  std::printf("double against dd_real: %.2e\n", worst);
}

// An unknown link is refused by name.
TEST(RecursiveFrames, UnknownLinkThrows) {
  const Robot r = load(cases[0]);
  Model m(r);
  const DD q(static_cast<std::size_t>(m.nq()), dd_real(0.0)), v(static_cast<std::size_t>(m.nv()), dd_real(0.0));
  DD out(6 * static_cast<std::size_t>(m.nv()));
  const auto names_it = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what()).find("panda_link9") != std::string::npos;
    }
    return false;
  };
  EXPECT_TRUE(names_it([&] { m.frame_placement("panda_link9", q.data(), out.data(), out.data() + 3); }));
  EXPECT_TRUE(names_it([&] { m.frame_jacobian("panda_link9", q.data(), out.data()); }));
  EXPECT_TRUE(names_it([&] { m.frame_acceleration_bias("panda_link9", q.data(), v.data(), out.data()); }));
}

}  // namespace
