// Controllers given a Kernels type without a kernel they need, one per EOM_CASE; each must stop
// with eom::RequireKernels' message naming the kernel and nothing else (CMakeLists.txt counts
// the errors). EOM_CASE 0 uses complete Kernels and must compile cleanly, so the harness itself
// is known to work. The Kernels come from add_eom_model() with restricted KERNELS lists.
#include <array>
#include <type_traits>

#include <example_arm3.hpp>
#include <example_arm3_no_mass_matrix.hpp>
#include <example_cart_pole.hpp>
#include <example_cart_pole_no_derivatives.hpp>

#include <eom/model/kernels.hpp>
#include <eom/reference/reference.hpp>

#include "arm3.hpp"  // the model, for eom::Reference

#include "computed_torque.hpp"  // examples/computed_torque
#include "lqr.hpp"              // examples/lqr_cartpole

// Evaluates a computed torque and a linearization with the given Kernels types.
template <class Arm, class CartPole> void use() {
  const examples::ComputedTorque<Arm> controller(
      examples::ComputedTorque<Arm>::critically_damped(10.0), Arm::parameter_values);
  const std::array<double, 3> q{}, qd{};
  double tau[3];
  controller.torque(q.data(), qd.data(), {}, tau);

  const std::array<double, 2> q0{}, u0{};
  examples::lqr::Linearization<2, 1> lin;
  examples::lqr::linearize<CartPole>(q0.data(), q0.data(), u0.data(),
                                     CartPole::parameter_values.data(), lin);
}

int main() {
#if EOM_CASE == 0
  // The per-kernel concepts see what KERNELS generated.
  static_assert(eom::HasMassMatrix<example_arm3::Kernels> &&
                !eom::HasMassMatrix<example_arm3_no_mass_matrix::Kernels>);
  static_assert(eom::HasCoriolis<example_arm3_no_mass_matrix::Kernels> &&
                eom::HasPotentialGradient<example_arm3_no_mass_matrix::Kernels>);
  static_assert(eom::HasForwardDynamicsDerivatives<example_cart_pole::Kernels> &&
                !eom::HasForwardDynamicsDerivatives<example_cart_pole_no_derivatives::Kernels>);
  static_assert(eom::HasInverseDynamics<example_arm3::Kernels> &&
                !eom::HasConstraintJacobian<example_arm3::Kernels>);  // no constraints
  // The run-time reference offers every kernel of an unconstrained model.
  using Ref = eom::Reference<examples::Arm3>;
  static_assert(eom::HasMassMatrix<Ref> && eom::HasMassMatrixDot<Ref> && eom::HasCoriolis<Ref> &&
                eom::HasPotentialGradient<Ref> && eom::HasGeneralizedForces<Ref> &&
                eom::HasForwardDynamics<Ref> && eom::HasKineticEnergy<Ref> &&
                eom::HasPotentialEnergy<Ref> && eom::HasForwardDynamicsDerivatives<Ref> &&
                eom::HasInverseDynamics<Ref> && !eom::HasConstraintResidual<Ref>);
  // A complete type passes through unchanged.
  static_assert(std::is_same_v<eom::RequireKernels<example_arm3::Kernels, eom::Kernel::mass_matrix>,
                               example_arm3::Kernels>);
  use<example_arm3::Kernels, example_cart_pole::Kernels>();
#elif EOM_CASE == 1
  use<example_arm3_no_mass_matrix::Kernels, example_cart_pole::Kernels>();  // computed torque
#elif EOM_CASE == 2
  use<example_arm3::Kernels, example_cart_pole_no_derivatives::Kernels>();  // LQR design
#elif EOM_CASE == 3
  // Every missing kernel is named at once; the one present (coriolis) is not.
  using K = eom::RequireKernels<example_arm3_no_mass_matrix::Kernels, eom::Kernel::mass_matrix,
                                eom::Kernel::coriolis, eom::Kernel::mass_matrix_dot,
                                eom::Kernel::inverse_dynamics>;
  double M[9];
  K::mass_matrix(nullptr, nullptr, M);
#endif
  return 0;
}
