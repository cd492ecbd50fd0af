// The kernel concept: what the runtime's templates (integrators, benchmarks, controllers) need of
// a model's equations of motion. eom::Reference<Model> and every generated `Kernels` struct
// satisfy it, so the same integrator runs over either.
#pragma once

#include <concepts>

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

}  // namespace eom
