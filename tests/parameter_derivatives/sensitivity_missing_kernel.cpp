// eom::Sensitivity<K, eom::with_parameters> over Kernels without forward_dynamics_parameter_derivatives
// (the bundled double_pendulum::Kernels: the kernel is generated only on request) must stop with
// eom::RequireKernels' one message naming it; CMakeLists.txt counts the errors. EOM_CASE 0 asks
// for Φ only, which needs no parameter kernel, and must compile cleanly.
#include <array>

#include <double_pendulum.hpp>

#include <eom/integration/integrate.hpp>
#include <eom/integration/sensitivity.hpp>

using K = double_pendulum::Kernels;
#if EOM_CASE == 0
using S = eom::Sensitivity<K>;
#else
using S = eom::Sensitivity<K, eom::with_parameters>;
#endif

int main() {
  const auto p = K::parameter_values;
  eom::IntegrationOptions opt;
  const auto r = eom::integrate<S>(0, 1, S::start({2.0, 2.5, 0.0, 0.0}), nullptr, p.data(), opt,
                                   [](double, const eom::StateOf<S::nq>&) {});
  return r.status == eom::Status::ok ? 0 : 1;
}
