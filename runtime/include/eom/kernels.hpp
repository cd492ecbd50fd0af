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

#include <concepts>
#include <type_traits>

namespace eom {

template <class K>
concept Dynamics = requires(double t, const double* x, double* y) {
  { K::nq } -> std::convertible_to<int>;
  { K::np } -> std::convertible_to<int>;
  { K::nu } -> std::convertible_to<int>;
  { K::nc } -> std::convertible_to<int>;
  { K::forward_dynamics(t, x, x, x, x, y) } -> std::same_as<bool>;
  { K::kinetic_energy(x, x, x) } -> std::convertible_to<double>;
  { K::potential_energy(x, x) } -> std::convertible_to<double>;
};

// ---- One concept per kernel of docs/CONTRACT.md §3, with the generated signature (double scalars) ----

template <class K>
concept HasSizes = requires {
  { K::nq } -> std::convertible_to<int>;
  { K::np } -> std::convertible_to<int>;
  { K::nu } -> std::convertible_to<int>;
  { K::nc } -> std::convertible_to<int>;
};
template <class K>
concept HasMassMatrix = requires(const double* x, double* y) {
  { K::mass_matrix(x, x, y) } -> std::same_as<void>;
};
template <class K>
concept HasMassMatrixDot = requires(const double* x, double* y) {
  { K::mass_matrix_dot(x, x, x, y) } -> std::same_as<void>;
};
template <class K>
concept HasCoriolis = requires(const double* x, double* y) {
  { K::coriolis(x, x, x, y) } -> std::same_as<void>;
};
template <class K>
concept HasPotentialGradient = requires(const double* x, double* y) {
  { K::potential_gradient(x, x, y) } -> std::same_as<void>;
};
template <class K>
concept HasGeneralizedForces = requires(double t, const double* x, double* y) {
  { K::generalized_forces(t, x, x, x, x, y) } -> std::same_as<void>;
};
template <class K>
concept HasConstraintResidual = requires(const double* x, double* y) {
  { K::constraint_residual(x, x, y) } -> std::same_as<void>;
};
template <class K>
concept HasConstraintJacobian = requires(const double* x, double* y) {
  { K::constraint_jacobian(x, x, y) } -> std::same_as<void>;
};
template <class K>
concept HasConstraintBias = requires(const double* x, double* y) {
  { K::constraint_bias(x, x, x, y) } -> std::same_as<void>;
};
template <class K>
concept HasForwardDynamics = requires(double t, const double* x, double* y) {
  { K::forward_dynamics(t, x, x, x, x, y) } -> std::same_as<bool>;
};
template <class K>
concept HasKineticEnergy = requires(const double* x) {
  { K::kinetic_energy(x, x, x) } -> std::convertible_to<double>;
};
template <class K>
concept HasPotentialEnergy = requires(const double* x) {
  { K::potential_energy(x, x) } -> std::convertible_to<double>;
};
template <class K>
concept HasForwardDynamicsDerivatives = requires(double t, const double* x, double* y) {
  { K::forward_dynamics_derivatives(t, x, x, x, x, y, y, y) } -> std::same_as<bool>;
};
template <class K>
concept HasForwardDynamicsParameterDerivatives = requires(double t, const double* x, double* y) {
  { K::forward_dynamics_parameter_derivatives(t, x, x, x, x, y) } -> std::same_as<bool>;
};
// forward_dynamics for K::batch_lanes states at once (on request: KERNELS ...
// forward_dynamics_batch).
// Structure-of-arrays lanes: entry i of lane l at x[i * batch_lanes + l] for t (batch_lanes
// values), q, qd, u, p and qdd. Returns the mask of lanes that succeeded (bit l); a failed lane
// gets NaN in its qdd, as forward_dynamics (docs/CONTRACT.md §3).
template <class K>
concept HasForwardDynamicsBatch = requires(const double* x, double* y) {
  { K::batch_lanes } -> std::convertible_to<int>;
  { K::forward_dynamics_batch(x, x, x, x, x, y) } -> std::same_as<unsigned>;
};
// The lanes of K's batch kernel, 0 when it has none.
template <class K>
inline constexpr int batch_lanes = [] {
  if constexpr (HasForwardDynamicsBatch<K>) return static_cast<int>(K::batch_lanes);
  else return 0;
}();
template <class K>
concept HasInverseDynamics = requires(double t, const double* x, double* y) {
  { K::inverse_dynamics(t, x, x, x, x, x, y) } -> std::same_as<void>;
};

// The kernels by name (the names add_eom_model's KERNELS takes).
enum class Kernel {
  mass_matrix,
  mass_matrix_dot,
  coriolis,
  potential_gradient,
  generalized_forces,
  constraint_residual,
  constraint_jacobian,
  constraint_bias,
  forward_dynamics,
  kinetic_energy,
  potential_energy,
  forward_dynamics_derivatives,
  inverse_dynamics,
  forward_dynamics_parameter_derivatives,  // generated only when KERNELS names it
  forward_dynamics_batch,                  // generated only when KERNELS names it
};

template <class K, Kernel k>
inline constexpr bool has_kernel = [] {
  using enum Kernel;
  if constexpr (k == mass_matrix) return HasMassMatrix<K>;
  else if constexpr (k == mass_matrix_dot) return HasMassMatrixDot<K>;
  else if constexpr (k == coriolis) return HasCoriolis<K>;
  else if constexpr (k == potential_gradient) return HasPotentialGradient<K>;
  else if constexpr (k == generalized_forces) return HasGeneralizedForces<K>;
  else if constexpr (k == constraint_residual) return HasConstraintResidual<K>;
  else if constexpr (k == constraint_jacobian) return HasConstraintJacobian<K>;
  else if constexpr (k == constraint_bias) return HasConstraintBias<K>;
  else if constexpr (k == forward_dynamics) return HasForwardDynamics<K>;
  else if constexpr (k == kinetic_energy) return HasKineticEnergy<K>;
  else if constexpr (k == potential_energy) return HasPotentialEnergy<K>;
  else if constexpr (k == forward_dynamics_derivatives) return HasForwardDynamicsDerivatives<K>;
  else if constexpr (k == inverse_dynamics) return HasInverseDynamics<K>;
  else if constexpr (k == forward_dynamics_parameter_derivatives)
    return HasForwardDynamicsParameterDerivatives<K>;
  else return HasForwardDynamicsBatch<K>;
}();

namespace detail {

// One static_assert per kernel, since a message must be a string literal. Each names the kernel
// and the fix; only the branch of the kernel asked for is instantiated.
template <class K, Kernel k> constexpr bool require_kernel() {
  using enum Kernel;
  if constexpr (k == mass_matrix)
    static_assert(has_kernel<K, mass_matrix>,
                  "eom::RequireKernels: needs the kernel `mass_matrix`, which this "
                  "Kernels type lacks: add mass_matrix to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == mass_matrix_dot)
    static_assert(has_kernel<K, mass_matrix_dot>,
                  "eom::RequireKernels: needs the kernel `mass_matrix_dot`, which this "
                  "Kernels type lacks: add mass_matrix_dot to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == coriolis)
    static_assert(has_kernel<K, coriolis>,
                  "eom::RequireKernels: needs the kernel `coriolis`, which this "
                  "Kernels type lacks: add coriolis to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == potential_gradient)
    static_assert(has_kernel<K, potential_gradient>,
                  "eom::RequireKernels: needs the kernel `potential_gradient`, which this "
                  "Kernels type lacks: add potential_gradient to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == generalized_forces)
    static_assert(has_kernel<K, generalized_forces>,
                  "eom::RequireKernels: needs the kernel `generalized_forces`, which this "
                  "Kernels type lacks: add generalized_forces to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == constraint_residual)
    static_assert(has_kernel<K, constraint_residual>,
                  "eom::RequireKernels: needs the kernel `constraint_residual`, which this "
                  "Kernels type lacks: add constraint_residual to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == constraint_jacobian)
    static_assert(has_kernel<K, constraint_jacobian>,
                  "eom::RequireKernels: needs the kernel `constraint_jacobian`, which this "
                  "Kernels type lacks: add constraint_jacobian to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == constraint_bias)
    static_assert(has_kernel<K, constraint_bias>,
                  "eom::RequireKernels: needs the kernel `constraint_bias`, which this "
                  "Kernels type lacks: add constraint_bias to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == forward_dynamics)
    static_assert(has_kernel<K, forward_dynamics>,
                  "eom::RequireKernels: needs the kernel `forward_dynamics`, which this "
                  "Kernels type lacks: add forward_dynamics to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == kinetic_energy)
    static_assert(has_kernel<K, kinetic_energy>,
                  "eom::RequireKernels: needs the kernel `kinetic_energy`, which this "
                  "Kernels type lacks: add kinetic_energy to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == potential_energy)
    static_assert(has_kernel<K, potential_energy>,
                  "eom::RequireKernels: needs the kernel `potential_energy`, which this "
                  "Kernels type lacks: add potential_energy to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == forward_dynamics_derivatives)
    static_assert(has_kernel<K, forward_dynamics_derivatives>,
                  "eom::RequireKernels: needs the kernel `forward_dynamics_derivatives`, which "
                  "this Kernels type lacks: add forward_dynamics_derivatives to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == inverse_dynamics)
    static_assert(has_kernel<K, inverse_dynamics>,
                  "eom::RequireKernels: needs the kernel `inverse_dynamics`, which this "
                  "Kernels type lacks: add inverse_dynamics to KERNELS "
                  "in add_eom_model() (or leave KERNELS out to generate every kernel)");
  else if constexpr (k == forward_dynamics_parameter_derivatives)
    static_assert(has_kernel<K, forward_dynamics_parameter_derivatives>,
                  "eom::RequireKernels: needs the kernel `forward_dynamics_parameter_derivatives`, "
                  "which this Kernels type lacks: add forward_dynamics_parameter_derivatives to "
                  "KERNELS in add_eom_model() (it is never generated by default)");
  else if constexpr (k == forward_dynamics_batch)
    static_assert(has_kernel<K, forward_dynamics_batch>,
                  "eom::RequireKernels: needs the kernel `forward_dynamics_batch`, which this "
                  "Kernels type lacks: add forward_dynamics_batch to KERNELS in add_eom_model() "
                  "(e.g. KERNELS defaults forward_dynamics_batch; it is never generated by "
                  "default)");
  return has_kernel<K, k>;
}

// What the requiring code sees once a kernel is missing (the build has already failed): K with
// every kernel declared, so that its calls compile and the static_assert stays the only error.
// Never defined: nothing can link against it.
template <class K> struct MissingKernelStandIn : K {
  static void mass_matrix(const double*, const double*, double*) noexcept;
  static void mass_matrix_dot(const double*, const double*, const double*, double*) noexcept;
  static void coriolis(const double*, const double*, const double*, double*) noexcept;
  static void potential_gradient(const double*, const double*, double*) noexcept;
  static void generalized_forces(double, const double*, const double*, const double*,
                                 const double*, double*) noexcept;
  static void constraint_residual(const double*, const double*, double*) noexcept;
  static void constraint_jacobian(const double*, const double*, double*) noexcept;
  static void constraint_bias(const double*, const double*, const double*, double*) noexcept;
  static bool forward_dynamics(double, const double*, const double*, const double*,
                               const double*, double*) noexcept;
  static double kinetic_energy(const double*, const double*, const double*) noexcept;
  static double potential_energy(const double*, const double*) noexcept;
  static bool forward_dynamics_derivatives(double, const double*, const double*, const double*,
                                           const double*, double*, double*, double*) noexcept;
  static void inverse_dynamics(double, const double*, const double*, const double*,
                               const double*, const double*, double*) noexcept;
  static bool forward_dynamics_parameter_derivatives(double, const double*, const double*,
                                                     const double*, const double*,
                                                     double*) noexcept;
  static constexpr int batch_lanes = 4;
  static unsigned forward_dynamics_batch(const double*, const double*, const double*,
                                         const double*, const double*, double*) noexcept;
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

// What the implicit and sensitivity methods need (eom/radau5.hpp, eom/sensitivity.hpp): the
// dynamics and their exact derivatives ∂q̈/∂(q, q̇, u).
template <class K>
concept DifferentiableDynamics = Dynamics<K> && requires(double t, const double* x, double* y) {
  { K::forward_dynamics_derivatives(t, x, x, x, x, y, y, y) } -> std::same_as<bool>;
};

}  // namespace eom
