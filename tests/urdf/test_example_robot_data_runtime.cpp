// Optional (cmake -DEOM_EXAMPLE_ROBOT_DATA=<a checkout of Gepetto/example-robot-data>): the
// published robots of robots/published/README.md that are neither bundled nor Talos
// (test_example_robot_data.cpp), read with the inertia policy each needs, their root fixed or freed
// as the README's table says, written as model headers by eomgen-urdf at build time and checked on
// the runtime's paths (eom::Reference, eom/multibody/tree.hpp) against the recursive algorithms in dd_real
// (tests/support/runtime_check.hpp, as test_published.cpp; Baxter's two mimic joints by the map of
// tests/support/mimic_map.hpp). Worst relative errors measured: robots/published/README.md.
#include <gtest/gtest.h>

#include <string>

#include <a1_model.hpp>
#include <anymal_c_model.hpp>
#include <baxter_model.hpp>
#include <icub_model.hpp>
#include <kinova_model.hpp>
#include <runtime_check.hpp>
#include <tiago_model.hpp>

namespace {

using eom::urdf::InertiaPolicy;

template <class Model>
void check(const char* name, const char* file, InertiaPolicy policy, bool free_root) {
  eomtest::expect_runtime_agrees<Model>(name, std::string(EOM_ERD_ROBOTS) + "/" + file,
                                        {.free_root = free_root, .inertia = policy});
}

TEST(ExampleRobotData, AnymalCFreedWithInertiasAsPublished) {
  check<eom::published::anymal_c>("ANYmal C", "anymal_c_simple_description/urdf/anymal.urdf", InertiaPolicy::warn, true);
}
TEST(ExampleRobotData, TiagoFixedWithInertiasAsPublished) {
  check<eom::published::tiago>("Tiago (no hand)", "tiago_description/robots/tiago_no_hand.urdf", InertiaPolicy::warn,
                               false);
}
TEST(ExampleRobotData, IcubReducedFreedWithInertiasAsPublished) {
  check<eom::published::icub>("iCub reduced", "icub_description/robots/icub_reduced.urdf", InertiaPolicy::warn, true);
}
TEST(ExampleRobotData, A1Freed) {
  check<eom::published::a1>("A1", "a1_description/urdf/a1.urdf", InertiaPolicy::error, true);
}
TEST(ExampleRobotData, KinovaFixed) {
  check<eom::published::kinova>("Kinova", "kinova_description/robots/kinova.urdf", InertiaPolicy::error, false);
}
TEST(ExampleRobotData, BaxterFixedWithMimicJoints) {
  check<eom::published::baxter>("Baxter (2 mimic joints)", "baxter_description/urdf/baxter.urdf", InertiaPolicy::error,
                                false);
}

}  // namespace
