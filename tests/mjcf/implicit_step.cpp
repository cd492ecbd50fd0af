// Compiled by ctest, syntax only (tests/mjcf/CMakeLists.txt): eom::contact_step stops the build,
// naming the integrator, for a header that states MuJoCo's implicit integrator (one not written
// by eomgen-mjcf, which refuses it). EOM_CASE 0 states RK4 and must compile.
#include <span>

#include <mjcf_rk4.hpp>
#include <mjcf_rk4_model.hpp>

#include <eom/contact/step.hpp>

using K = mjcf_rk4::Kernels;

struct Stated : eom::mjcf_models::mjcf_rk4 {
  static constexpr eom::SolverOptions solver_options{.timestep = 0.004,
                                                     .integrator = EOM_CASE == 0 ? 1 : 2};
};

eom::StepStatus step(eom::ContactStepper<K, Stated>& s, double& t, std::span<double, K::nq> q,
                     std::span<double, K::nv> v) {
  return eom::contact_step<K, Stated>(s, t, q, v, nullptr, K::parameter_values.data());
}
