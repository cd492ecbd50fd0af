// Sensitivities integrated alongside the state by the variational equations, x = (q, q̇):
//   Φ(t, t0) = ∂x(t)/∂x(t0):  Φ̇ = A Φ,      Φ(t0) = I,   A = [0 I; ∂q̈/∂q ∂q̈/∂q̇],
//   S(t) = ∂x(t)/∂p (on request, eom::with_parameters):
//                             Ṡ = A S + B,  S(t0) = 0,   B = [0; ∂q̈/∂p].
//
// The trick that makes every integrator of eom/integration/integrate.hpp integrate them unchanged: split
// Φ = [Φq; Φv] and S = [Sq; Sv] into position and velocity rows (n × 2n and n × np, n = nq).
// Then Φ̇q = Φv, Φ̇v = (∂q̈/∂q) Φq + (∂q̈/∂q̇) Φv, and Ṡq = Sv, Ṡv = (∂q̈/∂q) Sq + (∂q̈/∂q̇) Sv + ∂q̈/∂p,
// so (q, Φq, Sq) is again a "position" whose derivative is the "velocity" (q̇, Φv, Sv):
// eom::Sensitivity<K> is itself a second-order model, with
//   nq' = n (1 + 2n [+ np]),  q' = (q, vec Φq [, vec Sq]),  q̇' = (q̇, vec Φv [, vec Sv]),
//   q̈' = (q̈, vec((∂q̈/∂q) Φq + (∂q̈/∂q̇) Φv) [, vec((∂q̈/∂q) Sq + (∂q̈/∂q̇) Sv + ∂q̈/∂p)]),
// the derivatives coming from the exact kernels forward_dynamics_derivatives (∂q̈/∂q, ∂q̈/∂q̇) and,
// for S, forward_dynamics_parameter_derivatives (∂q̈/∂p over the free parameters: with
// FIXED_PARAMETERS, S has the free parameters' columns only), generated or eom::Reference.
// Step-size control then also watches Φ and S, as it should: the sensitivities are integrated to
// the same tolerance as the state. The augmented model takes the same p (and u) as the base model.
//
//   using S = eom::Sensitivity<K, eom::with_parameters>;   // or eom::Sensitivity<K>: Φ only
//   auto r = eom::integrate<S>(t0, t1, S::start(x0), u, p, opt);
//   S::state(r.x), S::transition(r.x) (Φ, 2n × 2n), S::parameter_sensitivity(r.x) (S, 2n × np)
//
// Cost per right-hand side: forward_dynamics and forward_dynamics_derivatives once (plus
// forward_dynamics_parameter_derivatives once with parameters), and the products, 2n² (2n + np)
// multiply-adds; the integrator works on 2n (1 + 2n + np) numbers instead of 2n. Φ alone
// (the default) carries no parameter columns and never calls the parameter kernel, which is
// generated only on request: eom::Sensitivity<K, eom::with_parameters> over a Kernels type
// without it stops the build with eom::RequireKernels' message naming
// forward_dynamics_parameter_derivatives.
//
// Methods: rk4, dopri5 and dop853 through eom::integrate over any base; taylor and taylor_paper
// over K = eom::Reference<Model> only (the augmented Taylor coefficients come from running the
// model on jets; a generated Kernels type is double-only, so Sensitivity<generated Kernels> has no
// taylor_coefficients; the reference's path is the oracle, not the fast one: at order p, 3p
// evaluations of the model on jets, O(p³) per step). Not radau5 (the augmented model has no
// forward_dynamics_derivatives of its own). eom::integrate returns Status::method_unavailable for
// a method a model cannot run.
//
// A free joint (eom/model/free_joint.hpp): x = (q, v) and Φ, S are taken in the tangent space, 2nv rows
// (δθ of the perturbation q ⊕ δ = (x + δx, q ⊗ exp(δθ/2), joints + δq), then δv), so Φ is
// 2nv × 2nv and ∂q̈/∂q is the kernel's tangent derivative D_q. The rotation rows of Φq then move
// as δθ̇ = δω − ω × δθ (the linearization of q̇ = ½ q ⊗ (0, ω) about a perturbed q ⊗ exp(δθ/2)),
// not as δω. The second-order form is kept by carrying Ψ = Φv − ω × Φq (rotation rows; Φv
// elsewhere) as the velocity of Φq, so that Φ̇q = Ψ exactly, with
//   Ψ̇ = D_q Φq + D_v Φv − ω̇ × Φq − ω × Ψ   (rotation rows; D_q Φq + D_v Φv elsewhere),
// and likewise for S (plus ∂v̇/∂p): the augmented model is again a model with a free joint,
// nq' = nv' + 1 (the base's q, then vec Φq, vec Sq), and the integrators normalize its quaternion
// as the base's. start(), state(), transition() and parameter_sensitivity() convert Φv ↔ Ψ. Not
// offered there: the Taylor methods (the reference's augmented coefficients assume q̇ = v).
//
// Scope: unconstrained models (nc = 0). For a constrained model the variational equations of the
// index-1 dynamics would drift off the tangent space and projection would have to act on Φ too;
// not offered. Inputs u are held as given (∂x/∂u is not computed).
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <type_traits>

#include "eom/integration/state.hpp"
#include "eom/model/kernels.hpp"
#include "eom/numeric/jet.hpp"
#include "eom/reference/reference.hpp"

namespace eom {

// What eom::Sensitivity integrates besides the state: Φ only (the default), or Φ and ∂x/∂p.
struct transition_only {};
struct with_parameters {};

namespace detail {
// K itself for Φ alone; through RequireKernels when ∂x/∂p needs the on-request parameter kernel
// (a specialization, so that a Φ-only user never instantiates the requirement).
template <class K, class Extent> struct SensitivityKernels { using type = K; };
template <class K> struct SensitivityKernels<K, with_parameters> {
  using type = eom::RequireKernels<K, Kernel::forward_dynamics_parameter_derivatives>;
};

// The Taylor-coefficient kernel of the augmented model (contract: generator/README.md, "Taylor mode"), offered when
// the base is eom::Reference<Model> in double: the same Model then runs on Taylor jets, so that
// ∂q̈/∂q, ∂q̈/∂q̇ and ∂q̈/∂p come out as series in time along the trajectory, and coefficient k of
// Φ̈ = (∂q̈/∂q) Φq + (∂q̈/∂q̇) Φv (and of S̈) is a convolution of known coefficients. Generated
// kernels are double-only straight-line code whose derivatives cannot be expanded in time that
// way: no Taylor method over Sensitivity<generated Kernels>.
template <class K> struct IsDoubleReference : std::false_type {};
template <class Model> struct IsDoubleReference<Reference<Model, double>> : std::true_type {};

template <class K, int ns, bool = IsDoubleReference<K>::value && nv_of<K> == K::nq>
struct SensitivityTaylor {};
template <class K, int ns> struct SensitivityTaylor<K, ns, true> {
  // Order 20 already serves tolerances down to e^(−38) ≈ 3e-17 (taylor.hpp), beyond double; a
  // shorter jet is cheaper to copy through the model's AD numbers.
  static constexpr int taylor_max_order = K::taylor_max_order < 20 ? K::taylor_max_order : 20;
  static constexpr int taylor_workspace = 0;

  // As K::taylor_coefficients, over the augmented state of Sensitivity (q' = (q, vec Φq, vec Sq),
  // q̇' = (q̇, vec Φv, vec Sv)). Order k of every quantity is computed from orders 0..k: the
  // model runs on jets that know q, q̇ to order k (O(order³) in all, like the reference's own).
  static bool taylor_coefficients(int order, double t, const double* q, const double* qd,
                                  const double* u, const double* p, double* qk, double* qdk,
                                  double* /*work*/) noexcept {
    constexpr int n = K::nq, m = 2 * n, na = n * (1 + m + ns), nu = K::nu, np = K::np;
    using J = Jet<double, taylor_max_order + 1>;
    using R = Reference<typename K::model_type, J>;
    const auto fail = [&] {
      for (int k = 0; k < (order + 1) * na; ++k)
        qk[k] = qdk[k] = std::numeric_limits<double>::quiet_NaN();
      return false;
    };
    if (order < 1 || order > taylor_max_order) return fail();
    for (int i = 0; i < na; ++i) qk[i] = q[i], qdk[i] = qd[i];
    std::array<J, n> qj, qdj, qddj;
    std::array<J, n * n> dq, dqd;
    std::array<J, (nu > 0 ? n * nu : 1)> du;
    std::array<J, (ns > 0 ? n * ns : 1)> dp;
    std::array<J, (nu > 0 ? nu : 1)> uj;
    std::array<J, (np > 0 ? np : 1)> pj;
    for (int i = 0; i < nu; ++i) uj[i] = J(u[i]);
    for (int i = 0; i < np; ++i) pj[i] = J(p[i]);
    std::array<double, taylor_max_order + 1> series;
    for (int k = 0; k < order; ++k) {
      const int known = k + 1;  // coefficients 0..k of q' and q̇' are known
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < known; ++j) series[j] = qk[j * na + i];
        qj[i] = J::truncated(series.data(), known);
        for (int j = 0; j < known; ++j) series[j] = qdk[j * na + i];
        qdj[i] = J::truncated(series.data(), known);
      }
      series[0] = t;
      if (known > 1) series[1] = 1;
      for (int j = 2; j < known; ++j) series[j] = 0;
      const J tj = J::truncated(series.data(), known);
      if (!R::forward_dynamics(tj, qj.data(), qdj.data(), uj.data(), pj.data(), qddj.data()) ||
          !R::forward_dynamics_derivatives(tj, qj.data(), qdj.data(), uj.data(), pj.data(),
                                           dq.data(), dqd.data(), du.data()))
        return fail();
      if constexpr (ns > 0)
        if (!R::forward_dynamics_parameter_derivatives(tj, qj.data(), qdj.data(), uj.data(),
                                                       pj.data(), dp.data()))
          return fail();
      const double next = 1.0 / (k + 1);
      double* qk_next = qk + (k + 1) * na;
      double* qdk_next = qdk + (k + 1) * na;
      for (int i = 0; i < n; ++i) qdk_next[i] = qddj[i].c[k] * next;
      // Columns j of Φ (j < m) and S (j ≥ m): coefficient k of Σ_l A(i, l) col_j(l), by
      // convolution of A's coefficients 0..k with the column's k..0 (+ ∂q̈/∂p's coefficient k).
      for (int j = 0; j < m + ns; ++j)
        for (int i = 0; i < n; ++i) {
          double s = 0;
          if constexpr (ns > 0)
            if (j >= m) s = dp[i + n * (j - m)].c[k];
          for (int l = 0; l < n; ++l) {
            const int at = n + j * n + l;
            for (int r = 0; r <= k; ++r)
              s += dq[i + n * l].c[r] * qk[(k - r) * na + at] +
                   dqd[i + n * l].c[r] * qdk[(k - r) * na + at];
          }
          qdk_next[n + j * n + i] = s * next;
        }
      for (int i = 0; i < na; ++i) {
        qk_next[i] = qdk[k * na + i] * next;
        if (!std::isfinite(qk_next[i]) || !std::isfinite(qdk_next[i])) return fail();
      }
    }
    return true;
  }
};
}  // namespace detail

template <DifferentiableDynamics K, class Extent = transition_only>
struct Sensitivity
    : detail::SensitivityTaylor<K, std::is_same_v<Extent, with_parameters> ? K::np : 0> {
  static_assert(std::is_same_v<Extent, transition_only> || std::is_same_v<Extent, with_parameters>,
                "eom::Sensitivity<K, Extent>: Extent is eom::transition_only (Φ) or "
                "eom::with_parameters (Φ and ∂x/∂p)");
  static_assert(K::nc == 0, "eom::Sensitivity: the state transition matrix is offered for "
                            "unconstrained models only (nc = 0)");
  static constexpr bool has_parameters = std::is_same_v<Extent, with_parameters>;
  static_assert(!has_parameters || K::np > 0,
                "eom::Sensitivity<K, eom::with_parameters>: the model has no free parameters");
  using Base = typename detail::SensitivityKernels<K, Extent>::type;

  static constexpr int base_nq = K::nq, base_nv = nv_of<K>;
  static constexpr bool free_joint = base_nv != base_nq;
  static_assert(layout_of<K>().free_joint_only(),
                "eom::Sensitivity: ball joints are not supported yet (its tangent-space "
                "variational equations are written for the free joint's quaternion)");
  static constexpr int n = base_nv, m = 2 * base_nv;  // Φ is m × m, column-major
  static constexpr int ns = has_parameters ? K::np : 0;  // columns of S = ∂x/∂p (m × ns)
  static constexpr int nv = n * (1 + m + ns), nq = nv + (base_nq - base_nv);
  static constexpr int np = K::np, nu = K::nu, nc = 0;
  // Offsets of vec Φv (Ψ with a free joint) and vec Sv within q̇'; vec Φq and vec Sq sit `shift`
  // later in q' (after the base's nq coordinates).
  static constexpr int phi_at = n, s_at = n + n * m, shift = base_nq - base_nv;
  using State = StateOf<nq, nv>;
  using BaseState = StateOf<base_nq, base_nv>;

  // ---- packing between (x, Φ, S) and the augmented state ---------------------------------------

  // The augmented initial state for x0 with Φ(t0) = I (and S(t0) = 0).
  static State start(const BaseState& x0) noexcept {
    State y{};
    for (int i = 0; i < base_nq; ++i) y[i] = x0[i];
    for (int i = 0; i < n; ++i) y[nq + i] = x0[base_nq + i];
    for (int j = 0; j < m; ++j) {
      if (j < n)
        y[shift + phi_at + j * n + j] = 1;  // Φq(j, j) = 1 for the position columns
      else
        y[nq + phi_at + j * n + (j - n)] = 1;  // Φv(j − n, j) = 1 for the velocity columns
    }
    if constexpr (free_joint) exchange(y, -1);  // Φv → Ψ
    return y;
  }
  static BaseState state(const State& y) noexcept {
    BaseState x;
    for (int i = 0; i < base_nq; ++i) x[i] = y[i];
    for (int i = 0; i < n; ++i) x[base_nq + i] = y[nq + i];
    return x;
  }
  // Φ (m × m, column-major): rows 0..n−1 from Φq, rows n..m−1 from Φv.
  static std::array<double, m * m> transition(const State& y) noexcept {
    return unpack<m>(y, phi_at);
  }
  // S = ∂x/∂p (m × np, column-major, column k along free parameter k): rows 0..n−1 from Sq,
  // rows n..m−1 from Sv.
  static std::array<double, m * ns> parameter_sensitivity(const State& y) noexcept
    requires has_parameters
  {
    return unpack<ns>(y, s_at);
  }

  // ---- the kernels the integrators need (eom::Dynamics) ----------------------------------------

  static bool forward_dynamics(double t, const double* q, const double* qd, const double* u,
                               const double* p, double* qdd) noexcept {
    std::array<double, n * n> dq, dqd;
    std::array<double, (nu > 0 ? n * nu : 1)> du;
    if (!Base::forward_dynamics(t, q, qd, u, p, qdd)) return false;
    if (!Base::forward_dynamics_derivatives(t, q, qd, u, p, dq.data(), dqd.data(), du.data()))
      return false;
    // Columns 0..m−1 are Φ's; columns m..m+ns−1 are S's, which add ∂q̈/∂p.
    std::array<double, (ns > 0 ? n * ns : 1)> dp{};
    if constexpr (has_parameters)
      if (!Base::forward_dynamics_parameter_derivatives(t, q, qd, u, p, dp.data())) return false;
    const double *pos = q + base_nq, *vel = qd + n;
    double* out = qdd + n;
    std::array<double, n> w;  // column j of Φv (Sv)
    for (int j = 0; j < m + ns; ++j) {
      const double *pj = pos + j * n, *vj = vel + j * n;
      for (int k = 0; k < n; ++k) w[k] = vj[k];
      if constexpr (free_joint) add_cross(qd + 3, pj + 3, 1, w.data() + 3);  // Φv = Ψ + ω × Φq
      for (int i = 0; i < n; ++i) {
        double s = j < m ? 0.0 : dp[i + n * (j - m)];
        for (int k = 0; k < n; ++k) s += dq[i + n * k] * pj[k] + dqd[i + n * k] * w[k];
        out[j * n + i] = s;
      }
      if constexpr (free_joint) {  // Ψ̇ = Φ̇v − ω̇ × Φq − ω × Ψ on the rotation rows
        add_cross(qdd + 3, pj + 3, -1, out + j * n + 3);
        add_cross(qd + 3, vj + 3, -1, out + j * n + 3);
      }
    }
    return true;
  }
  // The energies of the underlying state (what observers of a run usually want).
  static double kinetic_energy(const double* q, const double* qd, const double* p) noexcept {
    return K::kinetic_energy(q, qd, p);
  }
  static double potential_energy(const double* q, const double* p) noexcept {
    return K::potential_energy(q, p);
  }

 private:
  // out += sign · (a × b) (3-vectors).
  static void add_cross(const double* a, const double* b, double sign, double* out) noexcept {
    out[0] += sign * (a[1] * b[2] - a[2] * b[1]);
    out[1] += sign * (a[2] * b[0] - a[0] * b[2]);
    out[2] += sign * (a[0] * b[1] - a[1] * b[0]);
  }
  // The velocity block's rotation rows += sign · ω × Φq, every column: −1 turns Φv (Sv) into Ψ,
  // +1 back.
  static void exchange(State& y, double sign) noexcept {
    const double* omega = y.data() + nq + 3;
    for (int j = 0; j < m + ns; ++j) {
      const int at = phi_at + j * n + 3;  // column j's rotation rows
      add_cross(omega, y.data() + shift + at, sign, y.data() + nq + at);
    }
  }
  // The m × cols matrix whose position rows start at q'[shift + at] and velocity rows at q̇'[at].
  template <int cols> static std::array<double, m * cols> unpack(const State& x, int at) noexcept {
    if constexpr (free_joint) {
      State y = x;
      exchange(y, 1);  // Ψ → Φv
      return unpack_rows<cols>(y, at);
    } else {
      return unpack_rows<cols>(x, at);
    }
  }
  template <int cols>
  static std::array<double, m * cols> unpack_rows(const State& y, int at) noexcept {
    std::array<double, m * cols> a;
    for (int j = 0; j < cols; ++j)
      for (int i = 0; i < n; ++i) {
        a[i + m * j] = y[shift + at + j * n + i];
        a[n + i + m * j] = y[nq + at + j * n + i];
      }
    return a;
  }
};

}  // namespace eom
