// Published robot descriptions (robots/published, README there: sources and licenses), read with
// the inertia policy each needs, their root freed (FLOATING_BASE: they walk), and written as model
// headers by eomgen-urdf at build time. Generating every kernel of a 12–31-joint floating robot
// takes longer than the suite's budget, so they are checked on the runtime's paths, which are the
// generator's inputs: eom::Reference (the Lagrangian route by AD, double) for M, c + ∂V/∂q and v̇,
// and the tree algorithms of eom/multibody/tree.hpp (traced for inverse and forward dynamics) — against
// the recursive algorithms of tests/support/recursive_dynamics.hpp in dd_real on the same file
// (tests/support/runtime_check.hpp; test_example_robot_data_runtime.cpp does the same for the
// robots of example-robot-data that are not bundled).
#include <gtest/gtest.h>

#include <string>

#include <go1_model.hpp>
#include <hyq_model.hpp>
#include <romeo_model.hpp>
#include <runtime_check.hpp>

namespace {

using eom::urdf::InertiaPolicy;

template <class Model>
void check(const char* name, const char* file, InertiaPolicy policy) {
  eomtest::expect_runtime_agrees<Model>(name, std::string(EOM_PUBLISHED_DIR) + "/" + file,
                                        {.free_root = true, .inertia = policy});
}

// Measured (20 states, worst relative error of all seven checks): HyQ 1.9e-15, Go1 2.4e-15, Romeo
// 1.5e-14, each from the Reference's forward dynamics.
TEST(UrdfPublished, HyqWithNearestInertias) {
  check<eom::published::hyq>("HyQ", "hyq_no_sensors.urdf", InertiaPolicy::nearest);
}
TEST(UrdfPublished, Go1WithNearestInertias) {
  check<eom::published::go1>("Go1", "go1.urdf", InertiaPolicy::nearest);
}
TEST(UrdfPublished, RomeoWithInertiasAsPublished) {
  check<eom::published::romeo>("Romeo small", "romeo_small.urdf", InertiaPolicy::warn);
}

}  // namespace
