// Compile-fail case (ctest radau5.needs_jacobian): radau5 over kernels without
// forward_dynamics_derivatives must stop the build with radau5's own message.
#include <eom/integration/radau5.hpp>

struct WithoutJacobian {
  static constexpr int nq = 1, np = 0, nu = 0, nc = 0;
  static bool forward_dynamics(double, const double*, const double*, const double*, const double*,
                               double* qdd) noexcept {
    qdd[0] = 0;
    return true;
  }
  static double kinetic_energy(const double*, const double*, const double*) noexcept { return 0; }
  static double potential_energy(const double*, const double*) noexcept { return 0; }
};

int main() {
  const eom::StateOf<1> x{};
  return eom::radau5<WithoutJacobian>(0, 1, x, nullptr, nullptr, eom::AdaptiveOptions{},
                                      [](double, const auto&) {})
                 .status == eom::Status::ok
             ? 0
             : 1;
}
