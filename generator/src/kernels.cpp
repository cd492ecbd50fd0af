// The derivation of every kernel from the traced T, V, φ, Q (docs/CONTRACT.md §2), and the choice of
// derivative mode for each, by cost (n = nq; "sweep" = one pass over the graph of T or φ):
//
//   ∂T/∂q, ∂T/∂q̇ = momenta   one reverse sweep of T gives both (scalar function, 2n inputs)
//   M = ∂(∂T/∂q̇)/∂q̇          n forward sweeps over the momenta (column j along q̇ⱼ), lower
//                            triangle kept and mirrored, then q̇ := 0: T is quadratic in q̇,
//                            so M depends on q alone, as the signature says; for a tree-form
//                            model the composite-rigid-body algorithm traced (eom/multibody/tree.hpp)
//                            instead when it has fewer operations
//   Ṁ                        one forward sweep of M along q̇ (seeds qₖ -> q̇ₖ)
//   c = Ṁq̇ − ∂T/∂q           one forward sweep of the momenta along q̇: (∂p/∂q)q̇ = Ṁq̇ for a
//                            quadratic T, at the cost of one sweep instead of forming Ṁ (n²);
//                            for a tree-form model the RNEA at q̈ = 0 instead when cheaper
//   ∂V/∂q                    one reverse sweep of V
//   C = ∂φ/∂q                one reverse sweep per constraint (nc < nq: fewer than forward)
//   γ = q̇ᵀ(∂²φ/∂q²)q̇         two forward sweeps of φ along q̇ (no Hessian is formed)
//   q̈                        M and f = Q − c − ∂V/∂q as nodes, then an unrolled LDLᵀ of M and
//                            the range-space method (as runtime/include/eom/numeric/linalg.hpp):
//                            structural zeros of M vanish through x·0 = 0, pivots are checked
//                            at run time, nothing is solved symbolically
//   ∂q̈/∂(q, q̇, u)            the solve differentiated: for each direction x,
//                            [M Cᵀ; C 0][∂q̈; ∂μ] = [∂f − (∂M)q̈ − (∂C)ᵀμ; −∂γ − (∂C)q̈]
//                            reusing the factors; ∂f, ∂M, ∂C, ∂γ by one forward sweep each.
//                            Forward mode through the unrolled factorization would cost O(n³)
//                            per direction, this costs O(n²)
//   ∂q̈/∂p (on request)      the same differentiated solve along each free parameter, where f, γ,
//                            M and C all move
//   τ = Mq̈ + c + ∂V/∂q − Q   the cheaper (by op count) of: the pieces above, or one forward
//                            sweep of the momenta along (q̇, q̈), giving Mq̈ + Ṁq̇ = d/dt ∂T/∂q̇
//                            (the recursive Newton-Euler idea in AD form) in O(cost of T)
//                            where M q̈ costs O(n²): 5 194 against 60 244 ops for a 100-link chain
//   frames (FRAMES)          a frame on a tree link: its Jacobian column by column from the joints
//                            above it (z × (x − o), z) and J̇v by the Newton–Euler outward pass at
//                            v̇ = 0, both traced from eom/multibody/frames.hpp, O(depth); a frame of frames():
//                            its placement differentiated, ẋ and Ṙ along each tangent direction
//                            (ω = (ṘRᵀ)^∨), and two sweeps along q̇ for ẍ and ω̇ (as γ)
//   contact sets (CONTACTS) a set's stacked frame Jacobians and biases (above), then the
//                            range-space solve in its Gram form (ContactSpace), M factored
//                            leaves first so that a tree's branches stay apart: the Solo12's
//                            four point feet 11,078 operations against 18,273 for RangeSpace
//                            in the natural order; ρ's proximal steps unrolled
//   mass centre (on request) ∂G/∂q by one reverse sweep per coordinate of G; the centroidal
//                            momentum matrix by one forward sweep per velocity of the centroidal
//                            momentum, then v := 0 (it is linear in v)
//   ∂τ/∂(q, q̇) (on request)  τ's cheapest form differentiated: forward sweeps along each
//                            direction or one reverse sweep per entry, the cheaper
//   Taylor coefficients      the series of M, f, C, γ by Taylor arithmetic on their nodes, and per
//                            coefficient the right-hand side's convolution tails solved by the
//                            order-0 factors (eomgen/taylor.hpp): O(n²) recurrences per
//                            coefficient where Taylor arithmetic through the unrolled factorization
//                            would cost O(n³)
#include "eomgen/kernels.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <tuple>

#include <eom/model/free_joint.hpp>
#include <eom/multibody/frames.hpp>  // the angular velocity of a traced rotation

#include "eomgen/derive.hpp"
#include "eomgen/optimize.hpp"

namespace eom::gen {

std::vector<std::string> velocity_names(const std::vector<std::string>& coordinates,
                                        const std::vector<int>& quaternions, bool floating) {
  auto ends = [](const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
  };
  const int nq = static_cast<int>(coordinates.size());
  std::vector<std::string> v;
  eom::Layout(nq, nq - static_cast<int>(quaternions.size()), quaternions.data())
      .walk([&](int i, int) { v.push_back(coordinates[i]); },
            [&](int i, int) {
              // A free joint: x, y, z named <P>x, <P>y, <P>z before its quaternion (or the root's).
              const std::string& x = i >= 3 ? coordinates[i - 3] : std::string();
              const std::string prefix = ends(x, "x") ? x.substr(0, x.size() - 1) : std::string();
              const bool named = i >= 3 && ends(x, "x") && coordinates[i - 2] == prefix + "y" &&
                                 coordinates[i - 1] == prefix + "z";
              if (floating && i == 3) {
                for (int k = 0; k < 3; ++k) v[k] = (named ? prefix : "") + "v" + "xyz"[k];
                for (const char* w : {"wx", "wy", "wz"}) v.push_back((named ? prefix : "") + w);
                return;
              }
              if (named && v.size() >= 3 && v[v.size() - 3] == x) {
                for (int k = 0; k < 3; ++k) v[v.size() - 3 + k] = prefix + "v" + "xyz"[k];
                for (const char* w : {"wx", "wy", "wz"}) v.push_back(prefix + w);
                return;
              }
              const std::string& qw = coordinates[i];
              const std::string stem = ends(qw, "qw") ? qw.substr(0, qw.size() - 2) : qw + "_";
              for (const char* w : {"wx", "wy", "wz"}) v.push_back(stem + w);
            });
  return v;
}

const Signature& signature(KernelId k) {
  using enum InputKind;
  static const std::array<Signature, kernel_count> table{{
      {"mass_matrix", "M = d2T/dqd2 (nq x nq, column-major, symmetric)",
       "void", {q, p}, {{"M", Dim::nv, Dim::nv}}},
      {"mass_matrix_dot", "Mdot = sum_k dM/dq_k qd_k (nq x nq)",
       "void", {q, qd, p}, {{"Mdot", Dim::nv, Dim::nv}}},
      {"coriolis", "c = Mdot qd - dT/dq (nq)",
       "void", {q, qd, p}, {{"c", Dim::nv, Dim::one}}},
      {"potential_gradient", "dV/dq (nq)",
       "void", {q, p}, {{"dVdq", Dim::nv, Dim::one}}},
      {"generalized_forces", "Q, the model's generalized forces (nq)",
       "void", {t, q, qd, u, p}, {{"Q", Dim::nv, Dim::one}}},
      {"constraint_residual", "phi(q) (nc)",
       "void", {q, p}, {{"phi", Dim::nc, Dim::one}}},
      {"constraint_jacobian", "C = dphi/dq (nc x nq, column-major)",
       "void", {q, p}, {{"C", Dim::nc, Dim::nv}}},
      {"constraint_bias", "gamma = sum_k dC/dq_k qd_k qd (nc)",
       "void", {q, qd, p}, {{"gamma", Dim::nc, Dim::one}}},
      {"forward_dynamics",
       "qdd from [M C'; C 0][qdd; mu] = [Q - c - dV/dq; -gamma]; false (qdd = NaN) when an\n"
       "// input is not finite or M or C M^-1 C' is singular",
       "bool", {t, q, qd, u, p}, {{"qdd", Dim::nv, Dim::one}}},
      {"kinetic_energy", "T",
       "double", {q, qd, p}, {{"T", Dim::one, Dim::one}}},
      {"potential_energy", "V",
       "double", {q, p}, {{"V", Dim::one, Dim::one}}},
      {"forward_dynamics_derivatives",
       "dqdd/dq, dqdd/dqd (nq x nq), dqdd/du (nq x nu), column-major; false (NaN) as\n"
       "// forward_dynamics",
       "bool", {t, q, qd, u, p},
       {{"dqdd_dq", Dim::nv, Dim::nv}, {"dqdd_dqd", Dim::nv, Dim::nv}, {"dqdd_du", Dim::nv, Dim::nu}}},
      {"inverse_dynamics", "tau = M qdd + c + dV/dq - Q (constraints ignored)",
       "void", {t, q, qd, qdd, u, p}, {{"tau", Dim::nv, Dim::one}}},
      {"taylor_coefficients",
       "Taylor coefficients of the motion through (t, q, qd) under the forward dynamics, u\n"
       "// held constant: qk[k*nq + i] = q_i^(k)(t)/k!, qdk[k*nq + i] = qd_i^(k)(t)/k! for\n"
       "// k = 0..order (arrays of nq*(order + 1)); work holds taylor_workspace*(order + 1)\n"
       "// doubles. False (outputs NaN) as forward_dynamics, when order < 1 or order >\n"
       "// taylor_max_order, or when a coefficient is not finite",
       "bool", {t, q, qd, u, p},
       {{"qk", Dim::nq, Dim::series}, {"qdk", Dim::nv, Dim::series}},
       {{"int", "order"}}, {{"double*", "work"}}},
      {"forward_dynamics_parameter_derivatives",
       "dqdd/dp (nq x np, column-major, free parameters only); false (NaN) as\n"
       "// forward_dynamics",
       "bool", {t, q, qd, u, p},
       {{"dqdd_dp", Dim::nv, Dim::np}}},
      // every input and output holds batch_lanes values per entry (emit_batch.cpp)
      {"forward_dynamics_batch", "",
       "unsigned", {t, q, qd, u, p}, {{"qdd", Dim::nv, Dim::one}}},
      {"frame_placement",
       "frame f's origin (3, world) and rotation (3 x 3, frame axes -> world, column-major);\n"
       "// f outside [0, nframes): NaN",
       "void", {q, p}, {{"position", Dim::three, Dim::one}, {"rotation", Dim::three, Dim::three}},
       {{"int", "f"}}},
      {"frame_jacobian",
       "J (6 x nv, column-major) of frame f: rows 0-2 the velocity of its origin, rows 3-5 its\n"
       "// angular velocity, world axes; f outside [0, nframes): NaN",
       "void", {q, p}, {{"J", Dim::six, Dim::nv}}, {{"int", "f"}}},
      {"frame_acceleration_bias",
       "a = dJ/dt v (6) of frame f: its origin's classical acceleration and its angular\n"
       "// acceleration at zero dv/dt, world axes (it accelerates by J dv/dt + a); f outside\n"
       "// [0, nframes): NaN",
       "void", {q, qd, p}, {{"a", Dim::six, Dim::one}}, {{"int", "f"}}},
      {"center_of_mass", "the mass centre (3, world) of the bodies that move with q",
       "void", {q, p}, {{"com", Dim::three, Dim::one}}},
      {"center_of_mass_jacobian", "d com/dq along v (3 x nv, column-major)",
       "void", {q, p}, {{"J", Dim::three, Dim::nv}}},
      {"centroidal_momentum_matrix",
       "A (6 x nv, column-major): A v = the linear momentum, then the angular momentum about the\n"
       "// mass centre, world axes",
       "void", {q, p}, {{"A", Dim::six, Dim::nv}}},
      {"inverse_dynamics_derivatives",
       "dtau/dq, dtau/dqd (nv x nv each, column-major) of inverse_dynamics; dtau/dqdd = M",
       "void", {t, q, qd, qdd, u, p}, {{"dtau_dq", Dim::nv, Dim::nv}, {"dtau_dqd", Dim::nv, Dim::nv}}},
      {"contact_dynamics",
       "vdot and the contact forces lambda (contact_rows[s]: per frame its force, a 6d one's then\n"
       "// its torque about its origin, world axes) of contact set s: M vdot + c + dV/dq - Q = J' lambda,\n"
       "// J vdot + a = -kd J v (J, a: the set's frame Jacobians and biases stacked); rho > 0: the\n"
       "// proximal iterations (contact_proximal_iterations) give the least-norm lambda of a redundant\n"
       "// set; rho == 0: one exact solve. False (vdot, lambda NaN) when an input is not finite,\n"
       "// kd < 0, rho < 0, M or J M^-1 J' + rho I is singular; s outside [0, ncontact_sets): vdot NaN,\n"
       "// lambda untouched",
       "bool", {t, q, qd, u, p, kd, rho},
       {{"vdot", Dim::nv, Dim::one}, {"lambda", Dim::contact, Dim::one}}, {{"int", "s"}}},
      {"impulse_dynamics",
       "the velocity v_plus after contact set s closes on the velocity qd (v minus) and its impulse\n"
       "// (contact_rows[s], as lambda): M (v_plus - qd) = J' impulse, J v_plus = -restitution J qd.\n"
       "// False (NaN) as contact_dynamics, and for restitution outside [0, 1]",
       "bool", {q, qd, p, restitution, rho},
       {{"v_plus", Dim::nv, Dim::one}, {"impulse", Dim::contact, Dim::one}}, {{"int", "s"}}},
      {"contact_dynamics_derivatives",
       "dvdot/dq (tangent space), dvdot/dqd (nv x nv), dvdot/du (nv x nu), dlambda/dq, dlambda/dqd\n"
       "// (contact_rows[s] x nv), dlambda/du (contact_rows[s] x nu), column-major, of contact_dynamics;\n"
       "// false (NaN) as contact_dynamics",
       "bool", {t, q, qd, u, p, kd, rho},
       {{"dvdot_dq", Dim::nv, Dim::nv}, {"dvdot_dqd", Dim::nv, Dim::nv}, {"dvdot_du", Dim::nv, Dim::nu},
        {"dlambda_dq", Dim::contact, Dim::nv}, {"dlambda_dqd", Dim::contact, Dim::nv},
        {"dlambda_du", Dim::contact, Dim::nu}},
       {{"int", "s"}}},
      {"impulse_dynamics_derivatives",
       "dv_plus/dq (tangent space), dv_plus/dqd (nv x nv), dimpulse/dq, dimpulse/dqd (contact_rows[s]\n"
       "// x nv), column-major, of impulse_dynamics; false (NaN) as impulse_dynamics",
       "bool", {q, qd, p, restitution, rho},
       {{"dvplus_dq", Dim::nv, Dim::nv}, {"dvplus_dqd", Dim::nv, Dim::nv},
        {"dimpulse_dq", Dim::contact, Dim::nv}, {"dimpulse_dqd", Dim::contact, Dim::nv}},
       {{"int", "s"}}},
  }};
  return table[static_cast<std::size_t>(k)];
}

std::optional<KernelId> kernel_from_name(std::string_view name) {
  for (int i = 0; i < kernel_count; ++i)
    if (signature(static_cast<KernelId>(i)).name == name) return static_cast<KernelId>(i);
  return std::nullopt;
}

std::vector<KernelId> applicable_kernels(const TracedModel& m) {
  std::vector<KernelId> ks;
  for (int i = 0; i < kernel_count; ++i) {
    const auto k = static_cast<KernelId>(i);
    const bool constraint = k == KernelId::constraint_residual ||
                            k == KernelId::constraint_jacobian || k == KernelId::constraint_bias;
    if ((!constraint || m.nc > 0) && (!per_frame(k) || !m.frames.empty()) &&
        (!per_contact_set(k) || !m.contact_sets.empty()) && !on_request_only(k) &&
        !(m.floating() && on_request_when_floating(k)))
      ks.push_back(k);
  }
  return ks;
}

std::vector<KernelId> requestable_kernels(const TracedModel& m) {
  std::vector<KernelId> ks = applicable_kernels(m);
  for (int i = 0; i < kernel_count; ++i) {
    const auto k = static_cast<KernelId>(i);
    if ((on_request_only(k) && (!of_mass_centre(k) || m.has_bodies)) ||
        (m.floating() && on_request_when_floating(k)))
      ks.push_back(k);
  }
  return ks;
}

namespace {

using Nodes = std::vector<NodeId>;

// The unrolled factorization A = L D Lᵀ (L unit lower triangular) of a symmetric matrix given by
// its lower triangle, with one run-time guard per pivot. D holds exactly the pivots of the
// Cholesky factorization (Dⱼ = Aⱼⱼ − Σₖ L̃ⱼₖ² with L̃ = L√D), so the guard is the relative test
// of eom::linalg::cholesky, while the factor and the solves need no square root. Each pivot is
// inverted once: every later division by it (one per entry of L, one per solve) is a product.
// `reversed` factors A with its rows and columns in reverse order (solve() takes and returns the
// natural order; L, D, forward and backward are in the reversed one): a tree's velocities come
// parents first, so that eliminates leaves first and L keeps A's zeros (leaves_first below).
struct LDLT {
  int n = 0;
  bool reversed = false;
  Nodes L, D, D_inv;  // L: n×n column-major, strictly lower part used
  Nodes inverse;      // A⁻¹ in the elimination order, column-major, where solve() multiplies by it

  template <class Lower>
  LDLT(Graph& g, int size, Lower A_natural, Nodes& guards, bool reversed_ = false)
      : n(size), reversed(reversed_), L(size * size, Graph::zero), D(size), D_inv(size) {
    auto A = [&](int i, int j) { return reversed ? A_natural(n - 1 - i, n - 1 - j) : A_natural(i, j); };
    Nodes W(n * n, Graph::zero);  // W = L D, column by column
    for (int j = 0; j < n; ++j) {
      for (int i = j; i < n; ++i) {
        NodeId s = A(i, j);
        for (int k = 0; k < j; ++k) s = g.sub(s, g.mul(W[i + n * k], L[j + n * k]));
        W[i + n * j] = s;
      }
      D[j] = W[j + n * j];
      const NodeId ok = g.make(Op::PivotOk, D[j], A(j, j));
      if (!g.is_const(ok, 1)) guards.push_back(ok);
      D_inv[j] = g.div(Graph::one, D[j]);
      for (int i = j + 1; i < n; ++i) L[i + n * j] = g.mul(W[i + n * j], D_inv[j]);
    }
    invert_if_constant(g, A);
  }

  // A constant A that does not factor diagonally (a free body's inertia, parameters folded): its
  // inverse, rounded once from long double, where its product costs no more than the two
  // triangular solves (2 nnz(A⁻¹) − rows against 4 nnz(L) + n operations), whose multiply-adds
  // wait on one another: the product's rows run side by side.
  template <class Lower>
  void invert_if_constant(Graph& g, Lower A) {
    int fill = 0;
    for (int j = 0; j < n; ++j)
      for (int i = j; i < n; ++i) {
        if (!g.is_const(A(i, j))) return;
        fill += i > j && !g.is_const(L[i + n * j], 0.0);
      }
    if (fill == 0) return;
    using real = long double;
    std::vector<real> a(n * n), x(n * n, 0.0L);  // A (lower triangle) factored in place, then A⁻¹
    for (int j = 0; j < n; ++j)
      for (int i = j; i < n; ++i) a[i + n * j] = g[A(i, j)].value;
    for (int j = 0; j < n; ++j) {
      for (int k = 0; k < j; ++k) a[j + n * j] -= a[j + n * k] * a[j + n * k] * a[k + n * k];
      for (int i = j + 1; i < n; ++i) {
        for (int k = 0; k < j; ++k) a[i + n * j] -= a[i + n * k] * a[j + n * k] * a[k + n * k];
        a[i + n * j] /= a[j + n * j];
      }
    }
    for (int c = 0; c < n; ++c) {  // column c of A⁻¹: e_c through L, D and Lᵀ
      std::vector<real> y(n, 0.0L);
      y[c] = 1;
      for (int i = 0; i < n; ++i)
        for (int k = 0; k < i; ++k) y[i] -= a[i + n * k] * y[k];
      for (int i = 0; i < n; ++i) y[i] /= a[i + n * i];
      for (int i = n; i-- > 0;)
        for (int k = i + 1; k < n; ++k) y[i] -= a[k + n * i] * y[k];
      for (int i = 0; i < n; ++i) x[i + n * c] = y[i];
    }
    int entries = 0, rows = 0;
    for (int i = 0; i < n; ++i) {
      int in_row = 0;
      for (int c = 0; c < n; ++c) {
        if (!std::isfinite(static_cast<double>(x[i + n * c]))) return;  // singular: the guards fail
        in_row += static_cast<double>(x[i + n * c]) != 0.0;
      }
      entries += in_row;
      rows += in_row > 0;
    }
    if (2 * entries - rows > 4 * fill + n) return;
    inverse.resize(n * n);
    for (int k = 0; k < n * n; ++k) inverse[k] = g.constant(static_cast<double>(x[k]));
  }

  // x = A⁻¹ b; with `from` > 0 only the last n − from unknowns of the elimination order (natural:
  // rows from…, reversed: rows …n − 1 − from), the others left unfinished
  Nodes solve(Graph& g, Nodes b, int from = 0) const {
    if (reversed) std::reverse(b.begin(), b.end());
    if (!inverse.empty()) {
      Nodes x(n, Graph::zero);
      for (int i = 0; i < n; ++i)
        for (int k = 0; k < n; ++k)
          if (!g.is_const(inverse[i + n * k], 0.0)) x[i] = g.add(x[i], g.mul(inverse[i + n * k], b[k]));
      b = std::move(x);
    } else {
      b = forward(g, std::move(b));
      for (int i = 0; i < n; ++i) b[i] = g.mul(b[i], D_inv[i]);
      b = backward(g, std::move(b), from);
    }
    if (reversed) std::reverse(b.begin(), b.end());
    return b;
  }
  // L⁻¹ b
  Nodes forward(Graph& g, Nodes b) const {
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < i; ++k) b[i] = g.sub(b[i], g.mul(L[i + n * k], b[k]));
    return b;
  }
  // L⁻ᵀ b, from the far end, so that bᵢ's last term is the one that waits for bᵢ₊₁: one
  // multiply-add from each unknown to the next, not n − i of them (the solves run side by side)
  Nodes backward(Graph& g, Nodes b, int from = 0) const {
    for (int i = n - 1; i >= from; --i)
      for (int k = n - 1; k > i; --k) b[i] = g.sub(b[i], g.mul(L[k + n * i], b[k]));
    return b;
  }

  // A⁻¹ B for B's columns (n each, concatenated). The inverse is symmetric: where B holds unit
  // columns e_0 … e_{m−1} (in that order among the others, as ∂τ/∂u = −I puts them), e_j takes
  // its rows above j from the earlier e_r's row j, and in the natural order solves rows j… only
  // (the back substitution stops there: it halves). Leaves first, the back substitution ends at
  // row 0 instead; with all n of them, e_j then solves rows …j and takes the rows below from the
  // later ones, solved first. Either way the result is exactly symmetric.
  Nodes solve_columns(Graph& g, const Nodes& B) const {
    const std::size_t count = B.size() / n;
    auto column = [&](std::size_t k) { return Nodes(B.begin() + k * n, B.begin() + (k + 1) * n); };
    std::vector<std::size_t> unit_at;  // the columns of e_0, e_1, …
    for (std::size_t k = 0; k < count && unit_at.size() < static_cast<std::size_t>(n); ++k) {
      const int j = static_cast<int>(unit_at.size());
      bool unit = true;
      for (int i = 0; i < n && unit; ++i) unit = g.is_const(B[k * n + i], i == j ? 1.0 : 0.0);  // ±0
      if (unit) unit_at.push_back(k);
    }
    const int m = static_cast<int>(unit_at.size());
    const bool last_first = reversed && m == n;
    std::vector<int> unit(count, -1);  // column k is e_unit[k]; solved in order, e_j reversed if last_first
    for (int t = 0; t < m; ++t) unit[unit_at[t]] = last_first ? m - 1 - t : t;
    std::vector<Nodes> x(count);
    for (std::size_t k = 0; k < count; ++k) {
      const int j = unit[k];
      if (j < 0) {
        x[k] = solve(g, column(k));
        continue;
      }
      // `from` counts in the elimination order: natural rows j…, reversed rows …j
      Nodes col = solve(g, column(unit_at[j]), reversed ? (last_first ? n - 1 - j : 0) : j);
      for (int r = 0; r < m; ++r)
        if (last_first ? r > j : r < j) col[r] = x[unit_at[r]][j];
      x[unit_at[j]] = std::move(col);
    }
    Nodes all;
    for (const Nodes& col : x) all.insert(all.end(), col.begin(), col.end());
    return all;
  }
};

// The entries below the diagonal of L in A = L D Lᵀ (A symmetric, n×n, column-major), natural
// or reversed order (LDLT's `reversed`), from A's zero pattern by symbolic elimination.
int factor_fill(const Graph& g, int n, const Nodes& A, bool reversed) {
  std::vector<char> nz(n * n);  // L's pattern, column-major, in the elimination order
  int count = 0;
  for (int j = 0; j < n; ++j)
    for (int i = j + 1; i < n; ++i) {
      const int r = reversed ? n - 1 - i : i, c = reversed ? n - 1 - j : j;
      bool x = !g.is_const(A[r + n * c], 0.0);
      for (int k = 0; k < j && !x; ++k) x = nz[i + n * k] && nz[j + n * k];
      nz[i + n * j] = x;
      count += x;
    }
  return count;
}


// μ from (S + ρI) μ = b factored in LS: `iterations` proximal steps (S + ρI) μₖ₊₁ = b + ρ μₖ
// from μ₀ = 0 (below). With ρ = 0 each step is the first, the same nodes.
Nodes proximal_solve(Graph& g, const LDLT& LS, const Nodes& b, NodeId rho, int iterations) {
  Nodes mu = LS.solve(g, b);
  for (int k = 1; k < iterations; ++k) {
    Nodes next(b.size());
    for (std::size_t r = 0; r < b.size(); ++r) next[r] = g.add(b[r], g.mul(rho, mu[r]));
    mu = LS.solve(g, next);
  }
  return mu;
}

// [M Cᵀ; C 0][q̈; μ] = [f; −γ] by the range-space method, factored once, solvable for many
// right-hand sides (the derivative kernel solves one per direction). With a proximal parameter
// ρ (a node; zero folds away), S = C M⁻¹ Cᵀ + ρI is factored instead and μ refined by
// `iterations` proximal steps (S + ρI) μₖ₊₁ = C M⁻¹ f + γ + ρ μₖ from μ₀ = 0: each step
// shrinks the error along S's eigenvalue σ by ρ/(σ + ρ), and every iterate stays in S's range,
// so a redundant C (S singular) gets the least-norm μ.
struct RangeSpace {
  int nq, nc;
  Nodes C;  // nc×nq
  NodeId rho;
  LDLT LM;
  Nodes Y;  // M⁻¹Cᵀ, nq×nc
  std::optional<LDLT> LS;

  RangeSpace(Graph& g, int nq_, int nc_, const Nodes& M, bool leaves_first, Nodes C_, Nodes& guards,
             NodeId rho_ = Graph::zero)
      : nq(nq_), nc(nc_), C(std::move(C_)), rho(rho_),
        LM(g, nq_, [&](int i, int j) { return M[i + nq_ * j]; }, guards, leaves_first) {
    for (int k = 0; k < nc; ++k) {
      Nodes col(nq);
      for (int i = 0; i < nq; ++i) col[i] = C[k + nc * i];
      col = LM.solve(g, col);
      Y.insert(Y.end(), col.begin(), col.end());
    }
    if (nc > 0) {
      Nodes S(nc * nc, Graph::zero);  // C M⁻¹ Cᵀ, lower triangle
      for (int r = 0; r < nc; ++r)
        for (int k = 0; k <= r; ++k) {
          NodeId s = Graph::zero;
          for (int i = 0; i < nq; ++i) s = g.add(s, g.mul(C[r + nc * i], Y[i + nq * k]));
          S[r + nc * k] = r == k ? g.add(s, rho) : s;
        }
      LS.emplace(g, nc, [&](int i, int j) { return S[i + nc * j]; }, guards);
    }
  }

  // (q̈, μ) for the right-hand side (f, −γ)
  std::pair<Nodes, Nodes> solve(Graph& g, const Nodes& f, const Nodes& gamma, int iterations = 1) const {
    Nodes a = LM.solve(g, f);
    if (nc == 0) return {a, {}};
    Nodes b(nc);
    for (int r = 0; r < nc; ++r) {
      NodeId s = gamma[r];
      for (int i = 0; i < nq; ++i) s = g.add(s, g.mul(C[r + nc * i], a[i]));
      b[r] = s;
    }
    Nodes mu = proximal_solve(g, *LS, b, rho, iterations);
    for (int i = 0; i < nq; ++i)
      for (int k = 0; k < nc; ++k) a[i] = g.sub(a[i], g.mul(Y[i + nq * k], mu[k]));
    return {a, mu};
  }
};

// [M Jᵀ; J 0][x; μ] = [f; −γ] for the contact kernels, by the range-space method in its Gram form:
// with M = L D Lᵀ and Z = L⁻¹Jᵀ, S = J M⁻¹ Jᵀ = Zᵀ D⁻¹ Z and x = L⁻ᵀ D⁻¹ (L⁻¹ f − Z μ). The
// velocities are taken in reverse order: a tree's come parents first, so the factorization then
// eliminates leaves first and L keeps M's zeros (no fill-in between branches: a quadruped's legs
// stay apart, O(n·depth²) rather than O(n³)). Only forward substitutions meet Jᵀ, so Z keeps
// Jᵀ's zeros too: a foot's column stays on its leg and the base, and S's entries between two
// legs cost the base's six products. S as a sum of products of one factor is also symmetric to
// the last bit. ρ and the proximal steps as RangeSpace. Inputs and outputs in the natural order.
struct ContactSpace {
  int n, rows;
  NodeId rho;
  LDLT LM;      // of M reversed
  Nodes Z, Zs;  // L⁻¹Jᵀ and D⁻¹ L⁻¹Jᵀ, n × rows, reversed rows
  std::optional<LDLT> LS;

  int reversed(int i) const { return n - 1 - i; }

  ContactSpace(Graph& g, int n_, int rows_, const Nodes& M, const Nodes& J, NodeId rho_, Nodes& guards)
      : n(n_), rows(rows_), rho(rho_),
        LM(g, n_, [&](int i, int j) { return M[i + n_ * j]; }, guards, true) {
    for (int k = 0; k < rows; ++k) {
      Nodes col(n);
      for (int i = 0; i < n; ++i) col[i] = J[k + rows * reversed(i)];
      col = LM.forward(g, col);
      Z.insert(Z.end(), col.begin(), col.end());
      for (int i = 0; i < n; ++i) Zs.push_back(g.mul(LM.D_inv[i], col[i]));
    }
    Nodes S(rows * rows, Graph::zero);  // lower triangle
    for (int r = 0; r < rows; ++r)
      for (int k = 0; k <= r; ++k) {
        NodeId s = r == k ? rho : Graph::zero;
        for (int i = 0; i < n; ++i) s = g.add(s, g.mul(Zs[i + n * r], Z[i + n * k]));
        S[r + rows * k] = s;
      }
    LS.emplace(g, rows, [&](int i, int j) { return S[i + rows * j]; }, guards);
  }

  std::pair<Nodes, Nodes> solve(Graph& g, const Nodes& f, const Nodes& gamma, int iterations) const {
    Nodes fr(n);
    for (int i = 0; i < n; ++i) fr[i] = f[reversed(i)];
    const Nodes y = LM.forward(g, fr);
    Nodes b(rows);
    for (int r = 0; r < rows; ++r) {
      NodeId s = gamma[r];
      for (int i = 0; i < n; ++i) s = g.add(s, g.mul(Zs[i + n * r], y[i]));
      b[r] = s;
    }
    const Nodes mu = proximal_solve(g, *LS, b, rho, iterations);
    Nodes w(n);
    for (int i = 0; i < n; ++i) {
      NodeId s = g.mul(LM.D_inv[i], y[i]);
      for (int k = 0; k < rows; ++k) s = g.sub(s, g.mul(Zs[i + n * k], mu[k]));
      w[i] = s;
    }
    const Nodes xr = LM.backward(g, w);
    Nodes x(n);
    for (int i = 0; i < n; ++i) x[i] = xr[reversed(i)];
    return {x, mu};
  }

  // solve()'s steps (one proximal iteration) as row operations on right-hand sides stored by
  // rows, f reversed in rows 0..n−1 and γ in rows n..: the same operations in the same order on
  // the factors' nonzeros only (a structural zero of L or Zs, the tree's sparsity, is no step).
  // Their values go to `factors`. x comes back reversed in rows 0..n−1, μ in rows n...
  RowSolve row_solve(Graph& g, Nodes& factors) const {
    RowSolve out;
    out.rows = n + rows;
    std::map<NodeId, int> at;
    const auto factor = [&](NodeId f) {
      const auto [it, added] = at.emplace(f, static_cast<int>(factors.size()));
      if (added) factors.push_back(f);
      return it->second;
    };
    const auto add = [&](NodeId f, int from, int to, bool negate, bool f_only = false) {
      if (!g.is_const(f, 0.0))
        out.steps.push_back({RowSolve::Step::Kind::add, from, to, factor(f), negate, f_only});
    };
    const auto scale = [&](NodeId f, int to, bool f_only = false) {
      if (!g.is_const(f, 1.0)) out.steps.push_back({RowSolve::Step::Kind::scale, to, to, factor(f), false, f_only});
    };
    for (int i = 0; i < n; ++i)  // y = L⁻¹ f
      for (int k = 0; k < i; ++k) add(LM.L[i + n * k], k, i, true, true);
    for (int r = 0; r < rows; ++r)  // b = γ + Zsᵀ y
      for (int i = 0; i < n; ++i) add(Zs[i + n * r], i, n + r, false, true);
    const LDLT& S = *LS;  // μ = S⁻¹ b
    for (int i = 0; i < rows; ++i)
      for (int k = 0; k < i; ++k) add(S.L[i + rows * k], n + k, n + i, true);
    for (int i = 0; i < rows; ++i) scale(S.D_inv[i], n + i);
    for (int i = rows - 1; i >= 0; --i)
      for (int k = rows - 1; k > i; --k) add(S.L[k + rows * i], n + k, n + i, true);
    for (int i = 0; i < n; ++i) {  // w = D⁻¹ y − Zs μ
      scale(LM.D_inv[i], i, true);
      for (int k = 0; k < rows; ++k) add(Zs[i + n * k], n + k, i, true);
    }
    for (int i = n - 1; i >= 0; --i)  // x = L⁻ᵀ w
      for (int k = n - 1; k > i; --k) add(LM.L[k + n * i], k, i, true);
    out.factors = static_cast<int>(factors.size());
    out.nv = n;
    out.force_rows = rows;
    out.force_from = n;
    out.reversed = true;
    return out;
  }
};

// A direction of differentiation: its seeds, and whether it may move M and C.
struct Direction {
  std::vector<Seed> seeds;
  bool moves_M_C;
};

// Every quantity of docs/CONTRACT.md §2 as nodes, each derived on first use.
class Derivation {
 public:
  // optimize: M, Ṁ, c, ∂V/∂q, C, γ and the solve's directions through the optimize stage
  // (eomgen/optimize.hpp), else as derived.
  // n_ counts velocities v (the inputs qd), nq_ coordinates; they differ with a free joint
  // (eom/model/free_joint.hpp), where q̇ = G(q) v and gradients over q are taken along G's columns.
  Derivation(TracedModel& m, bool optimize)
      : m_(m), g_(m.graph), nq_(m.nq), n_(m.nv), optimize_(optimize) {
    for (int i = 0; i < nq_; ++i) q_.push_back(g_.input(InputKind::q, i));
    for (int i = 0; i < n_; ++i) qd_.push_back(g_.input(InputKind::qd, i));
    for (int i = 0; i < m.nu; ++i) u_.push_back(g_.input(InputKind::u, i));
    const Nodes rate = m.floating() ? free_joint([&](auto q, auto v, auto out) {
      eom::configuration_rate(m_.layout(), q, v, out);
    }, qd_, nq_) : qd_;
    for (int i = 0; i < nq_; ++i) along_qd_.emplace_back(q_[i], rate[i]);
    for (int j = 0; j < n_; ++j) {  // the tangent directions, G's columns
      std::vector<Seed> seeds;
      if (!m.floating()) {
        seeds.emplace_back(q_[j], Graph::one);
      } else {
        const Nodes column = free_joint([&](auto q, auto, auto out) {
          eom::configuration_direction(m_.layout(), q, j, out);
        }, {}, nq_);
        for (int i = 0; i < nq_; ++i)
          if (column[i] != Graph::zero) seeds.emplace_back(q_[i], column[i]);
      }
      along_q_.push_back(std::move(seeds));
    }
  }

  // [∂T/∂q, ∂T/∂v]
  const Nodes& dT() {
    if (dT_.empty()) {
      Nodes x = q_;
      x.insert(x.end(), qd_.begin(), qd_.end());
      dT_ = gradient(g_, m_.kinetic_energy, x);
    }
    return dT_;
  }
  Nodes momenta() { return Nodes(dT().begin() + nq_, dT().end()); }
  // Gᵀ ∂T/∂q: ∂T/∂q itself without a free joint
  const Nodes& dT_dq() {
    if (dT_dq_.empty()) dT_dq_ = tangent(Nodes(dT().begin(), dT().begin() + nq_));
    return dT_dq_;
  }
  // What a quaternion's non-commuting directions add to c: the Euler term ω × ∂T/∂ω in its
  // rotation rows (eom::Reference's mass_and_coriolis derives it), nothing elsewhere.
  NodeId bracket_term(int i) {
    int first = -1;  // the first velocity of the quaternion that row i turns, if any
    m_.layout().walk([](int, int) {}, [&](int, int j) {
      if (i >= j && i < j + 3) first = j;
    });
    if (first < 0) return Graph::zero;
    const int a = first + (i - first + 1) % 3, b = first + (i - first + 2) % 3;  // (ω × h)ᵢ = ω_a h_b − ω_b h_a
    const Nodes p = momenta();
    return g_.sub(g_.mul(qd_[a], p[b]), g_.mul(qd_[b], p[a]));
  }

  // How the unrolled solve factors M, from M's zero pattern (factor_fill): leaves first where L
  // has fewer nonzeros that way (a branching tree: MuJoCo's humanoid 216 entries below the
  // diagonal against 351, its legs and arms kept apart), else in the natural order (a chain,
  // whose M is full either way and whose natural order keeps solve_columns' halving for unit
  // right-hand sides); `fill`, L's entries below the diagonal in that order, decides the solve's
  // form (solve_form).
  struct Factoring {
    bool leaves_first;
    int fill;
  };
  const Factoring& factoring() {
    if (!factoring_) {
      const Nodes& M = mass_matrix();
      const int reversed = factor_fill(g_, n_, M, true), natural = factor_fill(g_, n_, M, false);
      factoring_ = Factoring{reversed < natural, std::min(reversed, natural)};
    }
    return *factoring_;
  }
  const Nodes& mass_matrix() {
    if (M_.empty()) {
      const Nodes p = momenta();
      Nodes lower;  // column by column, i >= j
      for (int j = 0; j < n_; ++j) {
        const Seed seed{qd_[j], Graph::one};
        const Nodes col = directional(g_, p, std::span(&seed, 1));
        lower.insert(lower.end(), col.begin() + j, col.end());
      }
      std::vector<Seed> at_rest;
      for (NodeId x : qd_) at_rest.emplace_back(x, Graph::zero);
      M_ = symmetric(optimized(substitute(g_, lower, at_rest)));
      // A tree-form model: M by the composite-rigid-body algorithm, O(n·depth), if cheaper. (Not
      // the closed form's by-product: the 30-link chain's in 3,010 operations against 3,628, but
      // behind the looped solve of its derivatives 1.6e-12 against 1.1e-12.)
      auto keep_cheaper = [&](const Nodes& other) {
        if (count_ops(g_, this->lower(other)) < count_ops(g_, this->lower(M_))) M_ = other;
      };
      if (!m_.tree_mass_matrix.empty()) keep_cheaper(symmetric(optimized(this->lower(m_.tree_mass_matrix))));
      if (floating_tree()) {  // M's columns from the RNEA at v = 0, v̇ = e_j, if cheaper
        Nodes by_columns;
        for (int j = 0; j < n_; ++j) {
          std::vector<Seed> at = at_rest;
          for (int k = 0; k < n_; ++k)
            at.emplace_back(g_.input(InputKind::qdd, k), k == j ? Graph::one : Graph::zero);
          const Nodes col = substitute(g_, m_.tree_inverse_dynamics, at);
          by_columns.insert(by_columns.end(), col.begin() + j, col.end());
        }
        keep_cheaper(symmetric(optimized(by_columns)));
      }
    }
    return M_;
  }

  // The mass_matrix kernel's M: mass_matrix()'s, or tree_mass_matrix_world's where cheaper (the
  // 30-link chain: 4 operations an entry against 8). Not for the factorizations, which keep
  // link axes (rounding about a far point is what M⁻¹ magnifies; tree_derivatives.hpp).
  Nodes mass_matrix_output() {
    const Nodes& M = mass_matrix();
    if (m_.tree_mass_matrix_world.empty()) return M;
    Nodes world = symmetric(optimized(this->lower(m_.tree_mass_matrix_world)));
    return count_ops(g_, this->lower(world)) < count_ops(g_, this->lower(M)) ? world : M;
  }

  Nodes mass_matrix_dot() {
    return symmetric(optimized(directional(g_, lower(mass_matrix()), along_qd_)));
  }

  const Nodes& coriolis() {
    if (c_.empty()) {
      c_ = directional(g_, momenta(), along_qd_);
      for (int i = 0; i < n_; ++i) c_[i] = g_.sub(c_[i], dT_dq()[i]);
      for (int i = 0; i < n_; ++i) c_[i] = g_.add(c_[i], bracket_term(i));
      c_ = optimized(c_);
      if (!m_.tree_inverse_dynamics.empty()) {  // the RNEA at v̇ = 0, if cheaper
        std::vector<Seed> at;
        for (int k = 0; k < n_; ++k) at.emplace_back(g_.input(InputKind::qdd, k), Graph::zero);
        const Nodes tree = optimized(substitute(g_, m_.tree_inverse_dynamics, at));
        if (count_ops(g_, tree) < count_ops(g_, c_)) c_ = tree;
      }
    }
    return c_;
  }

  // A floating tree-form model: its Lagrangian M carries the quaternion as a polynomial of degree
  // 4 that |q| = 1 would reduce and nothing reduces, so M's columns by the RNEA may be cheaper
  // still than the composite-rigid-body algorithm.
  bool floating_tree() const { return m_.floating() && !m_.tree_inverse_dynamics.empty(); }

  const Nodes& potential_gradient() {
    if (dV_.empty()) dV_ = optimized(tangent(gradient(g_, m_.potential_energy, q_)));
    return dV_;
  }

  Nodes generalized_forces() {
    return m_.has_generalized_forces ? m_.generalized_forces : Nodes(n_, Graph::zero);
  }

  const Nodes& constraint_jacobian() {  // nc×nq column-major
    if (C_.empty() && m_.nc > 0) {
      C_.assign(m_.nc * n_, Graph::zero);
      for (int i = 0; i < m_.nc; ++i) {
        const Nodes row = tangent(gradient(g_, m_.constraints[i], q_));
        for (int j = 0; j < n_; ++j) C_[i + m_.nc * j] = row[j];
      }
      C_ = optimized(C_);
    }
    return C_;
  }

  const Nodes& constraint_bias() {
    if (gamma_.empty() && m_.nc > 0)
      gamma_ = optimized(directional(g_, directional(g_, m_.constraints, along_qd_), along_qd_));
    return gamma_;
  }

  // f = Q − c − ∂V/∂q
  // Q − c − ∂V/∂q, for the solves (which factor M)
  const Nodes& force() {
    if (f_.empty()) {
      const Nodes Q = generalized_forces(), dV = gravity_on_a_free_tree() ? gravity_by_mass_matrix()
                                                                        : potential_gradient();
      for (int i = 0; i < n_; ++i) f_.push_back(g_.sub(g_.sub(Q[i], coriolis()[i]), dV[i]));
    }
    return f_;
  }

  // A tree on one free root (no other link on the world) whose potential is gravity on its bodies
  // (TracedModel::tree_gravity, V = g Σ m z): moving the whole tree up at unit speed gives every
  // body the velocity e_z, so ∂V/∂q = g M e with e the root's upward velocity (v's third): the
  // forward dynamics is that of no gravity less g on the root's z̈, and ∂V/∂q beside M is n
  // products of M's column, not ∂V/∂q's reverse sweep (Solo12: 479 operations, MuJoCo's
  // humanoid: 852). With other links on the world (MJCF bodies beside a free one) it is not.
  bool gravity_on_a_free_tree() const { return m_.tree_gravity && m_.one_free_root && floating_tree(); }
  Nodes gravity_by_mass_matrix() {
    const Nodes& M = mass_matrix();
    Nodes dV;
    for (int i = 0; i < n_; ++i) dV.push_back(g_.mul(m_.gravity, M[i + n_ * 2]));
    return dV;
  }

  const RangeSpace& solver() {
    if (!solver_) {
      solver_.emplace(g_, n_, m_.nc, mass_matrix(), factoring().leaves_first, constraint_jacobian(), guards_);
      auto [qdd, mu] = solver_->solve(g_, force(), constraint_bias());
      qdd_ = qdd;
      mu_ = mu;
      for (NodeId x : qdd_) guards_.push_back(g_.make(Op::IsFinite, x));
    }
    return *solver_;
  }
  const Nodes& forward_dynamics() {
    solver();
    return qdd_;
  }
  const Nodes& guards() {
    solver();
    return guards_;
  }

  // The forward_dynamics kernel's q̈ and guards: the solve above, or for a tree-form model without
  // constraints the articulated-body algorithm (τ = Q − ∂V/∂q; guards: every pivot positive and
  // finite, q̈ finite) or the solve with the closed form's bias (closed_bias_solve), whichever
  // has fewer operations. Taylor mode keeps the solve, whose factors it reuses. Looped without a
  // tree form: none, the dense routine solves the kernel's linear_system.
  struct Solution {
    Nodes qdd, guards;
    bool tree = false;
    bool by_steps = false;  // the from_parent form: emitted by steps (Kernel::by_steps)
  };
  Solution forward_dynamics_kernel(bool looped) {
    const bool tree_form = !m_.tree_forward_dynamics.empty() && m_.nc == 0;
    if (looped && !tree_form) return {};
    Solution s{forward_dynamics(), guards()};
    if (!tree_form) return s;
    std::vector<Seed> force, at_Q;  // τ = Q − ∂V/∂q; τ = Q with gravity as the world's acceleration
    const Nodes Q = generalized_forces();
    for (int i = 0; i < n_; ++i) {
      force.emplace_back(g_.input(InputKind::rhs, i), g_.sub(Q[i], potential_gradient()[i]));
      at_Q.emplace_back(g_.input(InputKind::rhs, i), Q[i]);
    }
    auto guarded = [&](Solution x) {
      for (NodeId d : m_.tree_pivots) {
        const NodeId ok = g_.make(Op::PivotOk, d, d);
        if (!g_.is_const(ok, 1)) x.guards.push_back(ok);
      }
      for (NodeId v : x.qdd) x.guards.push_back(g_.make(Op::IsFinite, v));
      return x;
    };
    Solution tree{substitute(g_, m_.tree_forward_dynamics, force), {}, true};
    tree = guarded(std::move(tree));
    auto outputs = [](const Solution& x) {  // q̈ and its guards: what the kernel computes
      Nodes all = x.qdd;
      append(all, x.guards);
      return all;
    };
    auto cost = [&](const Solution& x) { return count_ops(g_, outputs(x)); };
    if (cost(tree) < cost(s)) s = tree;
    if (!m_.tree_forward_dynamics_gravity.empty()) {  // gravity as the world's acceleration
      const Solution lifted = guarded({substitute(g_, m_.tree_forward_dynamics_gravity, at_Q), {}, true});
      if (cost(lifted) < cost(s)) s = lifted;
    }
    const Solution* c = looped ? nullptr : closed_bias_solve();  // its LDLᵀ is unrolled
    if (c && cost(*c) < cost(s)) s = *c;
    // A long chain's ABA waits on its dependent steps, the outward pass's most (the 30-link
    // chain: 2,984 operations, about 690 steps): the outward pass from the parent's acceleration
    // (eom::AbaOutward::from_parent; 3,324 and about 520 there, 0.92x the time) where the
    // estimate max(operations / 12, steps) is lower: an operation's latency is about three cycles
    // and a core issues about four a cycle. (MuJoCo's humanoid and Romeo, wide trees that their
    // operations bound, keep the carried pass: from_parent took 1.05x and 1.07x its time there.)
    if (s.tree) {
      auto estimate = [&](const Solution& x) {
        const Nodes all = outputs(x);
        return std::max(count_ops(g_, all) / 12, dependent_steps(g_, all));
      };
      std::vector<Solution> from_parent;
      if (!m_.tree_forward_dynamics_from_parent.empty())
        from_parent.push_back(guarded({substitute(g_, m_.tree_forward_dynamics_from_parent, force), {}, true}));
      if (!m_.tree_forward_dynamics_gravity_from_parent.empty())
        from_parent.push_back(guarded({substitute(g_, m_.tree_forward_dynamics_gravity_from_parent, at_Q), {}, true}));
      const Solution* x = nullptr;  // with gravity as the world's acceleration or not: the cheaper
      for (const Solution& y : from_parent)
        if (!x || cost(y) < cost(*x)) x = &y;
      if (x && estimate(*x) < estimate(s)) {
        s = *x;
        s.by_steps = true;
      }
    }
    return s;
  }

  // The forward dynamics as a linear system, for Taylor mode to differentiate (eomgen/taylor.hpp)
  // and for the looped form of big models (eomgen/emit.hpp): M, f, C, γ, and unless looped (the
  // dense routine solves it) the order-0 solution and the order-0 factors applied to a placeholder
  // right-hand side (inputs rhs), which coefficient k >= 1 of q̈ and μ solves with.
  TaylorSystem linear_system(bool looped) {
    const RangeSpace* s = looped ? nullptr : &solver();
    TaylorSystem t;
    t.nq = n_;
    t.nc = m_.nc;
    t.mass = mass_matrix();
    t.force = force();
    t.jacobian = constraint_jacobian();
    t.bias = constraint_bias();
    t.looped = looped;
    if (looped) return t;
    t.qdd = qdd_;
    t.mu = mu_;
    Nodes r, gamma;
    for (int i = 0; i < n_; ++i) r.push_back(g_.input(InputKind::rhs, i));
    for (int i = 0; i < m_.nc; ++i) gamma.push_back(g_.input(InputKind::rhs, n_ + i));
    auto [x, y] = s->solve(g_, r, gamma);
    t.solve_qdd = x;
    t.solve_mu = y;
    return t;
  }

  // ∂q̈/∂q, ∂q̈/∂q̇, ∂q̈/∂u, concatenated column-major (looped: the right-hand sides of their
  // solve instead, Kernel::looped), and the guards of the q̈ they are taken at.
  struct Derivatives {
    Nodes outputs, guards;
  };
  Derivatives forward_dynamics_derivatives(bool looped) {
    std::vector<Direction> along;
    for (const auto& seeds : along_q_) along.push_back({seeds, true});
    for (NodeId x : qd_) along.push_back({{{x, Graph::one}}, false});
    for (NodeId x : u_) along.push_back({{{x, Graph::one}}, false});
    Derivatives best{solve_derivatives(along, looped), looped ? Nodes{} : guards()};
    if (m_.nc > 0) return best;
    // Without constraints also −M⁻¹ ∂τ with ∂τ/∂q and ∂τ/∂v as inverse_dynamics_derivatives
    // has them (there reverse sweeps, one per entry of τ, where those are cheaper than one
    // forward sweep per direction), at the forward dynamics' q̈; ∂τ/∂u = −∂Q/∂u.
    Nodes dtau = inverse_dynamics_derivatives();
    for (NodeId x : u_) {
      const Seed seed{x, Graph::one};
      append(dtau, directional(g_, inverse_dynamics(), std::span(&seed, 1)));
    }
    auto keep_cheaper = [&](Derivatives other) {
      if (count_ops(g_, other.outputs) < count_ops(g_, best.outputs)) best = std::move(other);
    };
    if (looped) {
      for (NodeId& x : dtau) x = g_.neg(x);
      keep_cheaper({optimized(dtau), {}});
      return best;
    }
    keep_cheaper({solver().LM.solve_columns(g_, negated_at(dtau, qdd_)), guards()});
    // And the closed form's ∂τ at the q̈ of its own bias, which shares its vectors.
    if (const Solution* c = closed_bias_solve()) {
      Nodes closed = closed_derivatives();
      for (std::size_t k = n_ * n_ * 2; k < dtau.size(); ++k) closed.push_back(dtau[k]);  // ∂τ/∂u
      keep_cheaper({solver().LM.solve_columns(g_, negated_at(closed, c->qdd)), c->guards});
    }
    return best;
  }

  // −∂τ at the q̈ given (for the q̈ inputs), collected: the right-hand sides of −M⁻¹ ∂τ
  Nodes negated_at(const Nodes& dtau, const Nodes& qdd) {
    std::vector<Seed> at_qdd;
    for (int j = 0; j < n_; ++j) at_qdd.emplace_back(g_.input(InputKind::qdd, j), qdd[j]);
    Nodes x = substitute(g_, dtau, at_qdd);
    for (NodeId& y : x) y = g_.neg(y);
    return optimized(x);
  }

  // ∂q̈/∂p over the free parameters, column-major (nq×np). A parameter may move every piece:
  // masses and lengths M, loads f, geometry C and γ.
  Nodes forward_dynamics_parameter_derivatives(bool looped) {
    std::vector<Direction> along;
    for (int k = 0; k < m_.np(); ++k) along.push_back({{{g_.input(InputKind::p, k), Graph::one}}, true});
    return solve_derivatives(along, looped);
  }

  // τ = M q̈ + c + ∂V/∂q − Q, in the cheapest of its forms (all are built; the emitter only
  // writes the one kept): as written; with M q̈ + c = d/dt(∂T/∂q̇) − ∂T/∂q by one forward
  // sweep of the momenta along (q̇, q̈), which costs O(cost of T) where M q̈ costs O(n²); and
  // for a tree-form model with M q̈ + c by the recursive Newton–Euler algorithm, O(n).
  const Nodes& inverse_dynamics() {
    if (!tau_.empty()) return tau_;
    const Nodes Q = generalized_forces();
    const Nodes& M = mass_matrix();
    Nodes direct;
    for (int i = 0; i < n_; ++i) {
      NodeId s = g_.sub(g_.add(coriolis()[i], potential_gradient()[i]), Q[i]);
      for (int j = 0; j < n_; ++j) s = g_.add(s, g_.mul(M[i + n_ * j], g_.input(InputKind::qdd, j)));
      direct.push_back(s);
    }
    std::vector<Seed> along_qd_qdd = along_qd_;
    for (int i = 0; i < n_; ++i) along_qd_qdd.emplace_back(qd_[i], g_.input(InputKind::qdd, i));
    const Nodes dp = directional(g_, momenta(), along_qd_qdd);
    Nodes swept;
    for (int i = 0; i < n_; ++i)
      swept.push_back(g_.sub(g_.add(g_.add(g_.sub(dp[i], dT_dq()[i]), bracket_term(i)),
                                    potential_gradient()[i]),
                             Q[i]));
    tau_ = count_ops(g_, swept) < count_ops(g_, direct) ? swept : direct;
    if (!m_.tree_inverse_dynamics.empty()) {
      Nodes tree;
      for (int i = 0; i < n_; ++i)
        tree.push_back(g_.sub(g_.add(m_.tree_inverse_dynamics[i], potential_gradient()[i]), Q[i]));
      check_tree_agrees(tree, swept);  // swept is Lagrangian throughout (M and c may be the tree's)
      if (count_ops(g_, tree) < count_ops(g_, tau_)) tau_ = tree;
    }
    if (!m_.tree_inverse_dynamics_gravity.empty()) {  // ∂V/∂q in the same sweep, if cheaper
      Nodes tree;
      for (int i = 0; i < n_; ++i) tree.push_back(g_.sub(m_.tree_inverse_dynamics_gravity[i], Q[i]));
      if (count_ops(g_, tree) < count_ops(g_, tau_)) tau_ = tree;
    }
    return tau_;
  }

  // ∂τ/∂q (along the tangent directions) and ∂τ/∂v of the inverse dynamics: differentiated by
  // forward or reverse sweeps (jacobians), or, for a tree with a fixed base, the tree's closed
  // form (eom::tree_inverse_dynamics_derivatives) plus the sweeps of the rest, ∂V/∂q − Q (−Q
  // when the closed form carries the potential, TracedModel::tree_gravity), whichever has fewer
  // operations (a 30-link chain: 10,413 against 37,625; the Panda: 5,878 against 7,012; the UR5
  // keeps its sweeps, 3,950 against 4,576). Both are as accurate behind a solve (−M⁻¹ ∂τ): the
  // closed form takes its vectors about each branch's end, not the world origin.
  Nodes inverse_dynamics_derivatives() {
    if (!dtau_.empty()) return dtau_;  // derived once for both derivative kernels
    dtau_ = jacobians(inverse_dynamics());
    const Nodes closed = closed_derivatives();
    if (!closed.empty() && count_ops(g_, closed) < count_ops(g_, dtau_)) dtau_ = closed;
    return dtau_;
  }

  // The closed form's ∂τ/∂q, ∂τ/∂v (with the sweeps of the rest), empty without one
  Nodes closed_derivatives() {
    const Nodes& tree = m_.tree_inverse_dynamics_derivatives;
    if (tree.empty() || !closed_dtau_.empty()) return closed_dtau_;
    const Nodes Q = generalized_forces();
    Nodes rest;
    for (int i = 0; i < n_; ++i)
      rest.push_back(m_.tree_gravity ? g_.neg(Q[i]) : g_.sub(potential_gradient()[i], Q[i]));
    closed_dtau_ = jacobians(rest);
    for (std::size_t k = 0; k < tree.size(); ++k) closed_dtau_[k] = g_.add(tree[k], closed_dtau_[k]);
    return closed_dtau_ = optimized(closed_dtau_);
  }

  // The tree part of the closed form at v = 0 is ∂(M v̇)/∂q, but for gravity, which it carries
  // (tree_gravity) as the root's upward acceleration g: on a free tree alone, v's first three the
  // root's velocity in world axes, at v̇ := x − g e_z it is ∂(M x)/∂q (the impulse's −∂f − (∂M)x),
  // one pass for all directions where the momenta take a sweep each. A fixed base's gravity is no
  // acceleration of a coordinate: that keeps the sweep.
  bool momenta_closed_form() const {
    return !m_.tree_inverse_dynamics_derivatives.empty() && (!m_.tree_gravity || gravity_on_a_free_tree());
  }
  Nodes closed_momenta_derivatives(const Nodes& x) {
    const Nodes& tree = m_.tree_inverse_dynamics_derivatives;
    const Nodes dq(tree.begin(), tree.begin() + n_ * n_);
    if (!momenta_checked_) {  // the premise above, at a test state against the momenta's sweeps
      std::vector<Seed> to_qdd;
      for (int j = 0; j < n_; ++j) to_qdd.emplace_back(qd_[j], g_.input(InputKind::qdd, j));
      const Nodes Mx = substitute(g_, momenta(), to_qdd);
      Nodes swept, qdd;
      for (const auto& seeds : along_q_) append(swept, directional(g_, Mx, seeds));
      for (int j = 0; j < n_; ++j) qdd.push_back(g_.input(InputKind::qdd, j));
      check_agrees(closed_at_rest(dq, qdd), swept, "the closed form's ∂(M x)/∂q");
      momenta_checked_ = true;
    }
    return closed_at_rest(dq, x);
  }
  Nodes closed_at_rest(const Nodes& dq, const Nodes& x) {
    std::vector<Seed> at;
    for (int j = 0; j < n_; ++j) {
      at.emplace_back(qd_[j], Graph::zero);
      at.emplace_back(g_.input(InputKind::qdd, j), j == 2 && m_.tree_gravity ? g_.sub(x[j], m_.gravity) : x[j]);
    }
    return optimized(substitute(g_, dq, at));
  }

  // q̈ = M⁻¹(Q − τ(q, v, 0)) on the factors of mass_matrix(), with τ the closed form's by-product
  // (eom/multibody/tree_derivatives.hpp), which shares its vectors: where the derivatives are the closed form's, the
  // bias then costs little more. Its guards: the pivots, q̈ finite. Null without a closed form.
  // (Its M shares them too, but about a branch's far end that M's rounding is about twice the
  // link-axes CRBA's, and M⁻¹ magnifies it: the Panda's forward-dynamics derivatives 3.7e-14
  // against 7.7e-15 at the worst of 200 states.)
  const Solution* closed_bias_solve() {
    if (m_.tree_closed_tau.empty()) return nullptr;
    if (closed_bias_solve_) return &*closed_bias_solve_;
    Solution s;
    const Nodes& M = mass_matrix();
    const LDLT L(g_, n_, [&](int i, int j) { return M[i + n_ * j]; }, s.guards,
                 factoring().leaves_first);  // solver()'s nodes
    std::vector<Seed> at_rest;
    for (int j = 0; j < n_; ++j) at_rest.emplace_back(g_.input(InputKind::qdd, j), Graph::zero);
    const Nodes bias = substitute(g_, m_.tree_closed_tau, at_rest), Q = generalized_forces();
    Nodes f;
    for (int i = 0; i < n_; ++i)
      f.push_back(g_.sub(g_.sub(Q[i], bias[i]), m_.tree_gravity ? Graph::zero : potential_gradient()[i]));
    s.qdd = L.solve(g_, f);
    for (NodeId x : s.qdd) s.guards.push_back(g_.make(Op::IsFinite, x));
    s.tree = true;
    closed_bias_solve_ = std::move(s);
    return &*closed_bias_solve_;
  }

  // ∂y/∂q (along the tangent directions) and ∂y/∂v of n_ functions y (column-major, n_ × n_
  // each) by forward sweeps (one per direction) or reverse sweeps (one per entry of y),
  // whichever has fewer operations.
  Nodes jacobians(const Nodes& y) {
    Nodes forward;
    for (const auto& seeds : along_q_) append(forward, directional(g_, y, seeds));
    for (NodeId x : qd_) {
      const Seed seed{x, Graph::one};
      append(forward, directional(g_, y, std::span(&seed, 1)));
    }
    forward = optimized(forward);
    Nodes wrt = q_, reverse(2 * n_ * n_);
    append(wrt, qd_);
    for (int i = 0; i < n_; ++i) {
      const Nodes row = gradient(g_, y[i], wrt);
      const Nodes dq = tangent(Nodes(row.begin(), row.begin() + nq_));
      for (int j = 0; j < n_; ++j) {
        reverse[i + n_ * j] = dq[j];
        reverse[n_ * n_ + i + n_ * j] = row[nq_ + j];
      }
    }
    reverse = optimized(reverse);
    return count_ops(g_, reverse) < count_ops(g_, forward) ? reverse : forward;
  }

  // ---- task space (eom/multibody/frames.hpp) ----
  // Frame k's Jacobian (6 × nv): the tree's, else the placement differentiated along each
  // tangent direction: ẋ, and ω = (Ṙ Rᵀ)^∨ from Ṙ.
  Nodes frame_jacobian(int k) {
    const TracedModel::FrameNodes& f = m_.frames[k];
    if (!f.jacobian.empty()) return optimized(f.jacobian);
    Nodes J;
    for (int j = 0; j < n_; ++j) {
      const Nodes d = directional(g_, f.placement, along_q_[j]);
      append(J, Nodes(d.begin(), d.begin() + 3));
      append(J, angular_velocity(rotation(f.placement), rotation(d)));
    }
    return optimized(J);
  }

  // Frame k's bias J̇v (6): the tree's, else two sweeps of the placement along q̇ = G v (as γ):
  // ẍ, and ω̇ = (R̈ Rᵀ + Ṙ Ṙᵀ)^∨.
  Nodes frame_bias(int k) {
    const TracedModel::FrameNodes& f = m_.frames[k];
    if (!f.bias.empty()) return optimized(f.bias);
    const Nodes rate = directional(g_, f.placement, along_qd_);
    const Nodes acceleration = directional(g_, rate, along_qd_);
    Nodes a(acceleration.begin(), acceleration.begin() + 3);
    const Nodes w1 = angular_velocity(rotation(f.placement), rotation(acceleration)),
                w2 = angular_velocity(rotation(rate), rotation(rate));
    for (int i = 0; i < 3; ++i) a.push_back(g_.add(w1[i], w2[i]));
    return optimized(a);
  }

  // ---- contact sets (docs/CONTRACT.md §3) ----
  // Set s's stacked frame Jacobians (rows × nv, column-major: a point contact its frame's rows
  // 0-2, a 6d one all six) and biases (rows).
  std::pair<Nodes, Nodes> contact_jacobian_and_bias(int s) {
    const TracedModel::ContactSet& set = m_.contact_sets.at(s);
    const int rows = set.rows();
    Nodes J(rows * n_), a;
    int at = 0;
    for (const TracedModel::Contact& c : set.contacts) {
      const Nodes Jf = frame_jacobian(c.frame), af = frame_bias(c.frame);
      const int k = c.six_d ? 6 : 3;
      for (int r = 0; r < k; ++r) {
        for (int j = 0; j < n_; ++j) J[at + r + rows * j] = Jf[r + 6 * j];
        a.push_back(af[r]);
      }
      at += k;
    }
    return {J, a};
  }

  // Set s's system [M Jᵀ; J 0][x; μ] = [f; −γ], solved once for the value and derivative kernels:
  // contact dynamics x = v̇, f = Q − c − ∂V/∂q, γ = a + kd J v; the impulse x = Δv = v⁺ − v⁻,
  // f = 0, γ = (1 + e) J v⁻; λ (Λ) = −μ. Its guards: the pivots of M and of J M⁻¹ Jᵀ + ρI, x and
  // μ finite. `exact`: ρ folded to 0, where the proximal steps fold into the first solve.
  struct ContactProblem {
    std::optional<ContactSpace> space;
    Nodes J, gamma, x, mu, guards;
  };
  const ContactProblem& contact_problem(int s, bool impulse, bool exact = false) {
    ContactProblem& P = contact_problems_[{s, impulse, exact}];
    if (P.space) return P;
    auto [J, a] = contact_jacobian_and_bias(s);
    const int rows = static_cast<int>(a.size());
    const NodeId kd = g_.input(InputKind::kd, 0),
                 e1 = g_.add(Graph::one, g_.input(InputKind::restitution, 0));
    for (int r = 0; r < rows; ++r) {
      NodeId Jv = Graph::zero;
      for (int j = 0; j < n_; ++j) Jv = g_.add(Jv, g_.mul(J[r + rows * j], qd_[j]));
      P.gamma.push_back(impulse ? g_.mul(e1, Jv) : g_.add(a[r], g_.mul(kd, Jv)));
    }
    const NodeId rho = exact ? Graph::zero : g_.input(InputKind::rho, 0);
    P.space.emplace(g_, n_, rows, mass_matrix(), J, rho, P.guards);
    std::tie(P.x, P.mu) =
        P.space->solve(g_, impulse ? Nodes(n_, Graph::zero) : force(), P.gamma, contact_proximal_iterations);
    P.J = std::move(J);
    for (NodeId x : P.x) P.guards.push_back(g_.make(Op::IsFinite, x));
    for (NodeId x : P.mu) P.guards.push_back(g_.make(Op::IsFinite, x));
    return P;
  }

  // A contact kernel's outputs: the velocity part (v̇, v⁺ or their derivatives), then the force
  // part (λ, Λ or theirs), and the guards.
  struct ContactSolution {
    Nodes velocity, force, guards;
  };
  ContactSolution contact_dynamics(int s, bool impulse, bool exact) {
    const ContactProblem& P = contact_problem(s, impulse, exact);
    ContactSolution out{P.x, {}, P.guards};
    if (impulse)
      for (int i = 0; i < n_; ++i) out.velocity[i] = g_.add(qd_[i], P.x[i]);
    for (NodeId m : P.mu) out.force.push_back(g_.neg(m));
    return out;
  }

  // ∂(v̇, λ)/∂(q, v, u), or for the impulse ∂(v⁺, Λ)/∂(q, v⁻), column-major in that order: the
  // solve differentiated on the value's factors, along each direction
  //   [M Jᵀ; J 0][∂x; ∂μ] = [∂f − (∂M)x − (∂J)ᵀμ; −∂γ − (∂J)x]
  // with ∂f − (∂M)x = −∂τ at q̈ := x (the inverse dynamics swept along the direction, O(τ)), and
  // for the impulse (f = 0) −∂(M x) from the momenta ∂T/∂v = M v swept at v := x. Each solved once
  // on the factor of J M⁻¹ Jᵀ + ρI, without proximal steps (as Pinocchio's derivatives): exact for
  // ρ = 0, the regularized system's derivative for ρ > 0 (which differs by O(ρ/σ)); the steps
  // would cost a solve of S per direction each. Where the tree has the closed form
  // (eom::tree_inverse_dynamics_derivatives, a fixed base or a free root), ∂τ/∂q and ∂τ/∂v at
  // q̈ := x come from it instead of a sweep per direction, and the impulse's ∂(M x)/∂q on a free
  // tree (closed_momenta_derivatives); on such a tree (frames on its links) also (∂J)ᵀμ and (∂J)w
  // (closed_jacobian_derivatives) and ∂a/∂q, ∂a/∂v (closed_bias_derivatives) for all directions
  // at once, as Pinocchio's RNEA derivatives take the contact forces as external forces and its
  // frame acceleration derivatives γ's: every combination built, the one with fewest operations
  // kept (MuJoCo's humanoid takes them all; Solo12's contact dynamics keeps the sweeps of τ and of
  // the biases, fewer operations together there).
  // by_rows (SolveForm looped, eomgen/kernels.hpp): `force` is left empty and `velocity` holds
  // the factors' nonzeros, then each direction's right-hand side (f reversed, then γ: the rows of
  // ContactSpace::row_solve) but those folded to zero (RowSolve::zero), then zero padding, which
  // its steps solve.
  ContactSolution contact_derivatives(int s, bool impulse, std::optional<RowSolve>* by_rows = nullptr) {
    const bool closed_tau = impulse ? momenta_closed_form() : !m_.tree_inverse_dynamics_derivatives.empty();
    const bool closed_jacobian = closed_jacobian_applies(s);
    ContactSolution best;
    std::optional<RowSolve> best_rows;
    std::optional<std::size_t> best_ops;
    auto ops = [&](const ContactSolution& x) {
      Nodes all = x.velocity;
      append(all, x.force);
      return count_ops(g_, all);
    };
    // Each candidate built, the one with fewest operations kept.
    // jacobian: 0 J swept, 1 ∂J/∂q closed (the bias swept), 2 ∂a/∂q closed too
    for (const bool tau : {false, true})
      for (const int jacobian : {0, 1, 2}) {
        if ((tau && !closed_tau) || (jacobian && !closed_jacobian) || (jacobian == 2 && impulse)) continue;
        std::optional<RowSolve> rows;
        ContactSolution x = contact_derivatives(s, impulse, tau, jacobian, by_rows ? &rows : nullptr);
        const std::size_t n = ops(x);
        if (!best_ops || n < *best_ops) best = std::move(x), best_rows = std::move(rows), best_ops = n;
      }
    if (by_rows) *by_rows = std::move(best_rows);
    return best;
  }

  // 3-vectors of nodes, for the closed forms below
  using V3 = std::array<NodeId, 3>;
  V3 cross(const V3& a, const V3& b) {
    return {g_.sub(g_.mul(a[1], b[2]), g_.mul(a[2], b[1])), g_.sub(g_.mul(a[2], b[0]), g_.mul(a[0], b[2])),
            g_.sub(g_.mul(a[0], b[1]), g_.mul(a[1], b[0]))};
  }
  V3 plus(const V3& a, const V3& b) { return {g_.add(a[0], b[0]), g_.add(a[1], b[1]), g_.add(a[2], b[2])}; }
  V3 scaled(const V3& a, NodeId x) { return {g_.mul(a[0], x), g_.mul(a[1], x), g_.mul(a[2], x)}; }
  NodeId dot(const V3& a, const V3& b) {
    return g_.add(g_.add(g_.mul(a[0], b[0]), g_.mul(a[1], b[1])), g_.mul(a[2], b[2]));
  }

  // The first velocity whose Jacobian column moving along tangent direction k turns: the
  // columns at or below k's joint, or a free root's angular ones (and those below) for any of its
  // six directions (its linear columns are world-fixed).
  int first_turned(int k) const { return m_.floating() && k < 6 ? 3 : k; }

  // Whether set s's ∂J/∂q terms have the closed form below: frames on a tree with the closed
  // form of its inverse dynamics (no mimic or ball joints; a fixed base or a free root, v's first six).
  bool closed_jacobian_applies(int s) const {
    if (m_.tree_inverse_dynamics_derivatives.empty()) return false;
    for (const TracedModel::Contact& c : m_.contact_sets.at(s).contacts)
      if (m_.frames[c.frame].jacobian.empty()) return false;
    return true;
  }
  // ∂(Jᵀμ)/∂q (nv per tangent direction) and ∂(J w)/∂q (rows per direction) of set s's stacked
  // frame Jacobians in closed form, for every direction at once. About each frame's origin p,
  // column j of its Jacobian is (l_j, a_j) (p's velocity and the angular one per unit v_j); moving
  // q_k turns the columns at or below k's joint about S_k and moves p by l_k, so
  //   ∂(l_j, a_j)/∂q_k = (a_k × l_j, a_k × a_j)  if k is at or above j,   (a_j × l_k, 0) else,
  // with a free root's angular columns turned by all six of its directions and its world-fixed
  // linear ones by none (docs/CONTRACT.md §1's tangent directions). Columns off the frame's chain
  // are zero nodes and drop out. Checked at build time against the sweeps (closed_jacobian_checked_).
  std::pair<Nodes, Nodes> closed_jacobian_derivatives(int s, const Nodes& mu, const Nodes& w) {
    const TracedModel::ContactSet& set = m_.contact_sets.at(s);
    const int rows = set.rows();
    const bool floating = m_.floating();
    const V3 none{Graph::zero, Graph::zero, Graph::zero};
    // k at or above j; the directions whose columns k turns start at first_turned(k)
    auto moves = [&](int k, int j) { return floating && j < 6 ? j >= 3 && k < 6 : k <= j; };
    Nodes jt(n_ * n_, Graph::zero), jw(rows * n_, Graph::zero);
    int at = 0;
    for (const TracedModel::Contact& c : set.contacts) {
      const Nodes J = frame_jacobian(c.frame);
      std::vector<V3> l(n_), a(n_), g(n_), h(n_);
      const V3 f{mu[at], mu[at + 1], mu[at + 2]};
      const V3 n = c.six_d ? V3{mu[at + 3], mu[at + 4], mu[at + 5]} : none;
      for (int j = 0; j < n_; ++j) {
        l[j] = {J[6 * j], J[6 * j + 1], J[6 * j + 2]};
        a[j] = {J[6 * j + 3], J[6 * j + 4], J[6 * j + 5]};
        h[j] = cross(l[j], f);
        g[j] = c.six_d ? plus(h[j], cross(a[j], n)) : h[j];
      }
      // ∂(Jᵀμ)_j/∂q_k = μ · ∂(l_j, a_j)/∂q_k
      for (int k = 0; k < n_; ++k)
        for (int j = 0; j < n_; ++j)
          jt[j + n_ * k] = g_.add(jt[j + n_ * k], moves(k, j) ? dot(a[k], g[j]) : dot(a[j], h[k]));
      // ∂(J w)/∂q_k = a_k × (Σ_{j ≥ F(k)} w_j (l_j, a_j)) + (Σ_{j < F(k)} w_j a_j) × l_k, with
      // F = first_turned: suffix sums of w_j (l_j, a_j), prefix sums of w_j a_j
      std::vector<V3> below_l(n_ + 1, none), below_a(n_ + 1, none), above_a(n_ + 1, none);
      for (int j = n_; j-- > 0;) {
        below_l[j] = plus(below_l[j + 1], scaled(l[j], w[j]));
        below_a[j] = plus(below_a[j + 1], scaled(a[j], w[j]));
      }
      for (int j = 0; j < n_; ++j) above_a[j + 1] = plus(above_a[j], scaled(a[j], w[j]));
      for (int k = 0; k < n_; ++k) {
        const int b = first_turned(k);
        const V3 dl = plus(cross(a[k], below_l[b]), cross(above_a[b], l[k]));
        for (int r = 0; r < 3; ++r) jw[at + r + rows * k] = dl[r];
        if (c.six_d) {
          const V3 da = cross(a[k], below_a[b]);
          for (int r = 0; r < 3; ++r) jw[at + 3 + r + rows * k] = da[r];
        }
      }
      at += c.six_d ? 6 : 3;
    }
    if (closed_jacobian_checked_.insert(s).second) {  // the premise, per set, at placeholders, against sweeps
      Nodes m, x;
      for (int r = 0; r < rows; ++r) m.push_back(g_.input(InputKind::mu, r));
      for (int j = 0; j < n_; ++j) x.push_back(g_.input(InputKind::qdd, j));
      const Nodes Js = contact_jacobian_and_bias(s).first;
      Nodes swept_t, swept_w;
      for (const auto& seeds : along_q_) {
        const Nodes dJ = directional(g_, Js, seeds);
        for (int i = 0; i < n_; ++i) {
          NodeId t = Graph::zero;
          for (int r = 0; r < rows; ++r) t = g_.add(t, g_.mul(dJ[r + rows * i], m[r]));
          swept_t.push_back(t);
        }
        for (int r = 0; r < rows; ++r) {
          NodeId t = Graph::zero;
          for (int j = 0; j < n_; ++j) t = g_.add(t, g_.mul(dJ[r + rows * j], x[j]));
          swept_w.push_back(t);
        }
      }
      auto [closed_t, closed_w] = closed_jacobian_derivatives(s, m, x);
      check_agrees(closed_t, swept_t, "the closed form's ∂(Jᵀμ)/∂q");
      check_agrees(closed_w, swept_w, "the closed form's ∂(J w)/∂q");
    }
    return {optimized(jt), optimized(jw)};
  }

  // ∂a/∂q (rows per tangent direction) of set s's biases a = J̇v in closed form. In the frame's
  // coordinates S_j = (a_j, l_j) (angular, p's velocity), with D(b) = Σ_{j ≥ b} v_j S_j,
  // F = first_turned (the columns k turns, ∂S_j/∂q_k = S_k × S_j), P(b) = Σ_{j < b} v_j S_j and
  // Q(b) = Σ_{k ≥ b} v_k S_k × D(F(k)): the spatial acceleration at v̇ = 0 is A = Q(0), and
  //   ∂A/∂q_n = S_n × Q(F(n)) + P(F(n)) × E_n,   E_n = ∂V/∂q_n = S_n × D(F(n))
  // (Jacobi's identity joins the two terms of the columns n turns). The classical acceleration
  // of p, A's linear part + ω × v_p, adds A.ang × l_n + E_n.ang × v_p + ω × (E_n.lin + ω × l_n)
  // (p moves by l_n); the angular rows (6d) are ∂A.ang. Checked against the bias's sweeps.
  // And ∂a/∂v: ∂A/∂v_n = S_n × D(F(n)) + (Σ_{k : n ∈ k's columns} v_k S_k) × S_n, with
  // v_p's and ω's share S_n.a × v_p + ω × l_n in the linear rows. along_v: ∂/∂v's (rows × nv)
  // after ∂/∂q's.
  Nodes closed_bias_derivatives(int s) {
    const TracedModel::ContactSet& set = m_.contact_sets.at(s);
    const int rows = set.rows();
    const bool floating = m_.floating();
    struct Six {
      V3 a, l;  // angular, linear (about p)
    };
    const V3 none{Graph::zero, Graph::zero, Graph::zero};
    auto sum = [&](const Six& x, const Six& y) { return Six{plus(x.a, y.a), plus(x.l, y.l)}; };
    auto times = [&](const Six& x, NodeId w) { return Six{scaled(x.a, w), scaled(x.l, w)}; };
    auto motion = [&](const Six& x, const Six& y) {  // x × y
      return Six{cross(x.a, y.a), plus(cross(x.a, y.l), cross(x.l, y.a))};
    };
    Nodes da(2 * rows * n_, Graph::zero);
    int at = 0;
    for (const TracedModel::Contact& c : set.contacts) {
      const Nodes J = frame_jacobian(c.frame);
      std::vector<Six> S(n_);
      for (int j = 0; j < n_; ++j)
        S[j] = {{J[6 * j + 3], J[6 * j + 4], J[6 * j + 5]}, {J[6 * j], J[6 * j + 1], J[6 * j + 2]}};
      std::vector<Six> D(n_ + 1, {none, none}), Q(n_ + 1, {none, none}), P(n_ + 1, {none, none});
      for (int j = n_; j-- > 0;) D[j] = sum(D[j + 1], times(S[j], qd_[j]));
      for (int k = n_; k-- > 0;) Q[k] = sum(Q[k + 1], times(motion(S[k], D[first_turned(k)]), qd_[k]));
      for (int j = 0; j < n_; ++j) P[j + 1] = sum(P[j], times(S[j], qd_[j]));
      const Six& A = Q[0];
      const V3& omega = D[0].a;
      const V3& vp = D[0].l;
      for (int n = 0; n < n_; ++n) {
        const int b = first_turned(n);
        const Six E = motion(S[n], D[b]);
        const Six dA = sum(motion(S[n], Q[b]), motion(P[b], E));
        const V3 dl = plus(plus(dA.l, cross(A.a, S[n].l)),
                           plus(cross(E.a, vp), cross(omega, plus(E.l, cross(omega, S[n].l)))));
        for (int r = 0; r < 3; ++r) da[at + r + rows * n] = dl[r];
        if (c.six_d)
          for (int r = 0; r < 3; ++r) da[at + 3 + r + rows * n] = dA.a[r];
      }
      for (int n = 0; n < n_; ++n) {
        const Six& above = floating && n < 3 ? Six{none, none} : P[floating && n < 6 ? 6 : n + 1];
        const Six dA = sum(motion(S[n], D[first_turned(n)]), motion(above, S[n]));
        const V3 dl = plus(dA.l, plus(cross(S[n].a, vp), cross(omega, S[n].l)));
        for (int r = 0; r < 3; ++r) da[rows * n_ + at + r + rows * n] = dl[r];
        if (c.six_d)
          for (int r = 0; r < 3; ++r) da[rows * n_ + at + 3 + r + rows * n] = dA.a[r];
      }
      at += c.six_d ? 6 : 3;
    }
    if (closed_bias_checked_.insert(s).second) {  // the premise, per set, against the bias's sweeps
      const Nodes a = contact_jacobian_and_bias(s).second;
      Nodes swept;
      for (const auto& seeds : along_q_) append(swept, directional(g_, a, seeds));
      for (NodeId x : qd_) {
        const Seed seed{x, Graph::one};
        append(swept, directional(g_, a, std::span(&seed, 1)));
      }
      check_agrees(da, swept, "the closed form's ∂(J̇v)/∂(q, v)");
    }
    return optimized(da);
  }

  ContactSolution contact_derivatives(int s, bool impulse, bool closed_tau, int closed_jacobian,
                                      std::optional<RowSolve>* by_rows) {
    const ContactProblem& P = contact_problem(s, impulse);
    const int rows = static_cast<int>(P.gamma.size());
    std::vector<Seed> at_x, to_qdd;  // the q̈ placeholders: x held while the direction moves
    Nodes qdd;
    for (int j = 0; j < n_; ++j) {
      qdd.push_back(g_.input(InputKind::qdd, j));
      at_x.emplace_back(qdd[j], P.x[j]);
      to_qdd.emplace_back(qd_[j], qdd[j]);
    }
    const Nodes moved = impulse ? substitute(g_, momenta(), to_qdd) : inverse_dynamics();
    std::vector<Direction> along;
    for (const auto& seeds : along_q_) along.push_back({seeds, true});
    for (NodeId x : qd_) along.push_back({{{x, Graph::one}}, false});
    if (!impulse)
      for (NodeId x : u_) along.push_back({{{x, Graph::one}}, false});
    // ∂τ/∂q, ∂τ/∂v of the closed form at q̈ := x (u's directions keep the sweep: only Q moves);
    // the impulse's ∂(M x)/∂q (v⁻'s directions move nothing of f)
    const Nodes dtau = !closed_tau ? Nodes{}
                       : impulse   ? closed_momenta_derivatives(P.x)
                                   : substitute(g_, closed_derivatives(), at_x);
    const std::size_t closed_directions = impulse ? along_q_.size() : 2 * along_q_.size();
    ContactSolution out{{}, {}, P.guards};
    // With the Jacobian's closed form the q directions sweep no J: ∂γ/∂q + (∂J)x = ∂a/∂q (swept,
    // a the frames' biases) + (∂J)(x + kd v), or for the impulse (∂J)(x + (1 + e) v⁻).
    Nodes bias, jt, jw, dbias;
    if (closed_jacobian) {
      Nodes w(n_);
      const NodeId scale =
          impulse ? g_.add(Graph::one, g_.input(InputKind::restitution, 0)) : g_.input(InputKind::kd, 0);
      for (int j = 0; j < n_; ++j) w[j] = g_.add(P.x[j], g_.mul(scale, qd_[j]));
      std::tie(jt, jw) = closed_jacobian_derivatives(s, P.mu, w);  // μ = −λ
      if (closed_jacobian == 2)
        dbias = closed_bias_derivatives(s);
      else if (!impulse)
        bias = contact_jacobian_and_bias(s).second;
    }
    if (by_rows) {
      by_rows->emplace(P.space->row_solve(g_, out.velocity));
      if (impulse) (*by_rows)->identity_from = static_cast<int>(along_q_.size());
    }
    for (std::size_t k = 0; k < along.size(); ++k) {
      const bool from_closed = closed_tau && k < closed_directions;
      const int swept = from_closed ? 0 : n_;  // how many of d are τ's
      const bool jacobian_closed = closed_jacobian && along[k].moves_M_C;
      const bool bias_closed = closed_jacobian == 2 && k < 2 * along_q_.size();  // q and v directions
      Nodes y = from_closed ? Nodes{} : moved;
      if (!bias_closed) append(y, jacobian_closed ? bias : P.gamma);
      if (along[k].moves_M_C && !jacobian_closed) append(y, P.J);
      Nodes d = optimized(substitute(g_, directional(g_, y, along[k].seeds), at_x));
      Nodes df(n_), dgamma(rows, Graph::zero);
      if (bias_closed) {  // along v, γ's kd J v adds kd J's column
        dgamma.assign(dbias.begin() + rows * k, dbias.begin() + rows * (k + 1));
        const NodeId kd = g_.input(InputKind::kd, 0);
        if (!along[k].moves_M_C)
          for (int r = 0; r < rows; ++r)
            dgamma[r] = g_.add(dgamma[r], g_.mul(kd, P.J[r + rows * (k - along_q_.size())]));
      }
      else if (!(jacobian_closed && impulse))
        dgamma.assign(d.begin() + swept, d.begin() + swept + rows);
      for (int i = 0; i < n_; ++i) df[i] = g_.neg(from_closed ? dtau[i + n_ * k] : d[i]);
      if (jacobian_closed) {
        for (int i = 0; i < n_; ++i) df[i] = g_.sub(df[i], jt[i + n_ * k]);
        for (int r = 0; r < rows; ++r) dgamma[r] = g_.add(dgamma[r], jw[r + rows * k]);
      } else if (along[k].moves_M_C) {
        const Nodes dJ(d.begin() + swept + rows, d.end());
        for (int i = 0; i < n_; ++i)
          for (int r = 0; r < rows; ++r) df[i] = g_.sub(df[i], g_.mul(dJ[r + rows * i], P.mu[r]));
        for (int r = 0; r < rows; ++r)
          for (int j = 0; j < n_; ++j) dgamma[r] = g_.add(dgamma[r], g_.mul(dJ[r + rows * j], P.x[j]));
      }
      if (by_rows) {
        if (impulse && k >= along_q_.size())
          for (NodeId x : df)  // f_only's premise
            if (!g_.is_const(x, 0.0)) throw std::logic_error(m_.label() + ": the impulse's f moves along v⁻");
        // A right-hand side folded to zero (a free root's translations along q; the impulse's v⁻
        // off the set's chains) has a zero solution: no column of the steps.
        const auto zero = [&](NodeId x) { return g_.is_const(x, 0.0); };
        if (std::all_of(df.begin(), df.end(), zero) && std::all_of(dgamma.begin(), dgamma.end(), zero)) {
          (*by_rows)->zero.push_back(static_cast<int>(k));
          continue;
        }
        for (int i = n_ - 1; i >= 0; --i) out.velocity.push_back(df[i]);
        append(out.velocity, dgamma);
        continue;
      }
      auto [dx, dmu] = P.space->solve(g_, df, dgamma, 1);
      const bool of_v_minus = impulse && k >= along_q_.size();  // ∂v⁺/∂v⁻ = I + ∂Δv/∂v⁻
      if (of_v_minus) dx[k - along_q_.size()] = g_.add(dx[k - along_q_.size()], Graph::one);
      append(out.velocity, dx);
      for (NodeId m : dmu) out.force.push_back(g_.neg(m));
    }
    if (by_rows) {  // zero columns pad the solved ones to whole vectors (contact_row_lanes)
      RowSolve& r = **by_rows;
      const auto whole = [](int n) { return (n + contact_row_lanes - 1) / contact_row_lanes * contact_row_lanes; };
      const int solved = static_cast<int>(along.size() - r.zero.size());
      r.directions = whole(solved);
      out.velocity.resize(out.velocity.size() + static_cast<std::size_t>((r.directions - solved) * (n_ + rows)),
                          Graph::zero);
      if (impulse) r.f_directions = std::min(r.directions, whole(r.column(static_cast<int>(along_q_.size()))));
    }
    return out;
  }

 public:
  // ∂G/∂q along the tangent directions (3 × nv): one reverse sweep per coordinate of G.
  Nodes center_of_mass_jacobian() {
    Nodes J(3 * n_);
    for (int k = 0; k < 3; ++k) {
      const Nodes row = tangent(gradient(g_, m_.center_of_mass.at(k), q_));
      for (int j = 0; j < n_; ++j) J[k + 3 * j] = row[j];
    }
    return optimized(J);
  }

  // The centroidal momentum's derivative over v, column by column (it is linear in v), at v = 0.
  Nodes centroidal_momentum_matrix() {
    Nodes A;
    for (int j = 0; j < n_; ++j) {
      const Seed seed{qd_[j], Graph::one};
      append(A, directional(g_, m_.centroidal_momentum, std::span(&seed, 1)));
    }
    std::vector<Seed> at_rest;
    for (NodeId x : qd_) at_rest.emplace_back(x, Graph::zero);
    return optimized(substitute(g_, A, at_rest));
  }

 private:
  static void append(Nodes& to, const Nodes& x) { to.insert(to.end(), x.begin(), x.end()); }

  // A tree-form model states its robot twice, as the tree and as the bodies the kinetic energy
  // comes from; written by eomgen-urdf (bodies = eom::tree_bodies of the tree) they agree by
  // construction, but a hand-edited header may not. Compared at one state (every coordinate and
  // rate distinct, the default parameters), the two inverse dynamics must agree to rounding.
  void check_tree_agrees(const Nodes& tree, const Nodes& lagrangian) const {
    const double worst = difference(tree, lagrangian);
    if (!(worst <= 1e-9))
      throw TraceError(m_.label() + ": tree() and bodies() describe different robots: their "
                       "inverse dynamics differ by " + std::to_string(worst) + " at a test state "
                       "(write bodies as eom::tree_bodies of the tree)");
  }
  // Two derivations of one quantity must agree to rounding (else a premise of the generator's
  // is wrong for this model).
  void check_agrees(const Nodes& a, const Nodes& b, const std::string& what) const {
    const double worst = difference(a, b);
    if (!(worst <= 1e-9))
      throw std::logic_error(m_.label() + ": " + what + " differs from its sweeps by " + std::to_string(worst) +
                             " (relative) at a test state");
  }
  // max |a − b| over max(1, max |b|) at a test state (every coordinate and rate distinct, the
  // default parameters).
  double difference(const Nodes& a, const Nodes& b) const {
    Point x;
    for (int i = 0; i < nq_; ++i) x.q.push_back(0.3 + 0.17 * i);
    eom::normalize_configuration(m_.layout(), x.q.data());
    for (int i = 0; i < n_; ++i) {
      x.qd.push_back(0.5 - 0.23 * i);
      x.qdd.push_back(-0.4 + 0.31 * i);
    }
    x.u.assign(m_.nu, 0.7);
    x.p = m_.parameter_values;
    for (const TracedModel::ContactSet& set : m_.contact_sets)  // multipliers' placeholders
      while (static_cast<int>(x.mu.size()) < std::max(set.rows(), m_.nc))
        x.mu.push_back(0.9 - 0.19 * static_cast<double>(x.mu.size()));
    const std::vector<double> ya = evaluate(g_, a, x), yb = evaluate(g_, b, x);
    double scale = 1.0, worst = 0.0;
    for (std::size_t i = 0; i < yb.size(); ++i) scale = std::max(scale, std::abs(yb[i]));
    for (std::size_t i = 0; i < yb.size(); ++i) worst = std::max(worst, std::abs(ya[i] - yb[i]));
    return worst / scale;
  }
  Nodes optimized(const Nodes& x) { return optimize_ ? collect(g_, x) : x; }

  // ∂q̈/∂x for each input x, concatenated, by the differentiated solve
  //   [M Cᵀ; C 0][∂q̈; ∂μ] = [∂f − (∂M)q̈ − (∂C)ᵀμ; −∂γ − (∂C)q̈]
  // on the factors of the forward dynamics. ∂f − (∂M)q̈ comes from one forward sweep along x in
  // one of two ways, the one with fewer operations over all the directions kept:
  //   entries  of f and M's lower triangle, then (∂M)q̈ multiplied out: cheap where M collects
  //            into few terms, each touched by few coordinates (planar chains);
  //   sweep    of the inverse dynamics τ(q, q̇, q̈) at q̈ held fixed: ∂f − (∂M)q̈ = −∂τ/∂x, about
  //            the cost of τ per direction however dense ∂M is (3D bodies, robots).
  // ∂γ and, when x may move them (the pair's second member), ∂C by the same sweep.
  // looped: the right-hand side itself, nq + nc per direction, at q̈ and μ as leaves (inputs qdd
  // and mu: the looped form's dense routine computes them, and solves these right-hand sides on
  // the factors it keeps).
  Nodes solve_derivatives(std::span<const Direction> along, bool looped) {
    Nodes entries, swept;
    for (const Direction& x : along) append(entries, solve_derivative(x, false, looped));
    for (const Direction& x : along) append(swept, solve_derivative(x, true, looped));
    return count_ops(g_, swept) < count_ops(g_, entries) ? swept : entries;
  }

  Nodes solve_derivative(const Direction& x, bool sweep_tau, bool looped) {
    const bool moves_M_C = x.moves_M_C;
    const int nc = m_.nc, n_lower = n_ * (n_ + 1) / 2;
    Nodes qdd, mu;  // the unrolled solve's, or the dense routine's as leaves
    if (looped) {
      for (int j = 0; j < n_; ++j) qdd.push_back(g_.input(InputKind::qdd, j));
      for (int r = 0; r < nc; ++r) mu.push_back(g_.input(InputKind::mu, r));
    } else {
      solver();
      qdd = qdd_;
      mu = mu_;
    }
    // what x moves: f (or τ), γ, then M's lower triangle (unless τ is swept) and C
    Nodes y = sweep_tau ? inverse_dynamics() : force();
    append(y, constraint_bias());
    if (moves_M_C) {
      if (!sweep_tau) append(y, lower(mass_matrix()));
      append(y, constraint_jacobian());
    }
    Nodes d = directional(g_, y, x.seeds);
    if (sweep_tau) {  // τ's q̈ inputs take the forward dynamics' q̈, and ∂f − (∂M)q̈ = −∂τ
      if (!looped) {
        std::vector<Seed> at_qdd;
        for (int j = 0; j < n_; ++j) at_qdd.emplace_back(g_.input(InputKind::qdd, j), qdd[j]);
        d = substitute(g_, d, at_qdd);
      }
      for (int i = 0; i < n_; ++i) d[i] = g_.neg(d[i]);
    }
    d = optimized(d);
    Nodes df(d.begin(), d.begin() + n_), dgamma(d.begin() + n_, d.begin() + n_ + nc);
    if (moves_M_C) {
      const int m_at = n_ + nc, c_at = sweep_tau ? m_at : m_at + n_lower;
      const Nodes dC(d.begin() + c_at, d.end());
      if (!sweep_tau) {
        const Nodes dM = symmetric(Nodes(d.begin() + m_at, d.begin() + c_at));
        for (int i = 0; i < n_; ++i)
          for (int j = 0; j < n_; ++j) df[i] = g_.sub(df[i], g_.mul(dM[i + n_ * j], qdd[j]));
      }
      for (int i = 0; i < n_; ++i)
        for (int r = 0; r < nc; ++r) df[i] = g_.sub(df[i], g_.mul(dC[r + nc * i], mu[r]));
      for (int r = 0; r < nc; ++r)
        for (int j = 0; j < n_; ++j) dgamma[r] = g_.add(dgamma[r], g_.mul(dC[r + nc * j], qdd[j]));
    }
    if (looped) {  // the dense routine takes γ's sign as solve() does
      append(df, dgamma);
      return df;
    }
    return solver().solve(g_, df, dgamma).first;  // solve() takes γ's sign as in the forward dynamics
  }

  // The lower triangle column by column, and back to the full symmetric matrix.
  Nodes lower(const Nodes& A) const {
    Nodes lo;
    for (int j = 0; j < n_; ++j)
      for (int i = j; i < n_; ++i) lo.push_back(A[i + n_ * j]);
    return lo;
  }
  Nodes symmetric(const Nodes& lo) const {
    Nodes A(n_ * n_);
    for (int j = 0, k = 0; j < n_; ++j)
      for (int i = j; i < n_; ++i, ++k) A[i + n_ * j] = A[j + n_ * i] = lo[k];
    return A;
  }

  // Runs f(q, v, out) of eom/model/free_joint.hpp on the recording scalar, so that the generator and
  // the runtime share one G: q the inputs, v the given nodes, out n nodes.
  template <class F> Nodes free_joint(F&& f, const Nodes& v, int n) {
    Tape tape(g_, m_.label());
    Tape::Recording recording(tape, "free joint");
    std::vector<Expr> qe, ve, out(n);
    for (NodeId x : q_) qe.push_back(Expr::node(x));
    for (NodeId x : v) ve.push_back(Expr::node(x));
    f(qe.data(), ve.data(), out.data());
    Nodes ids;
    for (const Expr& e : out) ids.push_back(e.id());
    return ids;
  }
  // A placement's rotation (after the position), and ω = (Ṙ Rᵀ)^∨ of eom/multibody/frames.hpp, recorded.
  static Nodes rotation(const Nodes& placement) { return Nodes(placement.begin() + 3, placement.end()); }
  Nodes angular_velocity(const Nodes& R, const Nodes& dR) {
    Tape tape(g_, m_.label());
    Tape::Recording recording(tape, "frames");
    Rot3<Expr> r, dr;
    for (int k = 0; k < 9; ++k) {
      r[k] = Expr::node(R[k]);
      dr[k] = Expr::node(dR[k]);
    }
    Nodes w;
    for (const Expr& e : eom::detail::world_angular_velocity(r, dr)) w.push_back(e.id());
    return w;
  }
  // Gᵀ x for x over q (nq) to over v (nv): the identity without a free joint.
  Nodes tangent(const Nodes& x) {
    if (!m_.floating()) return x;
    return free_joint([&](auto q, auto g, auto out) { eom::tangent_gradient(m_.layout(), q, g, out); },
                      x, n_);
  }

  TracedModel& m_;
  Graph& g_;
  int nq_, n_;
  bool optimize_;
  Nodes q_, qd_, u_;
  Nodes dtau_;  // inverse_dynamics_derivatives, the cheaper candidate
  Nodes closed_dtau_;
  bool momenta_checked_ = false;  // closed_momenta_derivatives checked its premise
  std::set<int> closed_jacobian_checked_, closed_bias_checked_;  // sets whose closed forms checked it
  std::optional<Solution> closed_bias_solve_;
  std::vector<Seed> along_qd_;  // the direction q̇ = G(q) v in q
  std::vector<std::vector<Seed>> along_q_;  // the tangent directions, G's columns
  Nodes dT_, dT_dq_, M_, c_, dV_, C_, gamma_, f_, qdd_, mu_, guards_, tau_;
  std::map<std::tuple<int, bool, bool>, ContactProblem> contact_problems_;  // (set, impulse, exact)
  std::optional<RangeSpace> solver_;
  std::optional<Factoring> factoring_;
};

// The cost of a Taylor kernel's 16 first coefficients: the order-0 pass, then per coefficient k
// one operation per linear series and about k per recurrence or convolution tail. The optimize
// stage's collected M and f have fewer operations but may have more products of two series
// (chain10: 1.2-1.3x the time of its taylor_coefficients), so the kernel takes the cheaper.
std::size_t taylor_cost(const Graph& g, const Kernel& k) {
  const TaylorPlan plan = make_taylor_plan(g, *k.system, k.guards);
  return plan.operations + 16 * plan.series + 128 * (plan.recurrences + plan.tails);
}

}  // namespace

std::vector<Kernel> build_kernels(TracedModel& m, std::span<const KernelId> requested,
                                  SolveForm solve) {
  Derivation d(m, true);
  int fill = -1;  // M's factor's, where the form is the automatic one (and asked for at all)
  auto looped = [&] {
    if (solve == SolveForm::automatic && fill < 0) fill = d.factoring().fill;
    return solve_form(fill, solve) == SolveForm::looped;
  };
  // A tree-form model: tree() and bodies() must describe one robot whatever is asked for (M, c and
  // the frames may all come from the tree); inverse_dynamics() compares the two.
  if (!m.tree_inverse_dynamics.empty()) d.inverse_dynamics();
  std::optional<Derivation> plain;  // without the optimize stage, for Taylor mode
  std::vector<Kernel> out;
  for (KernelId k : requested) {
    if (m.nc == 0 && (k == KernelId::constraint_residual || k == KernelId::constraint_jacobian ||
                      k == KernelId::constraint_bias))
      throw std::invalid_argument(std::string(signature(k).name) +
                                  " requested but the model has no constraints");
    if (per_frame(k) && m.frames.empty())
      throw std::invalid_argument(m.label() + ": " + std::string(signature(k).name) +
                                  " requested but FRAMES names no frame; name the frames in "
                                  "FRAMES (or leave the kernel out of KERNELS)");
    if (of_mass_centre(k) && m.center_of_mass.empty())
      throw std::invalid_argument(
          m.label() + ": " + std::string(signature(k).name) +
          (m.has_bodies ? " was not traced (trace with TraceRequest::mass_centre)"
                        : " needs the body or tree form (bodies); the model states T itself, "
                          "which has no bodies to weigh"));
    if (per_contact_set(k) && m.contact_sets.empty())
      throw std::invalid_argument(m.label() + ": " + std::string(signature(k).name) +
                                  " requested but CONTACTS names no contact set; name the sets in "
                                  "CONTACTS (or leave the kernel out of KERNELS)");
    if (per_contact_set(k)) {
      const bool impulse = k == KernelId::impulse_dynamics || k == KernelId::impulse_dynamics_derivatives;
      const bool value = k == KernelId::contact_dynamics || k == KernelId::impulse_dynamics;
      const int directions = 2 * m.nv + (impulse ? 0 : m.nu);
      const bool by_rows = !value && contact_solve_form(directions, solve) == SolveForm::looped;
      // A value kernel also gets its twin with ρ = 0 folded (Kernel::exact), which the set's
      // switch calls for rho == 0
      for (int exact = 0; exact <= (value ? 1 : 0); ++exact)
        for (int s = 0; s < static_cast<int>(m.contact_sets.size()); ++s) {
          Kernel kernel{k, {}, {}};
          kernel.contact_set = s;
          kernel.exact = exact != 0;
          auto [velocity, force, guards] =
              value ? d.contact_dynamics(s, impulse, kernel.exact)
                    : d.contact_derivatives(s, impulse, by_rows ? &kernel.row_solve : nullptr);
          kernel.outputs = std::move(velocity);
          kernel.outputs.insert(kernel.outputs.end(), force.begin(), force.end());
          kernel.guards = std::move(guards);
          out.push_back(std::move(kernel));
        }
      continue;
    }
    if (per_frame(k)) {
      for (int f = 0; f < static_cast<int>(m.frames.size()); ++f) {
        Kernel kernel{k, {}, {}};
        kernel.frame = f;
        kernel.outputs = k == KernelId::frame_placement ? m.frames[f].placement
                         : k == KernelId::frame_jacobian ? d.frame_jacobian(f)
                                                         : d.frame_bias(f);
        out.push_back(std::move(kernel));
      }
      continue;
    }
    Kernel kernel{k, {}, {}};
    switch (k) {
      case KernelId::mass_matrix: kernel.outputs = d.mass_matrix_output(); break;
      case KernelId::mass_matrix_dot: kernel.outputs = d.mass_matrix_dot(); break;
      case KernelId::coriolis: kernel.outputs = d.coriolis(); break;
      case KernelId::potential_gradient: kernel.outputs = d.potential_gradient(); break;
      case KernelId::generalized_forces: kernel.outputs = d.generalized_forces(); break;
      case KernelId::constraint_residual: kernel.outputs = m.constraints; break;
      case KernelId::constraint_jacobian: kernel.outputs = d.constraint_jacobian(); break;
      case KernelId::constraint_bias: kernel.outputs = d.constraint_bias(); break;
      case KernelId::forward_dynamics:
      case KernelId::forward_dynamics_batch: {  // the same graph, written for vector lanes
        if (k == KernelId::forward_dynamics_batch && looped())
          throw std::invalid_argument(
              m.label() + ": forward_dynamics_batch is written in the unrolled form only, and the "
              "solve here is looped (" +
              (solve == SolveForm::looped
                   ? std::string("--solve looped was asked for")
                   : "M's factor has " + std::to_string(fill) + " entries below the diagonal: from " +
                         std::to_string(looped_fill_from) + " on (a full M of " +
                         std::to_string(looped_solve_from) +
                         " coordinates), the unrolled form's statements grow too many") +
              "); leave it out of KERNELS, or ask for the unrolled form (--solve unrolled)");
        const bool looped_here = looped() && k == KernelId::forward_dynamics;
        auto [qdd, guards, tree, by_steps] = d.forward_dynamics_kernel(looped_here);
        kernel.outputs = qdd;
        kernel.guards = guards;
        kernel.by_steps = by_steps && k == KernelId::forward_dynamics;  // lanes: throughput
        if (!tree) {
          kernel.system = d.linear_system(looped_here);
          kernel.looped = looped_here;
        }
        break;
      }
      case KernelId::kinetic_energy: kernel.outputs = {m.kinetic_energy}; break;
      case KernelId::potential_energy: kernel.outputs = {m.potential_energy}; break;
      case KernelId::forward_dynamics_derivatives: {
        auto [outputs, guards] = d.forward_dynamics_derivatives(looped());
        kernel.outputs = std::move(outputs);
        kernel.guards = std::move(guards);
        break;
      }
      case KernelId::inverse_dynamics: kernel.outputs = d.inverse_dynamics(); break;
      case KernelId::inverse_dynamics_derivatives:
        kernel.outputs = d.inverse_dynamics_derivatives();
        break;
      case KernelId::forward_dynamics_parameter_derivatives:
        kernel.outputs = d.forward_dynamics_parameter_derivatives(looped());
        break;
      case KernelId::center_of_mass: kernel.outputs = m.center_of_mass; break;
      case KernelId::center_of_mass_jacobian: kernel.outputs = d.center_of_mass_jacobian(); break;
      case KernelId::centroidal_momentum_matrix:
        kernel.outputs = d.centroidal_momentum_matrix();
        break;
      case KernelId::frame_placement:
      case KernelId::frame_jacobian:
      case KernelId::frame_acceleration_bias:  // above, per frame
      case KernelId::contact_dynamics:
      case KernelId::impulse_dynamics:
      case KernelId::contact_dynamics_derivatives:
      case KernelId::impulse_dynamics_derivatives: break;  // above, per contact set
      case KernelId::taylor_coefficients: {
        // The series of M and f collected or as derived, whichever is cheaper (taylor_cost);
        // q̈ and the order-0 factors are the solve's either way, so that coefficient 1 of q̇ is
        // the forward_dynamics kernel's q̈ to the last bit (to rounding where that kernel uses
        // the articulated-body algorithm).
        // Looped, the dense routine solves at order 0 and for each coefficient: the kernel keeps
        // M, f, C, γ and no solve of its own (TaylorSystem).
        Kernel a{k, {}, {}, d.linear_system(looped())};
        a.looped = looped();
        if (!looped()) {
          a.outputs = d.forward_dynamics();
          a.guards = d.guards();
        }
        if (!plain) plain.emplace(m, false);
        Kernel b = a;
        b.system->mass = plain->mass_matrix();
        b.system->force = plain->force();
        kernel = taylor_cost(m.graph, b) < taylor_cost(m.graph, a) ? std::move(b) : std::move(a);
        break;
      }
    }
    if (k == KernelId::forward_dynamics_derivatives || k == KernelId::forward_dynamics_parameter_derivatives) {
      if (looped()) {
        kernel.system = d.linear_system(true);
        kernel.looped = true;
      } else if (k == KernelId::forward_dynamics_parameter_derivatives) {
        kernel.guards = d.guards();
      }
    }
    out.push_back(std::move(kernel));
  }
  return out;
}

}  // namespace eom::gen
