// WRENCH_INPUTS (eom/multibody/wrench_inputs.hpp): external forces and wrenches on frames as more
// inputs of every kernel.
//   - the drone: rotor thrusts in the rotors' axes and a world wrench on the base, against the
//     Newton–Euler equations of one rigid body written out here (nothing of the tree recursions);
//   - Solo12 on a free base: two foot forces (world) and a base wrench (base axes) against
//     eom::Reference of the same wrapped model, against the wrenches' power f·ẋ + τ·ω with ẋ and ω
//     taken from central differences of the generated frame placements, and ∂v̇/∂u against M⁻¹Jᵀ;
//   - the names and sizes the generated header states.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <string_view>
#include <vector>

#include <wrench_drone.hpp>
#include <wrench_solo12.hpp>
#include <wrench_solo12_model.hpp>

#include <eom/model/free_joint.hpp>
#include <eom/multibody/wrench_inputs.hpp>
#include <eom/reference/reference.hpp>

#include "kernel_error.hpp"

namespace {

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<double, 9>;  // column-major

Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3 times(const Mat3& A, const Vec3& x) {
  return {A[0] * x[0] + A[3] * x[1] + A[6] * x[2], A[1] * x[0] + A[4] * x[1] + A[7] * x[2],
          A[2] * x[0] + A[5] * x[1] + A[8] * x[2]};
}
Vec3 transposed_times(const Mat3& A, const Vec3& x) {
  return {A[0] * x[0] + A[1] * x[1] + A[2] * x[2], A[3] * x[0] + A[4] * x[1] + A[5] * x[2],
          A[6] * x[0] + A[7] * x[1] + A[8] * x[2]};
}
Mat3 rotation_of(double w, double x, double y, double z) {  // unit quaternion → R, column-major
  return {1 - 2 * (y * y + z * z), 2 * (x * y + w * z),     2 * (x * z - w * y),
          2 * (x * y - w * z),     1 - 2 * (x * x + z * z), 2 * (y * z + w * x),
          2 * (x * z + w * y),     2 * (y * z - w * x),     1 - 2 * (x * x + y * y)};
}
Mat3 rpy(double r, double p, double y) {  // Rz(y) Ry(p) Rx(r)
  const double cr = std::cos(r), sr = std::sin(r), cp = std::cos(p), sp = std::sin(p),
               cy = std::cos(y), sy = std::sin(y);
  return {cy * cp, sy * cp, -sp, cy * sp * sr - sy * cr, sy * sp * sr + cy * cr, cp * sr,
          cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr};
}
// x solving the symmetric 3×3 system A x = b (Cramer: A is a well-conditioned inertia).
Vec3 solve3(const Mat3& A, const Vec3& b) {
  const Vec3 c0{A[0], A[1], A[2]}, c1{A[3], A[4], A[5]}, c2{A[6], A[7], A[8]};
  auto det = [](const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 bc = cross(b, c);
    return a[0] * bc[0] + a[1] * bc[1] + a[2] * bc[2];
  };
  const double d = det(c0, c1, c2);
  return {det(b, c1, c2) / d, det(c0, b, c2) / d, det(c0, c1, b) / d};
}

// A random state of a model with a free joint: q with a unit quaternion, v, u.
template <class K> struct State {
  std::array<double, K::nq> q{};
  std::array<double, K::nv> v{};
  std::array<double, K::nu> u{};
};
template <class K> State<K> random_state(std::mt19937& rng) {
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  State<K> s;
  for (double& x : s.q) x = d(rng);
  const double n = std::sqrt(s.q[3] * s.q[3] + s.q[4] * s.q[4] + s.q[5] * s.q[5] + s.q[6] * s.q[6]);
  for (int i = 3; i < 7; ++i) s.q[i] /= n;
  for (double& x : s.v) x = 2 * d(rng);
  for (double& x : s.u) x = 5 * d(rng);
  return s;
}

}  // namespace

// The drone of drone.urdf as one rigid body: mass m, mass centre c and inertia Ic about it (base
// axes), the rotors at r_k in base axes turned by R_k. Its free joint's v = (ṗ in world axes, ω in
// base axes), so with F the world force on it (gravity included) and τ_o the moment of the
// external loads about the base origin in base axes:
//   Ic ω̇ + ω × Ic ω = τ_o − c × Rᵀ F_ext      (about the mass centre)
//   p̈ = F / m − R (ω̇ × c + ω × (ω × c))        (the origin from the mass centre)
TEST(WrenchInputs, DroneThrustsMatchTheRigidBodyInClosedForm) {
  using K = wrench_drone::Kernels;
  static_assert(K::nq == 7 && K::nv == 6 && K::nu == 4 * 3 + 6);
  const double m = 1.42, g = 9.81;
  const Vec3 c{0.012, -0.008, -0.021};
  const Mat3 Ic{0.0213, 0.0011, -0.0007, 0.0011, 0.0241, 0.0005, -0.0007, 0.0005, 0.0397};
  const std::array<Vec3, 4> r{{{0.17, 0.17, 0.04}, {0.17, -0.17, 0.04}, {-0.17, 0.17, 0.04},
                               {-0.17, -0.17, 0.04}}};
  const std::array<Mat3, 4> Rk{rpy(0, 0, 0), rpy(0, 0, 0), rpy(0, 0, 0), rpy(0.1, -0.2, 0.3)};
  std::mt19937 rng(11);
  double worst = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const State<K> s = random_state<K>(rng);
    const Mat3 R = rotation_of(s.q[3], s.q[4], s.q[5], s.q[6]);
    const Vec3 w{s.v[3], s.v[4], s.v[5]};
    Vec3 F_body{0, 0, 0}, tau_o{0, 0, 0};  // base axes
    for (int k = 0; k < 4; ++k) {
      const Vec3 f = times(Rk[k], {s.u[3 * k], s.u[3 * k + 1], s.u[3 * k + 2]});
      const Vec3 m_k = cross(r[k], f);
      for (int i = 0; i < 3; ++i) F_body[i] += f[i], tau_o[i] += m_k[i];
    }
    const Vec3 Fw{s.u[12], s.u[13], s.u[14]}, Tw = transposed_times(R, {s.u[15], s.u[16], s.u[17]});
    const Vec3 Fb_world = times(R, F_body);
    Vec3 F_ext, tau;
    for (int i = 0; i < 3; ++i) F_ext[i] = Fb_world[i] + Fw[i];
    const Vec3 c_x_F = cross(c, transposed_times(R, F_ext)), Icw = times(Ic, w), gyro = cross(w, Icw);
    for (int i = 0; i < 3; ++i) tau[i] = tau_o[i] + Tw[i] - c_x_F[i] - gyro[i];
    const Vec3 wdot = solve3(Ic, tau);
    const Vec3 wc = cross(w, c), arm = cross(wdot, c), centripetal = cross(w, wc);
    const Vec3 back = times(R, {arm[0] + centripetal[0], arm[1] + centripetal[1], arm[2] + centripetal[2]});
    std::array<double, 6> expected{};
    for (int i = 0; i < 3; ++i) {
      expected[i] = F_ext[i] / m - back[i];
      expected[3 + i] = wdot[i];
    }
    expected[2] -= g;
    std::array<double, 6> vdot{};
    ASSERT_TRUE(K::forward_dynamics(0.0, s.q.data(), s.v.data(), s.u.data(), K::parameter_values.data(),
                                    vdot.data()));
    worst = std::max(worst, eomtest::kernel_error(vdot.data(), expected.data(), 6));
  }
  std::printf("drone, 50 states: worst %.2g against the closed form\n", worst);
  EXPECT_LT(worst, 1e-13);
}

namespace {
struct SoloWrenches {  // as tests/wrenches/CMakeLists.txt writes WRENCH_INPUTS for wrench_solo12
  static constexpr std::array<eom::WrenchInput, 3> wrench_inputs{
      {{"FL_FOOT", eom::WrenchKind::force}, {"HR_FOOT", eom::WrenchKind::force},
       {"base_link", eom::WrenchKind::body_wrench}}};
  static constexpr std::array<std::string_view, 12> input_names{
      "FL_FOOT_fx", "FL_FOOT_fy", "FL_FOOT_fz", "HR_FOOT_fx", "HR_FOOT_fy", "HR_FOOT_fz",
      "base_link_fx", "base_link_fy", "base_link_fz", "base_link_tx", "base_link_ty", "base_link_tz"};
};
using SoloModel = eom::WrenchInputs<eom::urdf_models::wrench_solo12, SoloWrenches>;
using Solo = wrench_solo12::Kernels;
constexpr int own_inputs = 12;  // one per joint of the legs
}  // namespace

TEST(WrenchInputs, NamesAndSizesFollowTheModelsOwnInputs) {
  static_assert(Solo::nu == own_inputs + 12);
  EXPECT_EQ(Solo::input_names[0], eom::urdf_models::wrench_solo12::inputs[0]);
  for (int i = 0; i < 12; ++i) EXPECT_EQ(Solo::input_names[own_inputs + i], SoloWrenches::input_names[i]);
  static_assert(wrench_drone::Kernels::nu == 18);
  EXPECT_EQ(wrench_drone::Kernels::input_names[0], "rotor_fl_fx");
  EXPECT_EQ(wrench_drone::Kernels::input_names[12], "base_link_fx");
  EXPECT_EQ(wrench_drone::Kernels::input_names[17], "base_link_tz");
}

TEST(WrenchInputs, SoloMatchesTheReferenceOfTheSameModel) {
  using R = eom::Reference<SoloModel>;
  const auto& p = Solo::parameter_values;
  std::mt19937 rng(5);
  double worst = 0, worst_derivative = 0;
  for (int trial = 0; trial < 4; ++trial) {  // the reference's derivatives take 1 s a state
    const State<Solo> s = random_state<Solo>(rng);
    std::array<double, Solo::nv> a{}, b{};
    ASSERT_TRUE(Solo::forward_dynamics(0.0, s.q.data(), s.v.data(), s.u.data(), p.data(), a.data()));
    ASSERT_TRUE(R::forward_dynamics(0.0, s.q.data(), s.v.data(), s.u.data(), p.data(), b.data()));
    worst = std::max(worst, eomtest::kernel_error(a.data(), b.data(), Solo::nv));
    std::vector<double> dq(Solo::nv * Solo::nv), dv(Solo::nv * Solo::nv), du(Solo::nv * Solo::nu),
        rq(dq.size()), rv(dv.size()), ru(du.size());
    ASSERT_TRUE(Solo::forward_dynamics_derivatives(0.0, s.q.data(), s.v.data(), s.u.data(), p.data(),
                                                   dq.data(), dv.data(), du.data()));
    ASSERT_TRUE(R::forward_dynamics_derivatives(0.0, s.q.data(), s.v.data(), s.u.data(), p.data(),
                                                rq.data(), rv.data(), ru.data()));
    worst_derivative = std::max({worst_derivative, eomtest::kernel_error(dq.data(), rq.data(), dq.size()),
                                 eomtest::kernel_error(dv.data(), rv.data(), dv.size()),
                                 eomtest::kernel_error(du.data(), ru.data(), du.size())});
  }
  std::printf("Solo12, 4 states: v̇ %.2g, derivatives %.2g against eom::Reference\n", worst,
              worst_derivative);
  EXPECT_LT(worst, 1e-12);
  EXPECT_LT(worst_derivative, 1e-11);
}

// Qᵀv of the wrench inputs alone equals their power Σ f·ẋ + τ·ω, ẋ and ω of each frame measured
// from central differences of frame_placement along q ⊕ h v: the Jacobian's rows, axes and the
// free joint's conventions, without the Jacobian.
TEST(WrenchInputs, SoloGeneralizedForcesDoTheWrenchesWork) {
  const auto& p = Solo::parameter_values;
  std::mt19937 rng(7);
  double worst = 0;
  for (int trial = 0; trial < 10; ++trial) {
    const State<Solo> s = random_state<Solo>(rng);
    State<Solo> none = s;
    for (int i = own_inputs; i < Solo::nu; ++i) none.u[i] = 0;
    std::array<double, Solo::nv> Q{}, Q0{};
    Solo::generalized_forces(0.0, s.q.data(), s.v.data(), s.u.data(), p.data(), Q.data());
    Solo::generalized_forces(0.0, s.q.data(), s.v.data(), none.u.data(), p.data(), Q0.data());
    double power_Q = 0;
    for (int j = 0; j < Solo::nv; ++j) power_Q += (Q[j] - Q0[j]) * s.v[j];

    const double h = 1e-5;
    auto placed = [&](int f, double step) {
      std::array<double, Solo::nq> q{};
      eom::integrate_configuration(eom::Layout(Solo::nq, Solo::nv), s.q.data(), s.v.data(), step, q.data());
      Vec3 x;
      Mat3 R;
      Solo::frame_placement(f, q.data(), p.data(), x.data(), R.data());
      return std::pair{x, R};
    };
    double power = 0;
    for (int f = 0; f < 3; ++f) {
      const auto [xp, Rp] = placed(f, h);
      const auto [xm, Rm] = placed(f, -h);
      const auto [x0, R0] = placed(f, 0.0);
      Vec3 xdot;
      Mat3 Rdot;
      for (int i = 0; i < 3; ++i) xdot[i] = (xp[i] - xm[i]) / (2 * h);
      for (int i = 0; i < 9; ++i) Rdot[i] = (Rp[i] - Rm[i]) / (2 * h);
      // [ω]× = Ṙ Rᵀ (world axes)
      auto W = [&](int i, int k) {
        double sum = 0;
        for (int j = 0; j < 3; ++j) sum += Rdot[i + 3 * j] * R0[k + 3 * j];
        return sum;
      };
      const Vec3 omega{0.5 * (W(2, 1) - W(1, 2)), 0.5 * (W(0, 2) - W(2, 0)), 0.5 * (W(1, 0) - W(0, 1))};
      const double* w = s.u.data() + own_inputs + 3 * f;
      if (f < 2) {  // world forces on the feet
        power += w[0] * xdot[0] + w[1] * xdot[1] + w[2] * xdot[2];
      } else {  // the base wrench in base axes
        const Vec3 force = times(R0, {w[0], w[1], w[2]}), torque = times(R0, {w[3], w[4], w[5]});
        for (int i = 0; i < 3; ++i) power += force[i] * xdot[i] + torque[i] * omega[i];
      }
    }
    worst = std::max(worst, std::abs(power_Q - power) / std::max(1.0, std::abs(power)));
  }
  std::printf("Solo12, 10 states: power of the wrenches, worst relative difference %.2g\n", worst);
  EXPECT_LT(worst, 1e-7);  // central differences with h = 1e-5: O(h²) and O(ε/h)
}

// ∂v̇/∂u on a wrench's columns is M⁻¹ Jᵀ (times the frame's rotation for the base-axes wrench),
// from the generated mass matrix and frame Jacobians: the derivative kernel takes the new inputs.
TEST(WrenchInputs, SoloInputDerivativesAreTheMappedJacobians) {
  const auto& p = Solo::parameter_values;
  constexpr int nv = Solo::nv;
  std::mt19937 rng(9);
  double worst = 0;
  for (int trial = 0; trial < 5; ++trial) {
    const State<Solo> s = random_state<Solo>(rng);
    std::vector<double> dq(nv * nv), dv(nv * nv), du(nv * Solo::nu), M(nv * nv);
    ASSERT_TRUE(Solo::forward_dynamics_derivatives(0.0, s.q.data(), s.v.data(), s.u.data(), p.data(),
                                                   dq.data(), dv.data(), du.data()));
    Solo::mass_matrix(s.q.data(), p.data(), M.data());
    for (int f = 0; f < 3; ++f) {
      std::vector<double> J(6 * nv);
      Vec3 x;
      Mat3 R;
      Solo::frame_jacobian(f, s.q.data(), p.data(), J.data());
      Solo::frame_placement(f, s.q.data(), p.data(), x.data(), R.data());
      const int n = f < 2 ? 3 : 6;
      for (int c = 0; c < n; ++c) {
        // M · (∂v̇/∂u_c) against Jᵀ e_c (world) or Jᵀ (R e_c) (base axes)
        std::array<double, 6> e{};
        if (f < 2) {
          e[c] = 1;
        } else {
          for (int i = 0; i < 3; ++i) e[(c < 3 ? 0 : 3) + i] = R[i + 3 * (c % 3)];
        }
        const double* column = du.data() + nv * (own_inputs + 3 * f + c);
        std::vector<double> Mx(nv, 0.0), JTe(nv, 0.0);
        for (int i = 0; i < nv; ++i)
          for (int j = 0; j < nv; ++j) Mx[i] += M[i + nv * j] * column[j];
        for (int j = 0; j < nv; ++j)
          for (int r = 0; r < 6; ++r) JTe[j] += J[r + 6 * j] * e[r];
        worst = std::max(worst, eomtest::kernel_error(Mx.data(), JTe.data(), nv));
      }
    }
  }
  std::printf("Solo12, 5 states: M ∂v̇/∂u against Jᵀ, worst %.2g\n", worst);
  EXPECT_LT(worst, 1e-12);
}
