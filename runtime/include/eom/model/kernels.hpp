// The kernel concept: what the runtime's templates (integrators, benchmarks, controllers) need of
// a model's equations of motion. eom::Reference<Model> and every generated `Kernels` struct
// satisfy it, so the same integrator runs over either.
//
// add_eom_model(... KERNELS ...) may generate only some kernels, so a template that needs more
// than Dynamics says which ones, either as a constraint (`requires eom::HasMassMatrix<K>`) or,
// for the clearest error, through eom::RequireKernels:
//
//   template <class Model> class ComputedTorque {
//     using K = eom::RequireKernels<Model, eom::Kernel::mass_matrix, eom::Kernel::coriolis>;
//     ...   // use K::mass_matrix, K::coriolis
//   };
//
// A Kernels type without mass_matrix then stops the build with one message per missing kernel
// ("eom::RequireKernels: needs the kernel `mass_matrix`, ... add mass_matrix to KERNELS in
// add_eom_model() ...") and nothing else: no cascade from the code that calls it, no link error.
#pragma once

#include <array>
#include <concepts>
#include <type_traits>

#include "eom/model/free_joint.hpp"

namespace eom {

// The kernel catalog: one row per kernel of docs/CONTRACT.md §3, in the generator's order (its
// KernelId, eomgen/kernels.hpp; a generator test checks the two agree). A row is
//   X(name, Concept, result, (parameters), (call arguments), (further members K needs), when)
// with `when` default (generated unless KERNELS leaves it out), on_request (only when KERNELS
// names it), with_frames (generated when FRAMES names a frame: one case per frame, f) or
// with_contacts (generated when CONTACTS names a contact set: one case per set, s). Everything
// below is made from it: the concepts HasConcept<K>, the Kernel enum,
// has_kernel, and RequireKernels' messages and stand-ins. A new kernel is one row.
#define EOM_KERNEL_CATALOG(X)                                                                      \
  X(mass_matrix, MassMatrix, void, (const double* q, const double* p, double* M), (q, p, M), (),   \
    default)                                                                                       \
  X(mass_matrix_dot, MassMatrixDot, void,                                                          \
    (const double* q, const double* qd, const double* p, double* Mdot), (q, qd, p, Mdot), (),      \
    default)                                                                                       \
  X(coriolis, Coriolis, void, (const double* q, const double* qd, const double* p, double* c),     \
    (q, qd, p, c), (), default)                                                                    \
  X(potential_gradient, PotentialGradient, void, (const double* q, const double* p, double* dVdq), \
    (q, p, dVdq), (), default)                                                                     \
  X(generalized_forces, GeneralizedForces, void,                                                   \
    (double t, const double* q, const double* qd, const double* u, const double* p, double* Q),    \
    (t, q, qd, u, p, Q), (), default)                                                              \
  X(constraint_residual, ConstraintResidual, void, (const double* q, const double* p, double* phi), \
    (q, p, phi), (), default)                                                                      \
  X(constraint_jacobian, ConstraintJacobian, void, (const double* q, const double* p, double* C),  \
    (q, p, C), (), default)                                                                        \
  X(constraint_bias, ConstraintBias, void,                                                         \
    (const double* q, const double* qd, const double* p, double* gamma), (q, qd, p, gamma), (),    \
    default)                                                                                       \
  X(forward_dynamics, ForwardDynamics, bool,                                                       \
    (double t, const double* q, const double* qd, const double* u, const double* p, double* qdd),  \
    (t, q, qd, u, p, qdd), (), default)                                                            \
  X(kinetic_energy, KineticEnergy, double, (const double* q, const double* qd, const double* p),   \
    (q, qd, p), (), default)                                                                       \
  X(potential_energy, PotentialEnergy, double, (const double* q, const double* p), (q, p), (),     \
    default)                                                                                       \
  X(forward_dynamics_derivatives, ForwardDynamicsDerivatives, bool,                                \
    (double t, const double* q, const double* qd, const double* u, const double* p,                \
     double* dqdd_dq, double* dqdd_dqd, double* dqdd_du),                                          \
    (t, q, qd, u, p, dqdd_dq, dqdd_dqd, dqdd_du), (), default)                                     \
  X(inverse_dynamics, InverseDynamics, void,                                                       \
    (double t, const double* q, const double* qd, const double* qdd, const double* u,              \
     const double* p, double* tau),                                                                \
    (t, q, qd, qdd, u, p, tau), (), default)                                                       \
  X(taylor_coefficients, TaylorCoefficients, bool,                                                 \
    (int order, double t, const double* q, const double* qd, const double* u, const double* p,     \
     double* qk, double* qdk, double* work),                                                       \
    (order, t, q, qd, u, p, qk, qdk, work), (K::taylor_max_order; K::taylor_workspace;), default)  \
  X(forward_dynamics_parameter_derivatives, ForwardDynamicsParameterDerivatives, bool,             \
    (double t, const double* q, const double* qd, const double* u, const double* p,                \
     double* dqdd_dp),                                                                             \
    (t, q, qd, u, p, dqdd_dp), (), on_request)                                                     \
  X(forward_dynamics_batch, ForwardDynamicsBatch, unsigned,                                        \
    (const double* t, const double* q, const double* qd, const double* u, const double* p,         \
     double* qdd),                                                                                 \
    (t, q, qd, u, p, qdd), (K::batch_lanes;), on_request)                                          \
  X(frame_placement, FramePlacement, void,                                                         \
    (int f, const double* q, const double* p, double* position, double* rotation),                 \
    (f, q, p, position, rotation), (K::nframes;), with_frames)                                     \
  X(frame_jacobian, FrameJacobian, void, (int f, const double* q, const double* p, double* J),     \
    (f, q, p, J), (K::nframes;), with_frames)                                                      \
  X(frame_acceleration_bias, FrameAccelerationBias, void,                                          \
    (int f, const double* q, const double* qd, const double* p, double* a), (f, q, qd, p, a),      \
    (K::nframes;), with_frames)                                                                    \
  X(center_of_mass, CenterOfMass, void, (const double* q, const double* p, double* com),           \
    (q, p, com), (), on_request)                                                                   \
  X(center_of_mass_jacobian, CenterOfMassJacobian, void,                                           \
    (const double* q, const double* p, double* J), (q, p, J), (), on_request)                      \
  X(centroidal_momentum_matrix, CentroidalMomentumMatrix, void,                                    \
    (const double* q, const double* p, double* A), (q, p, A), (), on_request)                      \
  X(inverse_dynamics_derivatives, InverseDynamicsDerivatives, void,                                \
    (double t, const double* q, const double* qd, const double* qdd, const double* u,              \
     const double* p, double* dtau_dq, double* dtau_dqd),                                          \
    (t, q, qd, qdd, u, p, dtau_dq, dtau_dqd), (), on_request)                                     \
  X(contact_dynamics, ContactDynamics, bool,                                                       \
    (int s, double t, const double* q, const double* qd, const double* u, const double* p,         \
     double kd, double rho, double* vdot, double* lambda),                                         \
    (s, t, q, qd, u, p, kd, rho, vdot, lambda), (K::ncontact_sets; K::contact_rows;), with_contacts) \
  X(impulse_dynamics, ImpulseDynamics, bool,                                                       \
    (int s, const double* q, const double* qd, const double* p, double restitution, double rho,    \
     double* v_plus, double* impulse),                                                             \
    (s, q, qd, p, restitution, rho, v_plus, impulse), (K::ncontact_sets; K::contact_rows;),        \
    with_contacts)                                                                                 \
  X(contact_dynamics_derivatives, ContactDynamicsDerivatives, bool,                                \
    (int s, double t, const double* q, const double* qd, const double* u, const double* p,         \
     double kd, double rho, double* dvdot_dq, double* dvdot_dqd, double* dvdot_du,                 \
     double* dlambda_dq, double* dlambda_dqd, double* dlambda_du),                                 \
    (s, t, q, qd, u, p, kd, rho, dvdot_dq, dvdot_dqd, dvdot_du, dlambda_dq, dlambda_dqd,           \
     dlambda_du), (K::ncontact_sets; K::contact_rows;), with_contacts)                             \
  X(impulse_dynamics_derivatives, ImpulseDynamicsDerivatives, bool,                                \
    (int s, const double* q, const double* qd, const double* p, double restitution, double rho,    \
     double* dvplus_dq, double* dvplus_dqd, double* dimpulse_dq, double* dimpulse_dqd),            \
    (s, q, qd, p, restitution, rho, dvplus_dq, dvplus_dqd, dimpulse_dq, dimpulse_dqd),             \
    (K::ncontact_sets; K::contact_rows;), with_contacts)

#define EOM_KERNEL_UNPAREN(...) __VA_ARGS__

namespace detail {
// A kernel's result: exactly void, bool or unsigned; a value convertible to double (the
// reference's energies may be another real type's).
template <class R, class Result>
concept KernelReturns =
    (std::same_as<Result, double> && std::convertible_to<R, double>) || std::same_as<R, Result>;
}  // namespace detail

// ---- One concept per kernel, HasMassMatrix<K> ... (the generated signature, double scalars) ----

#define EOM_KERNEL_CONCEPT(name, Concept, result, parameters, arguments, members, when)           \
  template <class K>                                                                               \
  concept Has##Concept = requires parameters {                                                     \
    { K::name arguments } -> detail::KernelReturns<result>;                                        \
    EOM_KERNEL_UNPAREN members                                                                            \
  };
EOM_KERNEL_CATALOG(EOM_KERNEL_CONCEPT)
#undef EOM_KERNEL_CONCEPT

template <class K>
concept HasSizes = requires {
  { K::nq } -> std::convertible_to<int>;
  { K::np } -> std::convertible_to<int>;
  { K::nu } -> std::convertible_to<int>;
  { K::nc } -> std::convertible_to<int>;
};

// K's velocity count: K::nv (nq − 1 with a free joint, eom/model/free_joint.hpp), or K::nq for a
// Kernels type that does not state it (then v = q̇).
template <class K>
inline constexpr int nv_of = [] {
  if constexpr (requires { K::nv; }) return static_cast<int>(K::nv);
  else return static_cast<int>(K::nq);
}();

// Where K's unit quaternions are (eom/model/free_joint.hpp): K::quaternions where K states
// them (a model with ball joints), else none or the free joint's (Layout(nq, nv)).
template <class K> constexpr Layout layout_of() {
  if constexpr (requires { K::quaternions; })
    return Layout(static_cast<int>(K::nq), nv_of<K>, K::quaternions.data());
  else
    return Layout(static_cast<int>(K::nq), nv_of<K>);
}

// What every integrator needs.
template <class K>
concept Dynamics = HasSizes<K> && HasForwardDynamics<K> && HasKineticEnergy<K> && HasPotentialEnergy<K>;

// The lanes of K's batch kernel (forward_dynamics for K::batch_lanes states at once, structure of
// arrays: entry i of lane l at x[i * batch_lanes + l], q of nq rows, qd and qdd of nv; the result is the mask of lanes that
// succeeded, a failed lane's qdd NaN), 0 when it has none.
template <class K>
inline constexpr int batch_lanes = [] {
  if constexpr (HasForwardDynamicsBatch<K>) return static_cast<int>(K::batch_lanes);
  else return 0;
}();

// The kernels by name (the names add_eom_model's KERNELS takes).
enum class Kernel {
#define EOM_KERNEL_ENUM(name, ...) name,
  EOM_KERNEL_CATALOG(EOM_KERNEL_ENUM)
#undef EOM_KERNEL_ENUM
};

template <class K, Kernel k>
inline constexpr bool has_kernel = [] {
#define EOM_KERNEL_HAS(name, Concept, ...) \
  if constexpr (k == Kernel::name) return Has##Concept<K>;
  EOM_KERNEL_CATALOG(EOM_KERNEL_HAS)
#undef EOM_KERNEL_HAS
  return false;
}();

namespace detail {

#define EOM_KERNEL_WHEN_default "(or leave KERNELS out to generate every kernel)"
#define EOM_KERNEL_WHEN_on_request "(it is never generated by default)"
#define EOM_KERNEL_WHEN_with_frames "(and name its frames in FRAMES)"
#define EOM_KERNEL_WHEN_with_contacts "(and name its contact sets in CONTACTS)"

// One static_assert per kernel, since a message must be a string literal. Each names the kernel
// and the fix; only the branch of the kernel asked for is instantiated.
template <class K, Kernel k> constexpr bool require_kernel() {
#define EOM_KERNEL_REQUIRE(name, Concept, result, parameters, arguments, members, when)           \
  if constexpr (k == Kernel::name)                                                                 \
    static_assert(has_kernel<K, Kernel::name>,                                                     \
                  "eom::RequireKernels: needs the kernel `" #name "`, which this Kernels type "    \
                  "lacks: add " #name " to KERNELS in add_eom_model() " EOM_KERNEL_WHEN_##when);
  EOM_KERNEL_CATALOG(EOM_KERNEL_REQUIRE)
#undef EOM_KERNEL_REQUIRE
  return has_kernel<K, k>;
}

#undef EOM_KERNEL_WHEN_default
#undef EOM_KERNEL_WHEN_on_request
#undef EOM_KERNEL_WHEN_with_frames
#undef EOM_KERNEL_WHEN_with_contacts

// What the requiring code sees once a kernel is missing (the build has already failed): K with
// every kernel declared, so that its calls compile and the static_assert stays the only error.
// Never defined: nothing can link against it.
template <class K> struct MissingKernelStandIn : K {
#define EOM_KERNEL_STAND_IN(name, Concept, result, parameters, ...) \
  static result name parameters noexcept;
  EOM_KERNEL_CATALOG(EOM_KERNEL_STAND_IN)
#undef EOM_KERNEL_STAND_IN
  static constexpr int taylor_max_order = 1, taylor_workspace = 0, batch_lanes = 1, nframes = 1,
                       ncontact_sets = 1;
  static constexpr std::array<int, 1> contact_rows{3};
};

template <class K, Kernel... ks> struct RequireKernels {
  static_assert(HasSizes<K>, "eom::RequireKernels: the type given is not a Kernels type (no "
                             "nq, np, nu, nc); pass <model>::Kernels or eom::Reference<Model>");
  // `&`, not `&&`: every kernel is checked, so all the missing ones are named at once.
  static constexpr bool complete = (true & ... & require_kernel<K, ks>());
  using type = std::conditional_t<complete, K, MissingKernelStandIn<K>>;
};

}  // namespace detail

// K itself when it offers every kernel in ks; otherwise the build stops with one message per
// missing kernel, naming it and the fix (see the top of this file).
template <class K, Kernel... ks>
using RequireKernels = typename detail::RequireKernels<K, ks...>::type;

// What the implicit and sensitivity methods need (eom/integration/radau5.hpp, eom/integration/sensitivity.hpp): the
// dynamics and their exact derivatives ∂q̈/∂(q, q̇, u).
template <class K>
concept DifferentiableDynamics = Dynamics<K> && requires(double t, const double* x, double* y) {
  { K::forward_dynamics_derivatives(t, x, x, x, x, y, y, y) } -> std::same_as<bool>;
};

}  // namespace eom
