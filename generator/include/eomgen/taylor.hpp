// Taylor mode: the normalized Taylor coefficients of the motion (the taylor_coefficients kernel),
// and of any graph's outputs along input series (evaluate_taylor), by univariate Taylor
// arithmetic on the nodes.
//
// A node's series is its coefficients x_0 .. x_order (x_j = x^(j)(t)/j!). The plan classifies
// each node once:
//   constant  depends on constants, p and u only (and booleans, decided at order 0): its higher
//             coefficients are zero, so it is computed once as a scalar and every operation with
//             it is linear (a constant factor scales, a constant term drops out)
//   varying   depends on t, q or q̇: a series. Linear operations (±, ·constant, /constant, abs,
//             select) give coefficient k from coefficient k of their arguments alone; the others
//             (products of two series, quotients, sqrt, exp, log, pow, sin/cos, tan, asin, acos,
//             atan, atan2, hypot) run a recurrence over lower coefficients
//   stored    a varying node whose lower coefficients a recurrence reads (an argument of a
//             product, the result of a quotient, ...): it gets a slot of order + 1 doubles; any
//             other varying node is a temporary, recomputed per coefficient
// Some recurrences need auxiliary series (the cos beside a sin, 1 + tan², √(1 − a²), 1 + a²,
// x² + y², log a and b·log a for a^b): each has a slot of its own. Which, and every recurrence,
// is the operation's entry in the operation table (src/ops/): one rule the evaluator here and the
// emitted code both run. Data-dependent choices (select
// conditions, the sign of abs) and the guards are decided from the order-0 values.
//
// The motion (system mode). The forward dynamics solve [M Cᵀ; C 0][q̈; μ] = [f; −γ] by an unrolled
// factorization. Its coefficient k is not taken through the factorization (a series product per
// entry of L and of every solve step, O(n³) recurrences): with coefficients 0..k−1 of q̈ and μ
// known, coefficient k of the system reads
//   M₀ q̈_k + C₀ᵀ μ_k = f_k − Σ_{j=1..k} (M_j q̈_{k−j} + C_jᵀ μ_{k−j})
//   C₀ q̈_k           = −γ_k − Σ_{j=1..k} C_j q̈_{k−j}
// so the series of M, f, C, γ (node recurrences), n² + 2 n·nc convolution tails (one per varying
// entry), and the order-0 factors applied to the right-hand side (linear, O(n²)) give q̈_k, μ_k.
//
// evaluate_taylor() and taylor_ode() run exactly the statements the emitted kernel writes: the
// plan's two passes (order0, coefficient: one schedule, made here), each step by the operation
// table's rule, with the same helper functions (src/taylor_recurrences.inc, which the emitter
// copies into the generated code), so tests check the arithmetic without compiling anything.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "eomgen/graph.hpp"

namespace eom::gen {

// The highest order the emitted taylor_coefficients accepts. The workspace grows linearly with the
// order and the work quadratically; double precision gains nothing beyond order ~30 (the optimal
// order for tolerance ε is about −½ ln ε + 1 ≈ 19 at ε = 1e-16, Jorba & Zou 2005), and an
// integrator may size fixed arrays by it (eom/integration/taylor.hpp: 2·2·nq·(max + 1) doubles on the stack).
inline constexpr int taylor_max_order = 64;

// The forward dynamics as a linear system, for Taylor mode (kernels.cpp builds it).
struct TaylorSystem {
  int nq = 0, nc = 0;
  std::vector<NodeId> mass;      // M, nq×nq column-major
  std::vector<NodeId> force;     // f = Q − c − ∂V/∂q
  std::vector<NodeId> jacobian;  // C, nc×nq column-major
  std::vector<NodeId> bias;      // γ
  std::vector<NodeId> qdd, mu;   // the solution at order 0 (forward_dynamics' q̈, the multipliers)
  // The order-0 solve of [M Cᵀ; C 0][x; y] = [r; −s] for a right-hand side given as the inputs
  // rhs 0..nq−1 (r) and rhs nq..nq+nc−1 (s): nodes linear in those, with the factors as scalars.
  std::vector<NodeId> solve_qdd, solve_mu;
  // The looped form (Kernel::looped): qdd, mu, solve_qdd and solve_mu are empty, and the kernel
  // (and taylor_ode) solve at order 0 and per coefficient by the dense routine.
  bool looped = false;
};

// The entries of the looped form's dense array (M's lower triangle row by row, f, C, γ) and
// their positions in it: what the kernel writes before it calls the dense routine.
std::vector<std::pair<NodeId, int>> dense_system_entries(const TaylorSystem& s);

// One statement of a pass, in the order the emitted kernel writes them and the evaluator
// (evaluate_taylor, taylor_ode) runs them.
struct TaylorStep {
  enum class Kind : std::uint8_t {
    node,         // order 0: node's value, its auxiliaries' first coefficients (and the q̈, μ it
                  // is); coefficient k: node's coefficient by its rule (a sin/cos pair at the
                  // lower id), or a step of the solve
    rhs,          // row `index` of coefficient k's right-hand side (convolution tails)
    dense_solve,  // the looped form: the right-hand side solved on the dense routine's factors
    result_qdd,   // coefficient k of q̈_index (and of q̇_index at k + 1)
    result_mu,    // coefficient k of μ_index
  };
  Kind kind;
  NodeId node = 0;  // kind node
  int index = 0;    // rhs row, q̈ or μ index
};

struct TaylorPlan {
  std::optional<TaylorSystem> system;  // system mode
  std::vector<NodeId> nodes;    // what order 0 computes (the cone of outputs, guards), id order
  std::vector<char> varying;    // per graph id: a series (else: a scalar, zero higher coefficients)
  std::vector<char> needed;     // per graph id: a varying node whose coefficients k >= 1 are
                                // needed (a varying node read only by conditions, or only as an
                                // order-0 factor of the system, is not)
  std::vector<char> stored;     // per graph id: a needed node whose lower coefficients are read
  std::vector<char> nonlinear;  // per graph id: coefficient k by a recurrence over lower ones
  // sin a and cos a in the cone: the one with the lower id computes both (partner = the other).
  std::vector<NodeId> partner;  // per graph id; 0 when none
  struct Aux {
    NodeId owner;
    int which;  // index into the owner's table entry's aux list
  };
  std::vector<Aux> aux;        // auxiliary series, in owner order
  std::vector<int> first_aux;  // per graph id: index into aux of its first auxiliary, or −1
  // System mode: the per-coefficient solve, nodes depending on the rhs inputs, in id order.
  std::vector<char> solve;
  std::vector<NodeId> solve_nodes;
  // The two passes. Order 0: the non-leaf nodes read later (system mode: by q̈, μ, the guards,
  // the dense routine, the recurrences and the solve; plain mode: all), in id order, a cos right
  // after the sin of the same argument. Coefficient k: the needed series, then (system mode) the
  // right-hand side, the solve and the results.
  std::vector<TaylorStep> order0, coefficient;

  // Statistics (for the generated comment and the README)
  std::size_t operations = 0;   // non-leaf nodes of the cone (the order-0 pass)
  std::size_t series = 0;       // needed non-leaf nodes (coefficient k of each, per k)
  std::size_t recurrences = 0;  // of those, the nonlinear ones
  std::size_t tails = 0;        // system mode: convolution tails of the right-hand side
  std::size_t slots = 0;        // stored series (inputs and q̈, μ included) + auxiliary series
};

// Plain mode: series of `outputs` (evaluate_taylor).
TaylorPlan make_taylor_plan(const Graph& g, std::span<const NodeId> outputs,
                            std::span<const NodeId> guards = {});
// System mode: the motion (the taylor_coefficients kernel).
TaylorPlan make_taylor_plan(const Graph& g, const TaylorSystem& system,
                            std::span<const NodeId> guards);

// Input series for evaluate_taylor: t, q, q̇ as coefficient vectors (missing coefficients are 0,
// so {t, 1} is time itself); u and p are constants.
struct SeriesPoint {
  std::vector<double> t;
  std::vector<std::vector<double>> q, qd;
  std::vector<double> u, p;
};

// Coefficients 0..order of each output (result[i][k]), by the plan's recurrences; the inputs
// must not involve qdd. Guards are not checked here.
std::vector<std::vector<double>> evaluate_taylor(const Graph& g, std::span<const NodeId> outputs,
                                                 const SeriesPoint& x, int order);

// The motion q̈ = forward dynamics through (t, q, q̇): coefficients 0..order of q (result[0][k*nq
// + i]) and q̇ (result[1]), as the emitted taylor_coefficients kernel computes them (without its
// input and guard checks).
std::array<std::vector<double>, 2> taylor_ode(const Graph& g, const TaylorSystem& system,
                                              const Point& x, int order);

}  // namespace eom::gen
