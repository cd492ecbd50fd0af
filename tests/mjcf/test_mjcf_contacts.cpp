// CONTACTS on a published humanoid: MuJoCo's humanoid.xml (27 dof, 6-joint legs) standing on two
// flat feet (double support, 12 rows) and on one (single support), its generated contact_dynamics
// and impulse_dynamics against the KKT solve in dd_real built from eom::Reference<Model, dd_real>
// (tests/support/contact_reference.hpp), beside what pivoted elimination of the same system in
// double achieves; and their derivative kernels (the closed forms on a free tree under gravity,
// with springs and armature) against forward differences of that solve in dd_real.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string_view>
#include <vector>

#include <mjcf_humanoid_contacts.hpp>
#include <mjcf_humanoid_contacts_model.hpp>

#include <qd/dd_real.h>

#include <eom/model/free_joint.hpp>
#include <eom/reference/reference.hpp>

#include "contact_reference.hpp"
#include "kernel_error.hpp"

namespace {

using K = mjcf_humanoid_contacts::Kernels;
using RD = eom::Reference<eom::mjcf_models::mjcf_humanoid_contacts, dd_real>;
constexpr int nq = K::nq, nv = K::nv, nu = K::nu;

int reference_frame(std::string_view name) {
  for (int f = 0; f < RD::nframes; ++f)
    if (RD::frame_names[f] == name) return f;
  ADD_FAILURE() << "no frame " << name;
  return 0;
}

// Set s by the header's tables, with the Reference's frame indices.
std::vector<eomtest::ContactFrame> reference_set(int s) {
  std::vector<eomtest::ContactFrame> set;
  for (int c = K::contact_begin[s]; c < K::contact_begin[s + 1]; ++c)
    set.push_back({reference_frame(K::frame_names[K::contact_frames[c]]), K::contact_six_d[c]});
  return set;
}

struct State {
  std::array<double, nq> q{};
  std::array<double, nv> v{};
  std::array<double, nu> u{};
};
// q on the manifold (the root's quaternion normalized), v, and u inside the motors' ctrlrange.
State random_state(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  State x;
  for (double& a : x.q) a = 0.5 * unit(rng);
  eom::normalize_configuration(eom::Layout(nq, nv), x.q.data());
  for (double& a : x.v) a = unit(rng);
  for (double& a : x.u) a = 0.5 * unit(rng);
  return x;
}

}  // namespace

TEST(MjcfContacts, HumanoidOnItsFeetMatchesTheKktSolveInDoubleDouble) {
  static_assert(nv == 27 && K::ncontact_sets == 2 && K::contact_rows[0] == 12 && K::contact_rows[1] == 6);
  const auto& p = K::parameter_values;
  std::mt19937_64 rng(48);
  double worst_v = 0, worst_l = 0, double_v = 0, double_l = 0;
  for (int trial = 0; trial < 3; ++trial) {
    const State state = random_state(rng);
    const auto& q = state.q;
    const auto& v = state.v;
    const auto& u = state.u;
    std::array<dd_real, nq> qd;
    std::array<dd_real, nv> vd;
    std::array<dd_real, nu> ud;
    std::vector<dd_real> pd(p.begin(), p.end());
    for (int i = 0; i < nq; ++i) qd[i] = q[i];
    for (int i = 0; i < nv; ++i) vd[i] = v[i];
    for (int i = 0; i < nu; ++i) ud[i] = u[i];
    for (int s = 0; s < K::ncontact_sets; ++s) {
      for (bool impulse : {false, true}) {
        const int rows = K::contact_rows[s];
        std::vector<double> x(nv), force(rows);
        ASSERT_TRUE(impulse ? K::impulse_dynamics(s, q.data(), v.data(), p.data(), 0.5, 0.0, x.data(), force.data())
                            : K::contact_dynamics(s, 0.0, q.data(), v.data(), u.data(), p.data(), 10.0, 0.0,
                                                  x.data(), force.data()));
        const auto k = eomtest::contact_kkt<RD>(reference_set(s), qd.data(), vd.data(), ud.data(), pd.data(),
                                                10.0, 0.5, impulse, 0.0);
        const std::vector<dd_real> y = eomtest::gauss_solve(k.A, k.b);
        std::vector<double> Ad, bd, ry;
        for (const dd_real& a : k.A) Ad.push_back(to_double(a));
        for (const dd_real& b : k.b) bd.push_back(to_double(b));
        for (const dd_real& a : y) ry.push_back(to_double(a));
        std::vector<double> yd = eomtest::gauss_solve(Ad, bd);
        if (impulse)
          for (int i = 0; i < nv; ++i) ry[i] += v[i], yd[i] += v[i];
        worst_v = std::max(worst_v, eomtest::kernel_error(x.data(), ry.data(), nv));
        worst_l = std::max(worst_l, eomtest::kernel_error(force.data(), ry.data() + nv, rows));
        double_v = std::max(double_v, eomtest::kernel_error(yd.data(), ry.data(), nv));
        double_l = std::max(double_l, eomtest::kernel_error(yd.data() + nv, ry.data() + nv, rows));
      }
    }
  }
  std::printf("MuJoCo's humanoid on two and on one 6d foot (3 states, contact dynamics kd = 10 and impulse "
              "e = 0.5): velocity %.2g, force %.2g against the dd_real KKT (pivoted elimination in double: "
              "%.2g, %.2g)\n", worst_v, worst_l, double_v, double_l);
  // measured 1.7e-14 and 3.6e-14 (elimination in double: 9.2e-15, 1.1e-14)
  EXPECT_LT(worst_v, 1e-13);
  EXPECT_LT(worst_l, 1e-13);
}

// The derivative kernels against forward differences in dd_real of the KKT solve (h = 1e-16:
// truncation ~h, rounding ~1e-32/h, both about 1e-16, far below the kernels' round-off) along
// the tangent directions of q (q ⊕ h e_j, CONTRACT §1), v (v⁻) and u, at random state `draw`,
// both sets, kd = 5 and 0, restitution 0 and 0.5. The dd_real Reference dominates the time (c by
// AD over (q, v): ~0.7 s, M 0.16 s): each perturbed point's terms serve every set, gain and
// restitution, and M is reused along v and u; about 40 s of CPU for the state.
static void check_derivatives(int draw) {
  using Terms = eomtest::DynamicsTerms<dd_real>;
  using Frames = std::array<eomtest::ContactTerms<dd_real>, K::ncontact_sets>;
  const auto& p = K::parameter_values;
  const std::vector<dd_real> pd(p.begin(), p.end());
  const dd_real h("1e-16");
  const double gains[] = {5.0, 0.0}, restitutions[] = {0.0, 0.5};
  // worst errors: v̇ and λ along q, v, u; v⁺ and Λ along q, v⁻
  std::array<double, 3> worst_vdot{}, worst_lambda{};
  std::array<double, 2> worst_vplus{}, worst_impulse{};
  double wrong_gain = 0;
  std::mt19937_64 rng(4848);
  for (int k = 0; k < draw; ++k) random_state(rng);
  const auto start = std::chrono::steady_clock::now();
  {
    const State x = random_state(rng);
    std::array<dd_real, nq> q0;
    std::array<dd_real, nv> v0;
    std::array<dd_real, nu> u0;
    for (int i = 0; i < nq; ++i) q0[i] = x.q[i];
    for (int i = 0; i < nv; ++i) v0[i] = x.v[i];
    for (int i = 0; i < nu; ++i) u0[i] = x.u[i];
    auto frames = [&](const dd_real* q, const dd_real* v) {
      Frames f;
      for (int s = 0; s < K::ncontact_sets; ++s)
        f[s] = eomtest::contact_terms<RD>(reference_set(s), q, v, pd.data());
      return f;
    };
    const Terms base = eomtest::dynamics_terms<RD>(q0.data(), v0.data(), u0.data(), pd.data());
    std::array<dd_real, nv> Q0;
    RD::generalized_forces(dd_real(0.0), q0.data(), v0.data(), u0.data(), pd.data(), Q0.data());
    const Frames base_frames = frames(q0.data(), v0.data());
    // diff[c][j]: column j of set/gain/restitution case c (contact: 2 sets x 2 gains; impulse: 2
    // sets x 2 restitutions), (velocity; force)
    std::array<std::vector<std::vector<double>>, 8> diff;
    auto solutions = [&](const Terms& d, const Frames& f, const dd_real* v) {
      std::array<std::vector<dd_real>, 8> y;
      for (int c = 0; c < 8; ++c) {
        const int s = c % 2;
        const bool impulse = c >= 4;
        const eomtest::Kkt<dd_real> k = eomtest::assemble_kkt(d, f[s], v, impulse ? 0.0 : gains[c / 2],
                                                              impulse ? restitutions[c / 2 - 2] : 0.0, impulse, 0.0);
        y[c] = eomtest::gauss_solve(k.A, k.b);
        for (int i = 0; i < nv && impulse; ++i) y[c][i] += v[i];  // v⁺ = v⁻ + (v⁺ − v⁻)
      }
      return y;
    };
    const std::array<std::vector<dd_real>, 8> at_x = solutions(base, base_frames, v0.data());
    for (int j = 0; j < 2 * nv + nu; ++j) {
      std::array<std::vector<dd_real>, 8> moved;
      {
        const dd_real step = h;
        std::array<dd_real, nq> q = q0;
        std::array<dd_real, nv> v = v0;
        std::array<dd_real, nu> u = u0;
        if (j < nv) {
          std::array<dd_real, nv> dir{};
          dir[j] = 1.0;
          eom::integrate_configuration(eom::Layout(nq, nv), q0.data(), dir.data(), step, q.data());
          moved = solutions(eomtest::dynamics_terms<RD>(q.data(), v.data(), u.data(), pd.data()),
                                 frames(q.data(), v.data()), v.data());
        } else if (j < 2 * nv) {
          v[j - nv] += step;
          Terms d = eomtest::dynamics_terms<RD>(q.data(), v.data(), u.data(), pd.data(), false);
          d.M = base.M;
          moved = solutions(d, frames(q.data(), v.data()), v.data());
        } else {  // only Q depends on u
          u[j - 2 * nv] += step;
          std::array<dd_real, nv> Q;
          RD::generalized_forces(dd_real(0.0), q.data(), v.data(), u.data(), pd.data(), Q.data());
          Terms d = base;
          for (int i = 0; i < nv; ++i) d.f[i] += Q[i] - Q0[i];
          moved = solutions(d, base_frames, v.data());
        }
      }
      for (int c = 0; c < 8; ++c) {
        std::vector<double> column;
        for (std::size_t i = 0; i < moved[c].size(); ++i) column.push_back(to_double((moved[c][i] - at_x[c][i]) / h));
        diff[c].push_back(column);
      }
    }
    // block (first, count) of directions against the kernel's velocity and force blocks
    auto compare = [&](int c, int first, int count, const std::vector<double>& velocity,
                       const std::vector<double>& force, double& worst_velocity, double& worst_force) {
      const int rows = K::contact_rows[c % 2];
      std::vector<double> ev, ef;
      for (int j = first; j < first + count; ++j) {
        ev.insert(ev.end(), diff[c][j].begin(), diff[c][j].begin() + nv);
        ef.insert(ef.end(), diff[c][j].begin() + nv, diff[c][j].end());
      }
      worst_velocity = std::max(worst_velocity, eomtest::kernel_error(velocity.data(), ev.data(), nv * count));
      worst_force = std::max(worst_force, eomtest::kernel_error(force.data(), ef.data(), rows * count));
    };
    for (int c = 0; c < 8; ++c) {
      const int s = c % 2, rows = K::contact_rows[s];
      std::vector<double> vq(nv * nv), vv(nv * nv), vu(nv * nu), lq(rows * nv), lv(rows * nv), lu(rows * nu);
      if (c < 4) {
        ASSERT_TRUE(K::contact_dynamics_derivatives(s, 0.0, x.q.data(), x.v.data(), x.u.data(), p.data(), gains[c / 2],
                                                    0.0, vq.data(), vv.data(), vu.data(), lq.data(), lv.data(),
                                                    lu.data()));
        compare(c, 0, nv, vq, lq, worst_vdot[0], worst_lambda[0]);
        compare(c, nv, nv, vv, lv, worst_vdot[1], worst_lambda[1]);
        compare(c, 2 * nv, nu, vu, lu, worst_vdot[2], worst_lambda[2]);
        if (c >= 2) {  // kd = 0's kernel against kd = 5's differences: what a wrong term costs
          double ignored = 0;
          compare(c - 2, nv, nv, vv, lv, wrong_gain, ignored);
        }
      } else {
        ASSERT_TRUE(K::impulse_dynamics_derivatives(s, x.q.data(), x.v.data(), p.data(), restitutions[c / 2 - 2], 0.0,
                                                    vq.data(), vv.data(), lq.data(), lv.data()));
        compare(c, 0, nv, vq, lq, worst_vplus[0], worst_impulse[0]);
        compare(c, nv, nv, vv, lv, worst_vplus[1], worst_impulse[1]);
      }
    }
  }
  std::printf("MuJoCo's humanoid on two and on one 6d foot (state %d, kd = 5 and 0), against dd_real "
              "differences of the KKT solve: dvdot/dq %.2g, /dv %.2g, /du %.2g; dlambda/dq %.2g, /dv %.2g, /du %.2g\n",
              draw, worst_vdot[0], worst_vdot[1], worst_vdot[2], worst_lambda[0], worst_lambda[1], worst_lambda[2]);
  std::printf("  impulse (e = 0, 0.5): dv+/dq %.2g, /dv- %.2g; dLambda/dq %.2g, /dv- %.2g; kd = 0's dvdot/dv "
              "against kd = 5's differences %.2g (%.1f s)\n",
              worst_vplus[0], worst_vplus[1], worst_impulse[0], worst_impulse[1], wrong_gain,
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  // measured 4.4e-14, 1.7e-14, 5.6e-15; 1.6e-14, 1.0e-14, 3.8e-15; impulse 1.3e-14, 4.7e-15;
  // 4.5e-15, 3.8e-15 (central differences, h = 1e-12, at twice the time: at most 2.8e-14, the
  // values' round-off, 1.7e-14 and 3.6e-14 above); kd = 0's kernel against kd = 5's differences 0.48
  for (double e : worst_vdot) EXPECT_LT(e, 2e-13);
  for (double e : worst_lambda) EXPECT_LT(e, 2e-13);
  for (double e : worst_vplus) EXPECT_LT(e, 2e-13);
  for (double e : worst_impulse) EXPECT_LT(e, 2e-13);
  EXPECT_GT(wrong_gain, 1e-3);  // the comparison sees a wrong term
}

TEST(MjcfContacts, HumanoidDerivativesMatchDifferencesOfTheKktSolveInDoubleDouble) { check_derivatives(0); }
