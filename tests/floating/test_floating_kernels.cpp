// Generated kernels of models with a free joint against eom::Reference (the oracle): a lone body in
// the body form, a hand-written floating tree, and the Panda and the branched robot from URDF with
// FLOATING_BASE. Every kernel, at random states with unit quaternions. The two robots also against
// Featherstone's recursive algorithms with a free root in dd_real (tests/support/
// recursive_dynamics.hpp, written independently), their tangent-space derivatives against
// fourth-order central differences of its ABA along q ⊕ ε e_j in dd_real.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <free_body.hpp>
#include <free_body_folded.hpp>
#include <free_branched.hpp>
#include <free_branched_model.hpp>
#include <free_panda.hpp>
#include <free_panda_model.hpp>
#include <free_tree.hpp>
#include <models/spacecraft_free.hpp>
#include <spacecraft_free.hpp>

#include <qd/dd_real.h>

#include <eom/model/free_joint.hpp>
#include <eom/model/kernels.hpp>
#include <eom/reference/reference.hpp>

#include "floating_models.hpp"
#include "kernel_error.hpp"
#include "recursive_dynamics.hpp"

namespace {

using eomtest::kernel_error;

// Every kernel of K against R's at `trials` random states; the worst error of each.
template <class K, class R> void compare_all(const char* name, int trials) {
  constexpr int nq = K::nq, nv = K::nv, nu = K::nu, np = K::np;
  static_assert(nq == R::nq && nv == R::nv && nv == nq - 1 && nu == R::nu && np == R::np);
  // (taylor_coefficients, on request for a floating model: tests/floating/test_floating_taylor.cpp)
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> x(-1, 1);
  const auto& p = K::parameter_values;
  double worst[10] = {};
  for (int trial = 0; trial < trials; ++trial) {
    std::vector<double> q(nq), v(nv), a(nv), u(nu + 1);
    for (double& e : q) e = x(rng);
    for (double& e : v) e = 2 * x(rng);
    for (double& e : a) e = 2 * x(rng);
    for (double& e : u) e = x(rng);
    eom::normalize_configuration(eom::Layout(nq, nv), q.data());
    std::vector<double> g(nv * nv), r(nv * nv), g2(nv * nv), r2(nv * nv), g3(nv * (nu + 1)),
        r3(nv * (nu + 1));
    auto check = [&](int k, int n) { worst[k] = std::max(worst[k], kernel_error(g.data(), r.data(), n)); };
    K::mass_matrix(q.data(), p.data(), g.data());
    R::mass_matrix(q.data(), p.data(), r.data());
    check(0, nv * nv);
    K::mass_matrix_dot(q.data(), v.data(), p.data(), g.data());
    R::mass_matrix_dot(q.data(), v.data(), p.data(), r.data());
    check(1, nv * nv);
    K::coriolis(q.data(), v.data(), p.data(), g.data());
    R::coriolis(q.data(), v.data(), p.data(), r.data());
    check(2, nv);
    K::potential_gradient(q.data(), p.data(), g.data());
    R::potential_gradient(q.data(), p.data(), r.data());
    check(3, nv);
    K::generalized_forces(0.3, q.data(), v.data(), u.data(), p.data(), g.data());
    R::generalized_forces(0.3, q.data(), v.data(), u.data(), p.data(), r.data());
    check(4, nv);
    ASSERT_TRUE(K::forward_dynamics(0.3, q.data(), v.data(), u.data(), p.data(), g.data()));
    ASSERT_TRUE(R::forward_dynamics(0.3, q.data(), v.data(), u.data(), p.data(), r.data()));
    check(5, nv);
    K::inverse_dynamics(0.3, q.data(), v.data(), a.data(), u.data(), p.data(), g.data());
    R::inverse_dynamics(0.3, q.data(), v.data(), a.data(), u.data(), p.data(), r.data());
    check(6, nv);
    g[0] = K::kinetic_energy(q.data(), v.data(), p.data());
    r[0] = R::kinetic_energy(q.data(), v.data(), p.data());
    g[1] = K::potential_energy(q.data(), p.data());
    r[1] = R::potential_energy(q.data(), p.data());
    check(7, 2);
    ASSERT_TRUE(R::forward_dynamics_derivatives(0.3, q.data(), v.data(), u.data(), p.data(), r.data(),
                                                r2.data(), r3.data()));
    ASSERT_TRUE(K::forward_dynamics_derivatives(0.3, q.data(), v.data(), u.data(), p.data(),
                                                g.data(), g2.data(), g3.data()));
    check(8, nv * nv);
    worst[9] = std::max({worst[9], kernel_error(g2.data(), r2.data(), nv * nv),
                         kernel_error(g3.data(), r3.data(), nv * nu)});
  }
  const char* kernels[10] = {"mass_matrix", "mass_matrix_dot", "coriolis", "potential_gradient",
                             "generalized_forces", "forward_dynamics", "inverse_dynamics",
                             "energies", "d/dq (tangent)", "d/dv, d/du"};
  for (int k = 0; k < 10; ++k) {
    // The Reference's own ∂v̇/∂q in double is the less accurate side for the free Panda (1.7e-12
    // from the dd_real ABA differences, where the generated kernel's is 1.0e-13: the test below),
    // so the derivatives are held to it at 1e-11 and to dd_real at 1e-12.
    EXPECT_LT(worst[k], k == 8 ? 1e-11 : 1e-12) << name << ": " << kernels[k];
    ::testing::Test::RecordProperty(std::string(name) + "." + kernels[k], std::to_string(worst[k]));
  }
}

TEST(FloatingKernels, LoneBodyMatchesTheReference) {
  compare_all<free_body::Kernels, eom::Reference<floating_test::FreeBody>>("free_body", 30);
}

TEST(FloatingKernels, HandWrittenTreeMatchesTheReference) {
  compare_all<free_tree::Kernels, eom::Reference<floating_test::FreeTree>>("free_tree", 30);
}

TEST(FloatingKernels, FreeFlyingSpacecraftMatchesTheReference) {
  compare_all<spacecraft_free::Kernels, eom::Reference<eom::models::SpacecraftFree>>("spacecraft_free", 6);
}

TEST(FloatingKernels, PandaOnAFreeBaseMatchesTheReference) {
  static_assert(free_panda::nq == 14 && free_panda::nv == 13 && free_panda::nu == 7);
  compare_all<free_panda::Kernels, eom::Reference<eom::urdf_models::free_panda>>("free_panda", 6);
}

TEST(FloatingKernels, BranchedRobotOnAFreeBaseMatchesTheReference) {
  compare_all<free_branched::Kernels, eom::Reference<eom::urdf_models::free_branched>>(
      "free_branched", 6);
}

// max |got − expected| / max(1, max |expected|) over every kernel compared, and which.
struct Worst {
  double value = 0;
  std::string where;
  void update(const char* kernel, const double* got, const std::vector<dd_real>& expected) {
    double diff = 0, scale = 1;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      diff = std::max(diff, std::abs(got[i] - to_double(expected[i])));
      scale = std::max(scale, std::abs(to_double(expected[i])));
    }
    if (diff / scale > value) value = diff / scale, where = kernel;
  }
};

template <class K> Worst compare_with_recursive(const char* file, int samples) {
  using DD = std::vector<dd_real>;
  const eom::urdf::Robot robot = eom::urdf::read(std::string(EOM_ROBOTS_DIR) + "/" + file, true);
  eomtest::RecursiveDynamics<dd_real> rd(robot);
  constexpr int nq = K::nq, nv = K::nv, nu = K::nu;
  EXPECT_EQ(rd.nq(), nq);
  EXPECT_EQ(rd.nv(), nv);
  const auto& p = K::parameter_values;
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> x(-1.0, 1.0);
  Worst worst;
  auto lift = [](const double* a, int n) { return DD(a, a + n); };
  for (int sample = 0; sample < samples; ++sample) {
    double q[nq], v[nv], u[nu], a[nv], U[nv] = {};
    for (double& e : q) e = 2 * x(rng);
    eom::normalize_configuration(eom::Layout(nq, nv), q);
    for (double& e : v) e = 2 * x(rng);
    for (double& e : a) e = 2 * x(rng);
    for (int i = 0; i < nu; ++i) U[6 + i] = u[i] = 5 * x(rng);
    DD Q = lift(q, nq);
    eom::normalize_configuration(eom::Layout(nq, nv), Q.data());  // unit in dd_real too
    const DD V = lift(v, nv), A = lift(a, nv), UU = lift(U, nv);
    for (int i = 0; i < nq; ++i) q[i] = to_double(Q[i]);
    DD M(nv * nv), tau(nv), acc(nv);
    double out[nv * nv];
    rd.mass_matrix(Q, M);
    K::mass_matrix(q, p.data(), out);
    worst.update("mass_matrix", out, M);
    rd.inverse_dynamics(Q, V, A, tau);
    for (int i = 0; i < nv; ++i) tau[i] -= UU[i] - rd.damping()[i] * V[i];  // minus Q
    K::inverse_dynamics(0.0, q, v, a, u, p.data(), out);
    worst.update("inverse_dynamics", out, tau);
    rd.forward_dynamics(Q, V, UU, acc);
    EXPECT_TRUE(K::forward_dynamics(0.0, q, v, u, p.data(), out));
    worst.update("forward_dynamics", out, acc);
    double d_dq[nv * nv], d_dv[nv * nv], d_du[nv * nu];
    EXPECT_TRUE(K::forward_dynamics_derivatives(0.0, q, v, u, p.data(), d_dq, d_dv, d_du));
    const dd_real h(1e-6);
    DD fd(nv * nv);
    for (int j = 0; j < nv; ++j) {  // along q ⊕ ε e_j, by the exp map in dd_real
      DD f[4] = {DD(nv), DD(nv), DD(nv), DD(nv)};
      const dd_real steps[4] = {-2.0 * h, -h, h, 2.0 * h};
      for (int k = 0; k < 4; ++k) {
        DD e(nv, dd_real(0.0)), moved(nq);
        e[j] = 1.0;
        eom::integrate_configuration(eom::Layout(nq, nv), Q.data(), e.data(), steps[k], moved.data());
        rd.forward_dynamics(moved, V, UU, f[k]);
      }
      for (int i = 0; i < nv; ++i)
        fd[i + nv * j] = (f[0][i] - 8.0 * f[1][i] + 8.0 * f[2][i] - f[3][i]) / (12.0 * h);
    }
    worst.update("forward_dynamics_derivatives (q)", d_dq, fd);
  }
  return worst;
}

TEST(FloatingKernels, PandaAndBranchedRobotMatchTheRecursiveAlgorithmsInDoubleDouble) {
  const Worst panda = compare_with_recursive<free_panda::Kernels>("panda.urdf", 20);
  const Worst branched = compare_with_recursive<free_branched::Kernels>("branched.urdf", 20);
  std::printf("free panda: worst %.1e (%s); free branched: worst %.1e (%s)\n", panda.value,
              panda.where.c_str(), branched.value, branched.where.c_str());
  EXPECT_LT(panda.value, 1e-12) << panda.where;
  EXPECT_LT(branched.value, 1e-12) << branched.where;
}

// The lone body with every parameter folded (mass centre at the origin, no gravity): M is constant
// and the generator solves it by its inverse, rounded once from long double (generator/README.md).
// Against the reference with the same parameters, and ω̇ against Euler's equations J ω̇ = −ω × Jω
// solved in dd_real (J in root axes, as the tracer folds it); a non-finite element anywhere in the
// input, and a result that overflows, are refused with NaN everywhere.
TEST(FloatingKernels, FoldedBodySolvedByItsInverseMatchesTheReferenceAndEuler) {
  namespace K = free_body_folded;
  using R = eom::Reference<floating_test::FreeBodyTree>;
  static_assert(K::np == 0 && K::nq == 7 && K::nv == 6);
  const std::array<double, 11> p{2.0, 0.3, 0.5, 0.7, 0.02, -0.01, 0.03, 0.0, 0.0, 0.0, 0.0};
  const std::array<double, 6> J = eom::detail::rotated_inertia(eom::constant_rpy<double>({0.3, -0.2, 0.5}),
                                                               std::array<double, 6>{0.3, 0.5, 0.7, 0.02, -0.01, 0.03});
  const auto at = [&](int i, int j) {  // xx, yy, zz, xy, xz, yz
    constexpr int index[3][3] = {{0, 3, 4}, {3, 1, 5}, {4, 5, 2}};
    return dd_real(J[index[i][j]]);
  };
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> x(-1, 1);
  double worst_reference = 0, worst_euler = 0, worst_derivatives = 0, worst_inverse = 0, worst_inverse_euler = 0;
  for (int trial = 0; trial < 50; ++trial) {
    std::array<double, 7> q;
    std::array<double, 6> v, a, g, r;
    for (double& e : q) e = x(rng);
    for (double& e : v) e = 3 * x(rng);
    for (double& e : a) e = x(rng);
    eom::normalize_configuration(eom::Layout(7, 6), q.data());
    ASSERT_TRUE(K::forward_dynamics(0.0, q.data(), v.data(), nullptr, nullptr, g.data()));
    ASSERT_TRUE(R::forward_dynamics(0.0, q.data(), v.data(), nullptr, p.data(), r.data()));
    worst_reference = std::max(worst_reference, kernel_error(g.data(), r.data(), 6));
    // Euler: b = −ω × Jω, then J ω̇ = b by Cramer's rule in dd_real
    dd_real w[3] = {v[3], v[4], v[5]}, Jw[3], b[3];
    for (int i = 0; i < 3; ++i) Jw[i] = at(i, 0) * w[0] + at(i, 1) * w[1] + at(i, 2) * w[2];
    for (int i = 0; i < 3; ++i) b[i] = -(w[(i + 1) % 3] * Jw[(i + 2) % 3] - w[(i + 2) % 3] * Jw[(i + 1) % 3]);
    const auto det = [&](int column, const dd_real* c) {  // det J with `column` replaced by c
      dd_real m[3][3];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) m[i][j] = j == column ? c[i] : at(i, j);
      return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
             m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    };
    const dd_real d = det(-1, b);
    std::array<double, 6> e{0, 0, 0, to_double(det(0, b) / d), to_double(det(1, b) / d), to_double(det(2, b) / d)};
    worst_euler = std::max(worst_euler, kernel_error(g.data(), e.data(), 6));
    std::array<double, 36> gq, gv, rq, rv;
    ASSERT_TRUE(K::forward_dynamics_derivatives(0.0, q.data(), v.data(), nullptr, nullptr, gq.data(), gv.data(), nullptr));
    ASSERT_TRUE(R::forward_dynamics_derivatives(0.0, q.data(), v.data(), nullptr, p.data(), rq.data(), rv.data(), nullptr));
    worst_derivatives = std::max({worst_derivatives, kernel_error(gq.data(), rq.data(), 36),
                                  kernel_error(gv.data(), rv.data(), 36)});
    K::inverse_dynamics(0.0, q.data(), v.data(), a.data(), nullptr, nullptr, g.data());
    R::inverse_dynamics(0.0, q.data(), v.data(), a.data(), nullptr, p.data(), r.data());
    worst_inverse = std::max(worst_inverse, kernel_error(g.data(), r.data(), 6));
    // Newton–Euler backwards: τ = (m a_lin, J α + ω × Jω), in dd_real
    for (int i = 0; i < 3; ++i) {
      e[i] = 2.0 * a[i];
      e[3 + i] = to_double(at(i, 0) * a[3] + at(i, 1) * a[4] + at(i, 2) * a[5] - b[i]);
    }
    worst_inverse_euler = std::max(worst_inverse_euler, kernel_error(g.data(), e.data(), 6));
  }
  // Against dd_real to rounding; the double Reference's own rounding is a few 1e-15 here.
  EXPECT_LT(worst_euler, 1e-15);
  EXPECT_LT(worst_inverse_euler, 1e-15);
  EXPECT_LT(worst_reference, 1e-14);
  EXPECT_LT(worst_derivatives, 1e-13);
  EXPECT_LT(worst_inverse, 1e-14);
  ::testing::Test::RecordProperty("folded.forward_dynamics_vs_euler", std::to_string(worst_euler));

  // Refused: a NaN or an infinity in t or in any element of q and v (the whole arrays are tested,
  // or caught by the results' guards), and ω so large that ω × Jω overflows.
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const auto refused = [&](double t, const std::array<double, 7>& q, const std::array<double, 6>& v) {
    std::array<double, 6> out;
    out.fill(1.0);
    const bool ok = K::forward_dynamics(t, q.data(), v.data(), nullptr, nullptr, out.data());
    return !ok && std::all_of(out.begin(), out.end(), [](double e) { return std::isnan(e); });
  };
  const std::array<double, 7> q0{0.1, 0.2, 0.3, 1.0, 0.0, 0.0, 0.0};
  const std::array<double, 6> v0{0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
  EXPECT_FALSE(refused(0.0, q0, v0));
  EXPECT_TRUE(refused(nan, q0, v0));
  EXPECT_TRUE(refused(inf, q0, v0));
  for (double bad : {nan, inf, -inf}) {
    for (int i = 0; i < 7; ++i) {
      auto q = q0;
      q[i] = bad;
      EXPECT_TRUE(refused(0.0, q, v0)) << "q[" << i << "] = " << bad;
    }
    for (int i = 0; i < 6; ++i) {
      auto v = v0;
      v[i] = bad;
      EXPECT_TRUE(refused(0.0, q0, v)) << "v[" << i << "] = " << bad;
    }
  }
  EXPECT_TRUE(refused(0.0, q0, {0, 0, 0, 1e200, -2e200, 3e200}));
}

TEST(FloatingKernels, NonFiniteInputIsRefused) {
  std::array<double, 7> q{0, 0, 0, 1, 0, 0, 0};
  std::array<double, 6> v{}, a;
  q[4] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(free_body::forward_dynamics(0, q.data(), v.data(), nullptr,
                                           free_body::parameter_values.data(), a.data()));
  for (double e : a) EXPECT_TRUE(std::isnan(e));
}

}  // namespace
