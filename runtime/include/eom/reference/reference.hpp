// eom::Reference<Model>: every kernel of docs/CONTRACT.md §3, with the generated signatures, computed at run
// time by operator-overloading AD (the OCEA way: one embedded evaluation of T over x = (q, q̇)
// yields ∂T/∂q, M and the mixed block ∂²T/∂q̇∂q of eq. 8). It is the oracle every generated kernel
// is tested against and the baseline it is benchmarked against, so it favours the direct reading
// of the definitions over speed.
//
// With a free joint (eom/model/free_joint.hpp) the velocity is v (nv = nq − 1) rather than q̇: T is
// evaluated along q̇ = G(q) v, every gradient over q is taken along G's columns (the tangent
// space), and c gains the term the quaternion's non-commuting directions give (the Euler term
// ω × ∂T/∂ω, see mass_and_coriolis). Without one, v = q̇ and G = 1.
//
// Real is the arithmetic type (double by default; long double or qd's dd_real give
// high-precision reference trajectories from the very same model source).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <span>
#include <string_view>
#include <type_traits>

#include "eom/model/kernels.hpp"
#include "eom/model/model.hpp"
#include "eom/multibody/body_check.hpp"
#include "eom/multibody/frames.hpp"
#include "eom/numeric/ad.hpp"
#include "eom/numeric/jet.hpp"
#include "eom/numeric/linalg.hpp"
#include "eom/reference/heap_stack.hpp"

namespace eom {

template <class Model, class Real = double>
struct Reference {
  using Info = ModelInfo<Model>;
  static_assert(Info::valid);
  static constexpr int nq = Info::nq, nv = Info::nv, np = Info::np, nu = Info::nu, nc = Info::nc;
  static constexpr auto quaternions = Info::quaternions;  // eom/model/free_joint.hpp
  using model_type = Model;
  using real_type = Real;

  static constexpr std::array<std::string_view, np> parameter_names = [] {
    std::array<std::string_view, np> n{};
    if constexpr (np > 0)
      for (int i = 0; i < np; ++i) n[i] = Model::parameters[i];
    return n;
  }();
  static constexpr std::array<double, np> parameter_values = Info::default_parameters();
  static constexpr int nframes = Info::nframes;
  static constexpr std::array<std::string_view, nframes> frame_names = Info::frame_names;

  // ---- kernels (docs/CONTRACT.md §3) --------------------------------------------------------------------

  static Real kinetic_energy(const Real* q, const Real* qd, const Real* p) noexcept {
    debug_check_bodies(q, p, "kinetic_energy");
    return kinetic_energy_of<Model, Real>(in(q, nq), in(qd, nv), in(p, np));
  }
  static Real potential_energy(const Real* q, const Real* p) noexcept {
    return Model::template potential_energy<Real>(in(q, nq), in(p, np));
  }

  // M = ∂²T/∂v² (eq. 7), column-major; T is quadratic in v, so it is evaluated at v = 0.
  static void mass_matrix(const Real* q, const Real* p, Real* M) noexcept {
    return on_heap<Embedded<nv, Real, 2>>([&] {
      debug_check_bodies(q, p, "mass_matrix");
      using A = Embedded<nv, Real, 2>;
      const std::array<Real, nv> zero{};
      const A T = kinetic_energy_of<Model, A>(lift<A, nq>(q), seed<A, nv>(zero.data(), 0),
                                                    lift<A, np>(p));
      for (int i = 0; i < nv; ++i)
        for (int j = 0; j < nv; ++j) M[i + nv * j] = T.hessian(i, j);
    });
  }

  // Ṁ = Σₖ ∂M/∂qₖ q̇ₖ: the Hessian over v carried as a directional derivative along q̇ = G v in q.
  static void mass_matrix_dot(const Real* q, const Real* qd, const Real* p, Real* Mdot) noexcept {
    return on_heap<Embedded<nv, Embedded<1, Real, 1>, 2>>([&] {
      debug_check_bodies(q, p, "mass_matrix_dot");
      using D = Embedded<1, Real, 1>;
      using A = Embedded<nv, D, 2>;
      std::array<Real, nq> rate;
      configuration_rate(Info::layout, q, qd, rate.data());
      std::array<A, nq> qa;
      std::array<A, nv> qda;
      for (int i = 0; i < nq; ++i) {
        D qi(q[i]);
        qi.g[0] = rate[i];
        qa[i] = A(qi);
      }
      for (int i = 0; i < nv; ++i) qda[i] = A::variable(D(Real(0)), i);
      const A T = kinetic_energy_of<Model, A>(qa, qda, lift<A, np>(p));
      for (int i = 0; i < nv; ++i)
        for (int j = 0; j < nv; ++j) Mdot[i + nv * j] = T.hessian(i, j).g[0];
    });
  }

  // c = Ṁ q̇ − ∂T/∂q (eqs. 6, 8, 11), from one embedded evaluation of T over (q, q̇).
  static void coriolis(const Real* q, const Real* qd, const Real* p, Real* c) noexcept {
    return on_heap<Hessian<Real>>([&] {
      debug_check_bodies(q, p, "coriolis");
      std::array<Real, nv * nv> M;
      mass_and_coriolis(q, qd, p, M.data(), c);
    });
  }

  static void potential_gradient(const Real* q, const Real* p, Real* dVdq) noexcept {
    return on_heap<Embedded<nq, Real, 1>>([&] {
      gradient_of_potential(q, p, dVdq);
    });
  }

  static void generalized_forces(Real t, const Real* q, const Real* qd, const Real* u,
                                 const Real* p, Real* Q) noexcept {
    forces(t, q, qd, u, p, Q);
  }

  static void constraint_residual(const Real* q, const Real* p, Real* phi) noexcept
    requires(nc > 0)
  {
    Model::template constraints<Real>(in(q, nq), in(p, np), std::span<Real>(phi, nc));
  }

  // C = ∂φ/∂q G (eq. 10), nc×nv column-major.
  static void constraint_jacobian(const Real* q, const Real* p, Real* C) noexcept
    requires(nc > 0)
  {
    return on_heap<Embedded<nq, Real, 1>>([&] {
      using A = Embedded<nq, Real, 1>;
      std::array<A, nc> phi;
      Model::template constraints<A>(seed<A, nq>(q, 0), lift<A, np>(p), phi);
      for (int i = 0; i < nc; ++i) {
        std::array<Real, nv> row;
        tangent_gradient(Info::layout, q, phi[i].g.data(), row.data());
        for (int j = 0; j < nv; ++j) C[i + nc * j] = row[j];
      }
    });
  }

  // γ = Ċ v = q̇ᵀ (∂²φᵢ/∂q²) q̇ + (∂φᵢ/∂q) Ġ v, q̇ = G v.
  static void constraint_bias(const Real* q, const Real* qd, const Real* p, Real* gamma) noexcept
    requires(nc > 0)
  {
    return on_heap<Embedded<nq, Real, 2>>([&] {
      std::array<Real, nc * nv> C;
      jacobian_and_bias(q, qd, p, C.data(), gamma);
    });
  }

  // q̈ from [M Cᵀ; C 0][q̈; μ] = [Q − c − ∂V/∂q; −γ] (range-space method). False, with qdd set to
  // NaN, when an input is not finite or M or C M⁻¹ Cᵀ is not positive definite.
  static bool forward_dynamics(Real t, const Real* q, const Real* qd, const Real* u,
                               const Real* p, Real* qdd) noexcept {
    return on_heap<Hessian<Real>>([&] {
      debug_check_bodies(q, p, "forward_dynamics");
      return dynamics<Real>(t, q, qd, u, p, qdd);
    });
  }

  // ∂v̇/∂q, ∂v̇/∂v (nv×nv) and ∂v̇/∂u (nv×nu), column-major: forward_dynamics run on first-order
  // AD numbers over (q, v, u), q moving along G's columns (the tangent space: column j is
  // d/dε v̇(q ⊕ ε e_j), eom/model/free_joint.hpp; ∂v̇/∂q itself without a free joint), derivative_block
  // directions per evaluation.
  static bool forward_dynamics_derivatives(Real t, const Real* q, const Real* qd, const Real* u,
                                           const Real* p, Real* dqdd_dq, Real* dqdd_dqd,
                                           Real* dqdd_du) noexcept {
    return on_heap<Hessian<Embedded<derivative_block, Real, 1>>>([&] {
      std::array<Real, nq> column;
      const auto direction = [&](int d, int k, auto& qa, auto& qda, auto& ua, auto&) {
        if (d < nv) {
          configuration_direction(Info::layout, q, d, column.data());
          for (int i = 0; i < nq; ++i) qa[i].g[k] = column[i];
        } else if (d < 2 * nv) {
          qda[d - nv].g[k] = Real(1);
        } else if constexpr (nu > 0) {
          ua[d - 2 * nv].g[k] = Real(1);
        }
      };
      const auto output = [&](int d) {
        return d < nv ? dqdd_dq + nv * d : d < 2 * nv ? dqdd_dqd + nv * (d - nv) : dqdd_du + nv * (d - 2 * nv);
      };
      return dynamics_derivatives(2 * nv + nu, t, q, qd, u, p, direction, output);
    });
  }

  // ∂q̈/∂p (nq×np, column-major; column k along parameter k), for parameter identification:
  // forward_dynamics run on first-order AD numbers over p. False, all NaN, exactly when
  // forward_dynamics is false (the pivot tests see the values, not the derivatives).
  static bool forward_dynamics_parameter_derivatives(Real t, const Real* q, const Real* qd,
                                                     const Real* u, const Real* p,
                                                     Real* dqdd_dp) noexcept {
    return on_heap<Hessian<Embedded<derivative_block, Real, 1>>>([&] {
      const auto direction = [](int d, int k, auto&, auto&, auto&, auto& pa) {
        if constexpr (np > 0) pa[d].g[k] = Real(1);
      };
      return dynamics_derivatives(np, t, q, qd, u, p, direction, [&](int d) { return dqdd_dp + nv * d; });
    });
  }

  // τ = M q̈ + c + ∂V/∂q − Q: the extra generalized force that q̈ needs (constraints ignored).
  static void inverse_dynamics(Real t, const Real* q, const Real* qd, const Real* qdd,
                               const Real* u, const Real* p, Real* tau) noexcept {
    return on_heap<Hessian<Real>>([&] {
      inverse<Real>(t, q, qd, qdd, u, p, tau);
    });
  }

  // ∂τ/∂q (tangent space) and ∂τ/∂v (nv × nv each, column-major): inverse_dynamics on first-order
  // AD numbers over (q, v), derivative_block directions per evaluation (like
  // forward_dynamics_derivatives: all 2 nv at once made a 30-link tree's numbers 0.9 MB each,
  // and its frames overflowed even the heap stack).
  static void inverse_dynamics_derivatives(Real t, const Real* q, const Real* qd, const Real* qdd,
                                           const Real* u, const Real* p, Real* dtau_dq,
                                           Real* dtau_dqd) noexcept {
    return on_heap<Hessian<Embedded<derivative_block, Real, 1>>>([&] {
      using A = Embedded<derivative_block, Real, 1>;
      std::array<Real, nq> column;
      for (int b = 0; b < 2 * nv; b += derivative_block) {
        auto qa = lift<A, nq>(q);
        auto qda = lift<A, nv>(qd);
        const int count = std::min(derivative_block, 2 * nv - b);
        for (int k = 0; k < count; ++k) {
          if (b + k < nv) {
            configuration_direction(Info::layout, q, b + k, column.data());
            for (int i = 0; i < nq; ++i) qa[i].g[k] = column[i];
          } else {
            qda[b + k - nv].g[k] = Real(1);
          }
        }
        const auto qdda = lift<A, nv>(qdd);
        const auto ua = lift<A, nu>(u);
        const auto pa = lift<A, np>(p);
        std::array<A, nv> tau;
        inverse<A>(A(t), qa.data(), qda.data(), qdda.data(), ua.data(), pa.data(), tau.data());
        for (int k = 0; k < count; ++k) {
          Real* out = b + k < nv ? dtau_dq + nv * (b + k) : dtau_dqd + nv * (b + k - nv);
          for (int i = 0; i < nv; ++i) out[i] = tau[i].g[k];
        }
      }
    });
  }

  // ---- task space (eom/multibody/frames.hpp: its conventions) ---------------------------------------
  // Frame f's placement; f outside [0, nframes): NaN.
  static void frame_placement(int f, const Real* q, const Real* p, Real* position,
                              Real* rotation) noexcept
    requires(nframes > 0)
  {
    return on_heap<Real>([&] {
      if (f < 0 || f >= nframes) {
        fill_nan(position, 3);
        fill_nan(rotation, 9);
        return;
      }
      std::array<Frame<Real>, nframes> x;
      frame_placements<Model, Real>(in(q, nq), in(p, np), x);
      for (int k = 0; k < 3; ++k) position[k] = x[f].position[k];
      for (int k = 0; k < 9; ++k) rotation[k] = x[f].rotation[k];
    });
  }

  // J (6 × nv): the placement differentiated along each tangent direction j, the origin's
  // velocity directly, the angular velocity from Ṙ Rᵀ.
  static void frame_jacobian(int f, const Real* q, const Real* p, Real* J) noexcept
    requires(nframes > 0)
  {
    return on_heap<Embedded<nv, Real, 1>>([&] {
      if (f < 0 || f >= nframes) {
        fill_nan(J, 6 * nv);
        return;
      }
      using A = Embedded<nv, Real, 1>;
      std::array<Frame<A>, nframes> x;
      frame_placements<Model, A>(seed_tangent<A>(q), lift<A, np>(p), x);
      Rot3<Real> R, dR;
      for (int k = 0; k < 9; ++k) R[k] = x[f].rotation[k].v;
      for (int j = 0; j < nv; ++j) {
        for (int k = 0; k < 9; ++k) dR[k] = x[f].rotation[k].g[j];
        const Vec3<Real> w = detail::world_angular_velocity(R, dR);
        for (int k = 0; k < 3; ++k) {
          J[k + 6 * j] = x[f].position[k].g[j];
          J[3 + k + 6 * j] = w[k];
        }
      }
    });
  }

  // a = J̇ v: the placement along the motion q(t) with q̇ = G(q) v, q̈ = Ġ v (v̇ = 0), to second
  // order in t: the origin's ẍ, and ω̇ = (R̈ Rᵀ + Ṙ Ṙᵀ)^∨.
  static void frame_acceleration_bias(int f, const Real* q, const Real* qd, const Real* p,
                                      Real* a) noexcept
    requires(nframes > 0)
  {
    return on_heap<Embedded<1, Real, 2>>([&] {
      if (f < 0 || f >= nframes) {
        fill_nan(a, 6);
        return;
      }
      using A = Embedded<1, Real, 2>;
      std::array<Real, nq> rate, bias;
      configuration_rate(Info::layout, q, qd, rate.data());
      configuration_rate_bias(Info::layout, q, qd, bias.data());
      std::array<A, nq> qa;
      for (int i = 0; i < nq; ++i) {
        qa[i] = A(q[i]);
        qa[i].g[0] = rate[i];
        qa[i].h[0] = bias[i];
      }
      std::array<Frame<A>, nframes> x;
      frame_placements<Model, A>(qa, lift<A, np>(p), x);
      Rot3<Real> R, dR, ddR;
      for (int k = 0; k < 9; ++k) {
        R[k] = x[f].rotation[k].v;
        dR[k] = x[f].rotation[k].g[0];
        ddR[k] = x[f].rotation[k].hessian(0, 0);
      }
      const Vec3<Real> w1 = detail::world_angular_velocity(R, ddR), w2 = detail::world_angular_velocity(dR, dR);
      for (int k = 0; k < 3; ++k) {
        a[k] = x[f].position[k].hessian(0, 0);
        a[3 + k] = w1[k] + w2[k];
      }
    });
  }

  static void center_of_mass(const Real* q, const Real* p, Real* com) noexcept
    requires(detail::declares_bodies<Model>)
  {
    return on_heap<Real>([&] {
      const Vec3<Real> x = eom::center_of_mass<Model, Real>(in(q, nq), in(p, np));
      for (int k = 0; k < 3; ++k) com[k] = x[k];
    });
  }

  // ∂G/∂q along the tangent directions (3 × nv).
  static void center_of_mass_jacobian(const Real* q, const Real* p, Real* J) noexcept
    requires(detail::declares_bodies<Model>)
  {
    return on_heap<Embedded<nv, Real, 1>>([&] {
      using A = Embedded<nv, Real, 1>;
      const auto qa = seed_tangent<A>(q);
      const auto pa = lift<A, np>(p);
      const Vec3<A> x = eom::center_of_mass<Model, A>(qa, pa);
      for (int j = 0; j < nv; ++j)
        for (int k = 0; k < 3; ++k) J[k + 3 * j] = x[k].g[j];
    });
  }

  // The centroidal momentum's derivative over v (6 × nv): it is linear in v.
  static void centroidal_momentum_matrix(const Real* q, const Real* p, Real* A_G) noexcept
    requires(detail::declares_bodies<Model>)
  {
    return on_heap<Embedded<nv, Real, 1>>([&] {
      using A = Embedded<nv, Real, 1>;
      const std::array<Real, nv> zero{};
      const auto qa = lift<A, nq>(q);
      const auto va = seed<A, nv>(zero.data(), 0);
      const auto pa = lift<A, np>(p);
      const std::array<A, 6> h = centroidal_momentum<Model, A>(qa, va, pa);
      for (int j = 0; j < nv; ++j)
        for (int k = 0; k < 6; ++k) A_G[k + 6 * j] = h[k].g[j];
    });
  }

  // ---- Taylor coefficients (contract: generator/README.md, "Taylor mode") ------------
  // qk[k·nq + i] = q_i⁽ᵏ⁾(t)/k!, qdk[k·nv + i] = v_i⁽ᵏ⁾(t)/k! for k = 0..order of the solution of
  // v̇ = forward_dynamics, q̇ = G(q) v through (t, q, v), u held constant and t advancing. Computed
  // the direct way: for k = 0..order−1 the templated dynamics run on jets that know q and v to
  // order k (and t + τ), and coefficient k of v̇ gives v's coefficient k+1 (q's comes from
  // coefficient k of G(q) v: v's own without a free joint, exact bilinear kinematics with one).
  // Order k costs one evaluation on (k+1)-coefficient jets, O(order³) in all: the oracle, not
  // the fast path. Branches and pivot tests see order-0 values (Jet compares those), so the
  // result is false exactly when forward_dynamics is false at (t, q, q̇) — or, beyond the
  // contract's list, when a higher coefficient overflows to Inf/NaN. On false every output of
  // orders 0..order is NaN (nothing is written when order < 0). No workspace: work may be null.
  static constexpr int taylor_max_order = 32;
  static constexpr int taylor_workspace = 0;

  static bool taylor_coefficients(int order, Real t, const Real* q, const Real* qd, const Real* u,
                                  const Real* p, Real* qk, Real* qdk, Real* /*work*/) noexcept {
    return on_heap<Hessian<Jet<Real, taylor_max_order + 1>>>([&] {
      using J = Jet<Real, taylor_max_order + 1>;
      const auto fail = [&] {
        const Real bad(std::numeric_limits<double>::quiet_NaN());
        for (int k = 0; k < (order + 1) * nq; ++k) qk[k] = bad;
        for (int k = 0; k < (order + 1) * nv; ++k) qdk[k] = bad;
        return false;
      };
      if (order < 1 || order > taylor_max_order) return fail();
      for (int i = 0; i < nq; ++i) qk[i] = q[i];
      for (int i = 0; i < nv; ++i) qdk[i] = qd[i];
      std::array<J, nq> qj, rate;
      std::array<J, nv> qdj, qddj;
      std::array<J, nu> uj;
      std::array<J, np> pj;
      for (int i = 0; i < nu; ++i) uj[i] = J(u[i]);
      for (int i = 0; i < np; ++i) pj[i] = J(p[i]);
      std::array<Real, taylor_max_order + 1> series;
      for (int k = 0; k < order; ++k) {
        const int known = k + 1;  // coefficients 0..k of q and q̇ are known
        for (int i = 0; i < nq; ++i) {
          for (int j = 0; j < known; ++j) series[j] = qk[j * nq + i];
          qj[i] = J::truncated(series.data(), known);
        }
        for (int i = 0; i < nv; ++i) {
          for (int j = 0; j < known; ++j) series[j] = qdk[j * nv + i];
          qdj[i] = J::truncated(series.data(), known);
        }
        series[0] = t;
        if (known > 1) series[1] = Real(1);
        for (int j = 2; j < known; ++j) series[j] = Real(0);
        const J tj = J::truncated(series.data(), known);
        if (!dynamics<J>(tj, qj.data(), qdj.data(), uj.data(), pj.data(), qddj.data())) return fail();
        configuration_rate(Info::layout, qj.data(), qdj.data(), rate.data());
        for (int i = 0; i < nv; ++i) {
          const Real a = qddj[i].c[k];  // coefficient k of v̇ (a constant v̇ stores zeros)
          if (!linalg::is_finite(a)) return fail();
          qdk[(k + 1) * nv + i] = a / Real(k + 1);
        }
        for (int i = 0; i < nq; ++i) {
          const Real a = rate[i].c[k];
          if (!linalg::is_finite(a)) return fail();
          qk[(k + 1) * nq + i] = a / Real(k + 1);
        }
      }
      return true;
    });
  }

 private:
  template <class S> static In<S> in(const S* x, int n) { return In<S>(x, x ? n : 0); }

  // f() on the thread's heap stack (eom/reference/heap_stack.hpp) when Big, the largest AD number the
  // kernel evaluates the model on, is over heap_stack_threshold bytes: the model's code keeps
  // hundreds of them in its frames (a tree's links, the bodies), which outgrows a thread's stack
  // on big models. Smaller ones (a 7-coordinate arm's M, c and q̈) run on the caller's stack and
  // skip the switch (about 2 µs).
  static constexpr std::size_t heap_stack_threshold = 1024;
  template <class R> using Hessian = Embedded<nq + nv, R, 2>;  // mass_and_coriolis's numbers
  template <class Big, class F> static std::invoke_result_t<F&> on_heap(F f) noexcept {
    using R = std::invoke_result_t<F&>;
    if constexpr (sizeof(Big) <= heap_stack_threshold) {
      return f();
    } else if constexpr (std::is_void_v<R>) {
      detail::on_heap_stack(f);
    } else {
      R r{};
      detail::on_heap_stack([&] { r = f(); });
      return r;
    }
  }

  static void fill_nan(Real* x, int n) {
    for (int i = 0; i < n; ++i) x[i] = Real(std::numeric_limits<double>::quiet_NaN());
  }

  // Without NDEBUG, the calls that evaluate T first check the bodies' physical consistency
  // (eom/multibody/body_check.hpp) and, like assert, print what is wrong and abort.
  static void debug_check_bodies([[maybe_unused]] const Real* q, [[maybe_unused]] const Real* p,
                                 [[maybe_unused]] const char* function) noexcept {
#ifndef NDEBUG
    if constexpr (detail::declares_bodies<Model> && std::is_floating_point_v<Real>) {
      std::array<double, nq> qv;
      std::array<double, np> pv;
      for (int i = 0; i < nq; ++i) qv[i] = static_cast<double>(q[i]);
      for (int i = 0; i < np; ++i) pv[i] = static_cast<double>(p[i]);
      const std::string problem = body_problem<Model>(qv, pv);
      if (!problem.empty()) {
        std::fprintf(stderr, "eom::Reference<Model>::%s: bodies: %s\n", function, problem.c_str());
        std::abort();
      }
    }
#endif
  }

  // x as AD constants, or as the independent variables offset, offset+1, ...
  template <class A, int n, class R> static std::array<A, n> lift(const R* x) {
    std::array<A, n> a;
    for (int i = 0; i < n; ++i) a[i] = A(x[i]);
    return a;
  }
  template <class A, int n, class R> static std::array<A, n> seed(const R* x, int offset) {
    std::array<A, n> a;
    for (int i = 0; i < n; ++i) a[i] = A::variable(x[i], offset + i);
    return a;
  }
  // q with derivative j along G's column j (j < nv): the tangent directions.
  template <class A> static std::array<A, nq> seed_tangent(const Real* q) {
    std::array<A, nq> a;
    for (int i = 0; i < nq; ++i) a[i] = A(q[i]);
    std::array<Real, nq> column;
    for (int j = 0; j < nv; ++j) {
      configuration_direction(Info::layout, q, j, column.data());
      for (int i = 0; i < nq; ++i) a[i].g[j] = column[i];
    }
    return a;
  }

  // ∂V/∂q G (the force conjugate to v) by first-order AD over q, on any real type R (Real, or AD
  // numbers for derivatives).
  template <class R> static void gradient_of_potential(const R* q, const R* p, R* dVdq) {
    using A = Embedded<nq, R, 1>;
    const A V = Model::template potential_energy<A>(seed<A, nq>(q, 0), lift<A, np>(p));
    tangent_gradient(Info::layout, q, V.g.data(), dVdq);
  }

  // The model's generalized forces, or zeros when it has none.
  template <class R>
  static void forces(const R& t, const R* q, const R* qd, const R* u, const R* p, R* Q) {
    for (int i = 0; i < nv; ++i) Q[i] = R(0);
    if constexpr (Info::has_generalized_forces)
      Model::template generalized_forces<R>(t, in(q, nq), in(qd, nv), in(u, nu), in(p, np),
                                            std::span<R>(Q, nv));
  }

  // One evaluation of T over x = (q, v) gives M (vv block), ∂T/∂q and the mixed block:
  // c = (∂²T/∂v∂q) q̇ − Gᵀ ∂T/∂q (+ ω × ∂T/∂ω with a free joint), q̇ = G(q) v. That last term is
  // the Lie bracket of the quaternion's directions: for q̇ = G v the Lagrange equations
  // projected by Gᵀ read d/dt(∂T/∂v) − Gᵀ ∂T/∂q + [G_j, G v]ᵀ ∂T/∂q̇ = Q, and the bracket of the
  // body-rate directions ½ q ⊗ e is ½ q ⊗ (e_j × ω) (Euler's ω × J ω for a lone body).
  template <class R>
  static void mass_and_coriolis(const R* q, const R* qd, const R* p, R* M, R* c) {
    using A = Embedded<nq + nv, R, 2>;
    const A T = kinetic_energy_of<Model, A>(seed<A, nq>(q, 0), seed<A, nv>(qd, nq),
                                                  lift<A, np>(p));
    std::array<R, nq> rate, dT_dq;
    std::array<R, nv> tangent;
    configuration_rate(Info::layout, q, qd, rate.data());
    for (int i = 0; i < nq; ++i) dT_dq[i] = T.g[i];
    tangent_gradient(Info::layout, q, dT_dq.data(), tangent.data());
    for (int i = 0; i < nv; ++i) {
      R s = -tangent[i];
      for (int j = 0; j < nq; ++j) s += T.hessian(nq + i, j) * rate[j];
      for (int j = 0; j < nv; ++j) M[i + nv * j] = T.hessian(nq + i, nq + j);
      c[i] = s;
    }
    Info::layout.walk([](int, int) {}, [&](int, int j) {  // each quaternion's rows
      const R* w = qd + j;
      const R h[3] = {T.g[nq + j], T.g[nq + j + 1], T.g[nq + j + 2]};  // ∂T/∂ω
      c[j] += w[1] * h[2] - w[2] * h[1];
      c[j + 1] += w[2] * h[0] - w[0] * h[2];
      c[j + 2] += w[0] * h[1] - w[1] * h[0];
    });
  }

  template <class R>
  static void jacobian_and_bias(const R* q, const R* qd, const R* p, R* C, R* gamma) {
    using A = Embedded<nq, R, 2>;
    std::array<A, nc> phi;
    Model::template constraints<A>(seed<A, nq>(q, 0), lift<A, np>(p), phi);
    std::array<R, nq> rate, bias, gradient;
    std::array<R, nv> row;
    configuration_rate(Info::layout, q, qd, rate.data());
    configuration_rate_bias(Info::layout, q, qd, bias.data());
    for (int i = 0; i < nc; ++i) {
      R g(0);
      for (int j = 0; j < nq; ++j) {
        gradient[j] = phi[i].g[j];
        for (int k = 0; k < nq; ++k) g += rate[j] * phi[i].hessian(j, k) * rate[k];
      }
      if constexpr (nq != nv)  // Ġ v: nonzero on the quaternions only
        for (int j = 0; j < nq; ++j) g += gradient[j] * bias[j];
      tangent_gradient(Info::layout, q, gradient.data(), row.data());
      for (int j = 0; j < nv; ++j) C[i + nc * j] = row[j];
      gamma[i] = g;
    }
  }

  template <class R>
  static void inverse(const R& t, const R* q, const R* qd, const R* qdd, const R* u, const R* p, R* tau) {
    std::array<R, nv * nv> M;
    std::array<R, nv> c, dV, Q;
    mass_and_coriolis(q, qd, p, M.data(), c.data());
    gradient_of_potential(q, p, dV.data());
    forces(t, q, qd, u, p, Q.data());
    for (int i = 0; i < nv; ++i) {
      R s = c[i] + dV[i] - Q[i];
      for (int j = 0; j < nv; ++j) s += M[i + nv * j] * qdd[j];
      tau[i] = s;
    }
  }

  // The derivatives of v̇ along `directions` directions, derivative_block per evaluation of the
  // dynamics on first-order AD numbers (each direction's derivative takes the same operations
  // whatever the block holds, so the values do not depend on it; the numbers stay small:
  // derivative_block + 1 values instead of one per direction). direction(d, k, q, v, u, p) seeds
  // direction d as the numbers' k-th; output(d) is where its nv derivatives go. On failure (the
  // values' failure: forward_dynamics's) every output is NaN.
  static constexpr int derivative_block = 8;
  template <class Direction, class Output>
  static bool dynamics_derivatives(int directions, Real t, const Real* q, const Real* qd,
                                   const Real* u, const Real* p, Direction direction, Output output) {
    using A = Embedded<derivative_block, Real, 1>;
    bool ok = true;
    if (directions == 0) {
      std::array<Real, nv> qdd;
      ok = dynamics<Real>(t, q, qd, u, p, qdd.data());
    }
    for (int b = 0; ok && b < directions; b += derivative_block) {
      auto qa = lift<A, nq>(q);
      auto qda = lift<A, nv>(qd);
      auto ua = lift<A, nu>(u);
      auto pa = lift<A, np>(p);
      const int count = std::min(derivative_block, directions - b);
      for (int k = 0; k < count; ++k) direction(b + k, k, qa, qda, ua, pa);
      std::array<A, nv> qdd;
      ok = dynamics<A>(A(t), qa.data(), qda.data(), ua.data(), pa.data(), qdd.data());
      for (int k = 0; k < count; ++k)
        for (int i = 0; i < nv; ++i) output(b + k)[i] = qdd[i].g[k];
    }
    if (!ok)
      for (int d = 0; d < directions; ++d) fill_nan(output(d), nv);
    return ok;
  }

  template <class R>
  static bool dynamics(R t, const R* q, const R* qd, const R* u, const R* p, R* qdd) {
    auto fail = [&] {
      for (int i = 0; i < nv; ++i) qdd[i] = R(std::numeric_limits<double>::quiet_NaN());
      return false;
    };
    if (!linalg::is_finite(t)) return fail();
    for (int i = 0; i < nq; ++i)
      if (!linalg::is_finite(q[i])) return fail();
    for (int i = 0; i < nv; ++i)
      if (!linalg::is_finite(qd[i])) return fail();
    for (int i = 0; i < nu; ++i)
      if (!linalg::is_finite(u[i])) return fail();
    for (int i = 0; i < np; ++i)
      if (!linalg::is_finite(p[i])) return fail();

    std::array<R, nv * nv> M;
    std::array<R, nv> f, dV, Q;
    mass_and_coriolis(q, qd, p, M.data(), f.data());  // f = c for now
    gradient_of_potential(q, p, dV.data());
    forces(t, q, qd, u, p, Q.data());
    for (int i = 0; i < nv; ++i) f[i] = Q[i] - f[i] - dV[i];

    std::array<R, nc * nv> C{};
    std::array<R, nc> gamma{};
    if constexpr (nc > 0) jacobian_and_bias(q, qd, p, C.data(), gamma.data());
    std::array<R, nv> out;
    if (!linalg::solve_constrained<R, nv, nc>(M, f, C, gamma, out.data())) return fail();
    for (int i = 0; i < nv; ++i)
      if (!linalg::is_finite(out[i])) return fail();
    for (int i = 0; i < nv; ++i) qdd[i] = out[i];
    return true;
  }
};

}  // namespace eom
