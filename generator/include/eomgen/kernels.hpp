// The kernels of docs/CONTRACT.md §3, as graphs: their catalog (KernelId, Signature), the model
// once traced (TracedModel, which eomgen/trace.hpp's trace<Model>() records), and
//   build_kernels()  derives every requested kernel on that graph (see src/kernels.cpp for the
//                    derivative strategy of each), giving per kernel its output and guard nodes
//
// All kernels share one graph, so a subexpression common to several kernels is one node; the
// emitter writes each kernel from the cone of its own outputs only.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <eom/model/free_joint.hpp>

#include "eomgen/graph.hpp"
#include "eomgen/tape.hpp"
#include "eomgen/taylor.hpp"

namespace eom::gen {

// The kernels of docs/CONTRACT.md §3, in the order the generated header declares them.
enum class KernelId {
  mass_matrix, mass_matrix_dot, coriolis, potential_gradient, generalized_forces,
  constraint_residual, constraint_jacobian, constraint_bias, forward_dynamics, kinetic_energy,
  potential_energy, forward_dynamics_derivatives, inverse_dynamics, taylor_coefficients,
  forward_dynamics_parameter_derivatives, forward_dynamics_batch,
  frame_placement, frame_jacobian, frame_acceleration_bias,  // one case per frame FRAMES names
  center_of_mass, center_of_mass_jacobian, centroidal_momentum_matrix,
  inverse_dynamics_derivatives,
  contact_dynamics, impulse_dynamics,  // one case per contact set CONTACTS names
  contact_dynamics_derivatives, impulse_dynamics_derivatives,
};
inline constexpr int kernel_count = 27;

// Kernels generated only when KERNELS names them, never by default: ∂q̈/∂p (for parameter
// identification: most users never need it, and it costs a solve per parameter), the batch
// forward dynamics (SIMD lanes, for ensembles; eomgen/emit.hpp), the mass centre's kernels, and
// ∂τ/∂(q, v) (for MPC, DDP and identification).
inline constexpr bool on_request_only(KernelId k) {
  return k == KernelId::forward_dynamics_parameter_derivatives ||
         k == KernelId::inverse_dynamics_derivatives ||
         k == KernelId::forward_dynamics_batch || k == KernelId::center_of_mass ||
         k == KernelId::center_of_mass_jacobian || k == KernelId::centroidal_momentum_matrix;
}
// And for a model with unit quaternions in q (free and ball joints, eom/model/free_joint.hpp):
// taylor_coefficients (by default it would add a Taylor kernel to the build of every floating
// model, most of which never integrate by Taylor's method; KERNELS defaults taylor_coefficients).
inline constexpr bool on_request_when_floating(KernelId k) { return k == KernelId::taylor_coefficients; }
// Kernels of one frame each, called with the frame's index f (eom/multibody/frames.hpp): generated, by
// default, when FRAMES names a frame.
inline constexpr bool per_frame(KernelId k) {
  return k == KernelId::frame_placement || k == KernelId::frame_jacobian ||
         k == KernelId::frame_acceleration_bias;
}
// Kernels of one contact set each, called with the set's index s: generated, by default, when
// CONTACTS names a set.
inline constexpr bool per_contact_set(KernelId k) {
  return k == KernelId::contact_dynamics || k == KernelId::impulse_dynamics ||
         k == KernelId::contact_dynamics_derivatives || k == KernelId::impulse_dynamics_derivatives;
}
// The proximal steps of the contact kernels (kernels.cpp's RangeSpace): each shrinks λ's error
// along an eigenvalue σ of J M⁻¹ Jᵀ by ρ/(σ + ρ), so for ρ up to 1e-4 σ four leave 1e-16.
inline constexpr int contact_proximal_iterations = 4;
// Kernels written as one function per case (a frame, a contact set) and a switch over the index.
inline constexpr bool per_case(KernelId k) { return per_frame(k) || per_contact_set(k); }
// Kernels of the mass centre: for models with bodies (the body or tree form).
inline constexpr bool of_mass_centre(KernelId k) {
  return k == KernelId::center_of_mass || k == KernelId::center_of_mass_jacobian ||
         k == KernelId::centroidal_momentum_matrix;
}

enum class Dim {
  one, three, six, nq, nv, nc, nu, np, series /* order + 1 */, outputs /* as many as the kernel has */,
  contact /* the contact set's rows: each case has its own */
};

// A kernel's C++ signature: `result name(leading..., inputs..., double* outputs..., trailing...)`;
// t is `double t`, every other input `const double* x`.
struct Signature {
  struct Output {
    std::string_view name;
    Dim rows, cols;  // column-major rows × cols
    int count = -1;  // one case's length where a Dim varies by case (Dim::contact), else −1
  };
  struct Extra {
    std::string_view type, name;
  };
  std::string_view name;
  std::string_view summary;  // one line of documentation in the generated header ("": none)
  std::string_view result;  // "void", "double" (one output, returned), "bool" (false: singular)
                            // or "unsigned" (the batch kernel's mask of lanes that succeeded)
  std::vector<InputKind> inputs;
  std::vector<Output> outputs;
  std::vector<Extra> leading = {}, trailing = {};  // e.g. Taylor's `int order`, `double* work`
};
// The generator's kernel table: one row per KernelId with its signature and summary (the
// runtime's EOM_KERNEL_CATALOG in eom/model/kernels.hpp lists the same kernels; tests/generator's
// test_catalog checks that names, order, results and arguments agree).
const Signature& signature(KernelId k);
std::optional<KernelId> kernel_from_name(std::string_view name);

// The velocities' names: the coordinates', but for each unit quaternion's (eom/model/free_joint.hpp;
// `quaternions`: the q index of each w). A free joint's six (x, y, z, qw, qx, qy, qz in q; vx,
// vy, vz, wx, wy, wz in v) are named <P>vx … <P>wz when its first three coordinates are <P>x,
// <P>y, <P>z (the root's: else vx … wz); a ball joint's three <P>wx, <P>wy, <P>wz when its w is
// <P>qw, else <w>_wx ….
std::vector<std::string> velocity_names(const std::vector<std::string>& coordinates,
                                        const std::vector<int>& quaternions, bool floating);

// The model once recorded: sizes, free parameters, and its functions as nodes of `graph`.
// Inputs are the nodes graph.input(kind, i); a fixed parameter is a constant, never an input.
struct TracedModel {
  std::string name;        // the model's name (add_eom_model's <name>)
  std::string class_name;  // the C++ class, as the user wrote it
  int nq = 0, nv = 0, nu = 0, nc = 0;  // nv = nq − the quaternions (eom/model/free_joint.hpp)
  std::vector<int> quaternions;        // the q index of each unit quaternion's w (nq − nv)
  bool has_generalized_forces = false;
  std::vector<std::string> parameter_names;  // free parameters only, in model order
  std::vector<double> parameter_values;
  // The model's names (coordinates: nq; velocities: nv, the free joint's six named below; inputs:
  // nu) and its limits, ±inf where the model states none (position_lower/upper: nq;
  // effort_limit, velocity_limit: nv; a URDF model header carries its <limit>s).
  std::vector<std::string> coordinate_names, velocity_names, input_names;
  std::vector<double> position_lower, position_upper, effort_limit, velocity_limit;
  Graph graph;
  NodeId kinetic_energy = Graph::zero, potential_energy = Graph::zero;
  std::vector<NodeId> constraints, generalized_forces;
  // Tree-form models (eom/multibody/tree.hpp), empty for others: M v̇ + c by the recursive Newton–Euler
  // algorithm at the inputs q, v (qd), v̇ (qdd); and v̇ = M⁻¹(τ − c) by the articulated-body
  // algorithm with τ the placeholder inputs rhs, with its pivots; M by the composite-rigid-body
  // algorithm (nv × nv).
  std::vector<NodeId> tree_inverse_dynamics, tree_forward_dynamics, tree_pivots, tree_mass_matrix;
  // ∂(M v̇ + c)/∂q, then /∂v, in closed form (eom::tree_inverse_dynamics_derivatives; nv × nv
  // each): for a fixed base without mimic joints, else empty. With tree_gravity, of
  // M v̇ + c + ∂V/∂q: the potential is gravity on the tree's bodies (V = g Σ m z, as a URDF
  // header writes it).
  std::vector<NodeId> tree_inverse_dynamics_derivatives;
  bool tree_gravity = false;
  NodeId gravity = 0;  // with tree_gravity: g's node (a constant or a parameter)
  bool one_free_root = false;  // the tree hangs from a free link 0 alone (no other link on the world)
  // Its by-product τ (M v̇ + c, with tree_gravity + ∂V/∂q), which shares its vectors.
  std::vector<NodeId> tree_closed_tau;
  // With tree_gravity (a fixed base or a free root): tree_inverse_dynamics (τ + ∂V/∂q) and
  // tree_forward_dynamics (at τ = rhs, no −∂V/∂q) with gravity as the world's upward acceleration.
  std::vector<NodeId> tree_inverse_dynamics_gravity, tree_forward_dynamics_gravity;
  // M with each column's force dotted in world axes (eom::tree_mass_matrix_world; a tree without
  // free or ball joints, else empty): the mass_matrix kernel's where it has fewer operations.
  std::vector<NodeId> tree_mass_matrix_world;
  // tree_forward_dynamics and tree_forward_dynamics_gravity with the outward pass from the
  // parent's acceleration (eom::AbaOutward::from_parent), where they are traced.
  std::vector<NodeId> tree_forward_dynamics_from_parent, tree_forward_dynamics_gravity_from_parent;
  // The frames FRAMES names (eom/multibody/frames.hpp), in that order: the placement (position, then the
  // rotation column-major) and, for a frame on a link of the tree form, its Jacobian (6 × nv)
  // and bias J̇v (6) by the tree's recursions; empty for a frame of frames(): build_kernels
  // differentiates the placement.
  struct FrameNodes {
    std::string name;
    std::vector<NodeId> placement, jacobian, bias;
  };
  std::vector<FrameNodes> frames;
  // The contact sets CONTACTS names (docs/CONTRACT.md §3), in that order: each contact a frame
  // (its index in `frames`) held in position (3 rows) or, six_d, in placement (6 rows).
  struct Contact {
    int frame = 0;
    bool six_d = false;
  };
  struct ContactSet {
    std::string name;
    std::vector<Contact> contacts;
    int rows() const {
      int r = 0;
      for (const Contact& c : contacts) r += c.six_d ? 6 : 3;
      return r;
    }
  };
  std::vector<ContactSet> contact_sets;
  bool has_bodies = false;  // the body or tree form: the mass centre's kernels apply
  // When traced (TraceRequest::mass_centre): the mass centre (3) and the centroidal momentum (6)
  // at (q, qd), eom/multibody/frames.hpp.
  std::vector<NodeId> center_of_mass, centroidal_momentum;

  int np() const { return static_cast<int>(parameter_names.size()); }
  bool floating() const { return nq != nv; }
  eom::Layout layout() const { return {nq, nv, quaternions.data()}; }
  std::string label() const { return "model " + name + " (" + class_name + ")"; }
};

// The kernels generated by default for a model: constraint_* only when nc > 0, no on-request
// kernel (nor, with quaternions in q, taylor_coefficients).
std::vector<KernelId> applicable_kernels(const TracedModel& m);
// Every kernel a model may request: the default ones, then the on-request ones.
std::vector<KernelId> requestable_kernels(const TracedModel& m);

// The kernels that solve [M Cᵀ; C 0][q̈; μ] = [f; −γ] (forward_dynamics and its derivatives)
// take one of two forms:
//   unrolled  the LDLᵀ factorization and the range-space solves as straight-line statements:
//             structural zeros of M vanish and every operand is a register or a constant, but
//             a dense M costs O(nq³) statements (the derivative kernels O(nq⁴)), which dominate
//             the compile time of big models
//   looped    M, f, C, γ as straight-line statements, then a small dense routine with loops
//             factors and solves them (eomgen/emit.hpp): O(nq²) statements (the derivative
//             kernels O(nq³): their right-hand sides)
// `automatic` takes the looped form where M's factor L, in the order the unrolled solve takes
// (leaves first on a branching tree), has at least looped_fill_from entries below the diagonal:
// as many as a full M of looped_solve_from coordinates, where the looped form is faster to
// compile and no slower to run (docs/benchmarks/scaling.md and generator/README.md have the
// measurements on chains). A branching tree keeps the unrolled form longer: Romeo (37
// velocities, 297 entries) runs its forward_dynamics_derivatives unrolled in 0.46-0.61x the looped
// kernel's time (docs/benchmarks/pinocchio.md). Taylor mode takes the form too (the order-0 solve,
// and each coefficient's solve on its factors); forward_dynamics_batch exists unrolled only.
enum class SolveForm { automatic, unrolled, looped };
inline constexpr int looped_solve_from = 30;
inline constexpr int looped_fill_from = looped_solve_from * (looped_solve_from - 1) / 2;

// The form of a model whose M factors with `fill` entries below the diagonal: the one place
// that decides.
constexpr SolveForm solve_form(int fill, SolveForm asked) {
  if (asked != SolveForm::automatic) return asked;
  return fill >= looped_fill_from ? SolveForm::looped : SolveForm::unrolled;
}

// The contact derivative kernels take one of two forms too (the same SolveForm):
//   unrolled  each direction's solve on the value's factors written out, straight-line and
//             scalar: ~1.9k operations a direction on MuJoCo's humanoid, 70% of the kernel
//   looped    the right-hand sides written by rows (value i of every direction side by side),
//             then the solve as a list of row steps over the factors' nonzeros (RowSolve), each
//             a multiply-add along two rows that the compiler vectorizes across the directions
// `automatic` takes the rows form from contact_rows_from directions (2 nv + nu, or 2 nv for the
// impulse): a step then fills at least two 4-wide vectors, where a few directions would leave the
// lanes empty and lose the straight-line form's constant folding (a free base alone has 12).
inline constexpr int contact_rows_from = 8;
constexpr SolveForm contact_solve_form(int directions, SolveForm asked) {
  if (asked != SolveForm::automatic) return asked;
  return directions >= contact_rows_from ? SolveForm::looped : SolveForm::unrolled;
}

// The row steps' right-hand sides come in multiples of this many (an AVX-512 vector of doubles;
// two of AVX2), zero columns padding them: each step's loop then has no remainder (Solo12's
// stance: 45 directions took 1.01-1.03x the time of 48).
inline constexpr int contact_row_lanes = 8;

// A solve by rows: B := A⁻¹ B for the right-hand sides B (`rows` rows of `directions` values,
// row i at rhs + ld·i), A given by its factors' nonzeros (`factors` values), as steps in order.
struct RowSolve {
  struct Step {
    enum class Kind : std::uint8_t { add, scale } kind;  // B[to] += f B[from]; B[to] *= f
    int from, to, factor;
    bool negate;  // −f instead of f
    bool f_only = false;  // a step on f's part alone (y = L⁻¹ f, Zsᵀ y, D⁻¹ y): f_directions of them
  };
  int factors = 0, rows = 0, directions = 0;
  std::vector<Step> steps;
  // The outputs from the solved rows: the velocity part's value i in row velocity_row(i), the
  // force part's (negated: λ = −μ) from row force_from; the impulse adds the identity to
  // ∂v⁺/∂v⁻ (directions identity_from… of the velocity part; −1: none).
  int nv = 0, force_rows = 0, force_from = 0;
  bool reversed = false;  // velocity_row(i) = nv − 1 − i, else i
  int identity_from = -1;
  // The directions whose f may be nonzero, a prefix (the impulse's along q: v⁻ moves γ alone),
  // in whole vectors; −1: all. The f_only steps run over those.
  int f_directions = -1;
  // The directions (in the outputs' column order) whose right-hand side folded to zero,
  // ascending: not solved, their output columns zero. `directions` counts the solved ones and
  // the zero columns after them that pad them to whole vectors.
  std::vector<int> zero;
  // Direction d's column among the solved ones (for d not in `zero`).
  int column(int d) const {
    return d - static_cast<int>(std::lower_bound(zero.begin(), zero.end(), d) - zero.begin());
  }
  int velocity_row(int i) const { return reversed ? nv - 1 - i : i; }
  int ld() const { return directions; }
  int count(const Step& s) const { return s.f_only && f_directions >= 0 ? f_directions : directions; }
};

struct Kernel {
  KernelId id;
  std::vector<NodeId> outputs;  // the signature's outputs, flattened in order (but see looped)
  std::vector<NodeId> guards;   // conditions that must all hold, else the kernel returns false
  // forward_dynamics, its derivatives and taylor_coefficients: the linear system
  // [M Cᵀ; C 0][q̈; μ] = [f; −γ] they solve, for Taylor mode to differentiate and for the looped
  // form
  std::optional<TaylorSystem> system = {};
  // The looped form (SolveForm): the emitter solves `system` (M, f, C, γ only) by the dense
  // routine, whose pivot test and q̈'s finiteness are the kernel's guards. forward_dynamics and
  // taylor_coefficients have no outputs or guards of their own; a derivative kernel's outputs are
  // the right-hand sides of its differentiated solve, nq + nc per direction, read at the
  // routine's q̈ (inputs qdd) and μ (inputs mu).
  bool looped = false;
  // The contact derivative kernels' rows form: outputs are the factors' nonzeros (row_solve's
  // `factors`), then the right-hand sides, direction after direction (rows each); the emitter
  // writes them into arrays and solves them by the steps.
  std::optional<RowSolve> row_solve = {};
  int frame = -1;  // a per_frame kernel's frame (its index in TracedModel::frames), else −1
  int contact_set = -1;  // a per_contact_set kernel's set (in TracedModel::contact_sets), else −1
  // A contact value kernel with ρ folded to 0 (<kernel>_<s>_exact): the exact KKT solve, one solve
  // of S = J M⁻¹ Jᵀ instead of contact_proximal_iterations, which the set's switch calls when
  // rho == 0 (the general kernel's result there up to rounding)
  bool exact = false;
  // Emitted in the order its statements can start (after their arguments' dependent steps, as
  // dependent_steps counts them), not in id order: for a kernel bound by its dependency chains
  // (the ABA's from_parent form on a long chain), whose passes id order writes one after the
  // other, so that the core overlaps them (lower(), eomgen/program.hpp).
  bool by_steps = false;
  int case_index() const { return frame >= 0 ? frame : contact_set; }

  // What the kernel computes: its outputs, then its guards (the roots of its cone).
  std::vector<NodeId> roots() const {
    std::vector<NodeId> r = outputs;
    r.insert(r.end(), guards.begin(), guards.end());
    return r;
  }
};

// Throws std::invalid_argument for a constraint kernel of a model without constraints, and for
// forward_dynamics_batch where the solve is looped (naming the model and the reason).
std::vector<Kernel> build_kernels(TracedModel& m, std::span<const KernelId> requested,
                                  SolveForm solve = SolveForm::automatic);

}  // namespace eom::gen
