// eom_bench_floating: the free joint's targets (issue "free-flying systems"), side by side in one
// binary, every kernel compiled with the same flags:
//   - the Panda on a free base (models/robots/panda.urdf, FLOATING_BASE): generated
//     forward_dynamics, inverse_dynamics and forward_dynamics_derivatives against the recursive
//     ABA, RNEA and forward differences of the ABA (tests/support/recursive_dynamics.hpp, double);
//   - a lone free body (every parameter folded, mass centre at the frame origin): generated
//     forward_dynamics against a hand-written Newton–Euler step, v̇ = F/m, ω̇ = J⁻¹(τ − ω × Jω),
//     called as a function like the kernel, and again inlined into the timing loop.
// Each pair is timed in alternating rounds (1000 calls per round, 201 rounds); the figure is the
// median of the per-round ratios, so that the machine's load changes both sides alike.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <bench_free_body.hpp>
#include <bench_free_panda.hpp>

#include <eom/model/free_joint.hpp>
#include <eom/multibody/spatial.hpp>
#include <eom/multibody/tree.hpp>

#include "paired_timing.hpp"
#include "recursive_dynamics.hpp"

using eombench::compare, eombench::sink;

// The hand-written Newton–Euler step of a lone free body (inertia J about its mass centre in body
// axes, J⁻¹ kept once): v̇ = F/m, ω̇ = J⁻¹(τ − ω × Jω), here with no force and no moment.
struct NewtonEuler {
  std::array<double, 6> J, Jinv;  // xx, yy, zz, xy, xz, yz
  void step(const double* v, double* vdot) const {
    const double* w = v + 3;
    const std::array<double, 3> Jw = eom::detail::inertia_times(J, std::array<double, 3>{w[0], w[1], w[2]});
    const std::array<double, 3> r{-(w[1] * Jw[2] - w[2] * Jw[1]), -(w[2] * Jw[0] - w[0] * Jw[2]),
                                  -(w[0] * Jw[1] - w[1] * Jw[0])};
    const std::array<double, 3> dw = eom::detail::inertia_times(Jinv, r);
    vdot[0] = vdot[1] = vdot[2] = 0.0;  // F = 0
    vdot[3] = dw[0];
    vdot[4] = dw[1];
    vdot[5] = dw[2];
  }
};
// Called as the generated kernel is: a function call, not inlined (the second figure has the step
// inlined into the timing loop, as a user's own code may).
[[gnu::noinline]] void newton_euler_call(const NewtonEuler& body, const double* v, double* vdot) {
  body.step(v, vdot);
}

int main() {
  std::printf("%-58s %12s %12s\n", "kernel (generated vs baseline)", "generated", "baseline");
  // ---- the Panda on a free base --------------------------------------------------------------
  {
    namespace K = bench_free_panda;
    constexpr int nq = K::nq, nv = K::nv, nu = K::nu;
    const auto robot = eom::urdf::read(std::string(EOM_ROBOTS_DIR) + "/panda.urdf", true);
    eomtest::RecursiveDynamics<double> rd(robot);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> x(-1, 1);
    constexpr int states = 64;
    std::vector<std::array<double, nq>> q(states);
    std::vector<std::array<double, nv>> v(states), a(states), tau(states);
    std::vector<std::array<double, nu>> u(states);
    for (int s = 0; s < states; ++s) {
      for (double& e : q[s]) e = x(rng);
      eom::normalize_configuration(eom::Layout(nq, nv), q[s].data());
      for (double& e : v[s]) e = x(rng);
      for (double& e : a[s]) e = x(rng);
      for (double& e : u[s]) e = 5 * x(rng);
      tau[s] = {};
      for (int i = 0; i < nu; ++i) tau[s][6 + i] = u[s][i];
    }
    const auto& p = K::parameter_values;
    std::array<double, nv> out;
    std::array<double, nv * nv> dq, dv;
    std::array<double, nv * nu> du;
    auto generated_fd = [&](int i) {
      const int s = i % states;
      K::forward_dynamics(0.0, q[s].data(), v[s].data(), u[s].data(), p.data(), out.data());
      sink = out[0];
    };
    auto aba = [&](int i) {
      const int s = i % states;
      rd.forward_dynamics(q[s], v[s], tau[s], out);
      sink = out[0];
    };
    compare("free Panda forward_dynamics / recursive ABA", generated_fd, aba);
    auto generated_id = [&](int i) {
      const int s = i % states;
      K::inverse_dynamics(0.0, q[s].data(), v[s].data(), a[s].data(), u[s].data(), p.data(), out.data());
      sink = out[0];
    };
    auto rnea = [&](int i) {
      const int s = i % states;
      rd.inverse_dynamics(q[s], v[s], a[s], out);
      sink = out[0];
    };
    compare("free Panda inverse_dynamics / recursive RNEA", generated_id, rnea);
    auto generated_d = [&](int i) {
      const int s = i % states;
      K::forward_dynamics_derivatives(0.0, q[s].data(), v[s].data(), u[s].data(), p.data(),
                                      dq.data(), dv.data(), du.data());
      sink = dq[0];
    };
    auto differences = [&](int i) {  // forward differences of the ABA: 1 + nv + nv + nu calls
      const int s = i % states;
      std::array<double, nv> base, f, e{};
      std::array<double, nq> moved;
      const double h = 1e-7;
      rd.forward_dynamics(q[s], v[s], tau[s], base);
      for (int j = 0; j < nv; ++j) {
        e.fill(0.0);
        e[j] = 1.0;
        eom::integrate_configuration(eom::Layout(nq, nv), q[s].data(), e.data(), h, moved.data());
        rd.forward_dynamics(moved, v[s], tau[s], f);
        for (int k = 0; k < nv; ++k) dq[k + nv * j] = (f[k] - base[k]) / h;
      }
      for (int j = 0; j < nv; ++j) {
        auto w = v[s];
        w[j] += h;
        rd.forward_dynamics(q[s], w, tau[s], f);
        for (int k = 0; k < nv; ++k) dv[k + nv * j] = (f[k] - base[k]) / h;
      }
      for (int j = 0; j < nu; ++j) {
        auto t = tau[s];
        t[6 + j] += h;
        rd.forward_dynamics(q[s], v[s], t, f);
        for (int k = 0; k < nv; ++k) du[k + nv * j] = (f[k] - base[k]) / h;
      }
      sink = dq[0];
    };
    compare("free Panda forward_dynamics_derivatives / ABA differences", generated_d, differences);
  }
  // ---- a lone free body, every parameter folded ------------------------------------------------
  {
    namespace K = bench_free_body;
    static_assert(K::np == 0);
    // The body's inertia in body axes (FreeBody's inertial axes turned by rpy (0.3, -0.2, 0.5)),
    // and its inverse, once: what a hand-written step would keep.
    const auto R = eom::constant_rpy<double>({0.3, -0.2, 0.5});
    const auto J6 = eom::detail::rotated_inertia(R, std::array<double, 6>{0.3, 0.5, 0.7, 0.02, -0.01, 0.03});
    const double a = J6[0], b = J6[1], c = J6[2], d = J6[3], e = J6[4], f = J6[5];
    const double det = a * (b * c - f * f) - d * (d * c - f * e) + e * (d * f - b * e);
    const std::array<double, 6> Jinv{(b * c - f * f) / det, (a * c - e * e) / det,
                                     (a * b - d * d) / det, (e * f - d * c) / det,
                                     (d * f - b * e) / det, (d * e - a * f) / det};
    constexpr int states = 64;
    std::mt19937_64 rng(4);
    std::uniform_real_distribution<double> x(-1, 1);
    std::vector<std::array<double, 7>> q(states);
    std::vector<std::array<double, 6>> v(states);
    for (int s = 0; s < states; ++s) {
      for (double& y : q[s]) y = x(rng);
      eom::normalize_configuration(eom::Layout(7, 6), q[s].data());
      for (double& y : v[s]) y = 3 * x(rng);
    }
    // One output array per state, as the hand-written chain's benchmark keeps: into a single
    // array, the inlined step's stores (and the products only they need) left the loop.
    std::vector<std::array<double, 6>> vdot(states);
    auto generated = [&](int i) {
      const int s = i % states;
      K::forward_dynamics(0.0, q[s].data(), v[s].data(), nullptr, nullptr, vdot[s].data());
      sink = vdot[s][3];
    };
    const NewtonEuler body{J6, Jinv};
    auto called = [&](int i) {
      const int s = i % states;
      newton_euler_call(body, v[s].data(), vdot[s].data());
      sink = vdot[s][3];
    };
    compare("free body forward_dynamics / hand-written Newton-Euler", generated, called);
    auto inlined = [&](int i) {
      const int s = i % states;
      body.step(v[s].data(), vdot[s].data());
      sink = vdot[s][3];
    };
    compare("free body forward_dynamics / the same, inlined in the loop", generated, inlined);
  }
  return 0;
}
