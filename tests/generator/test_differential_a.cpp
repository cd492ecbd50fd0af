// Random Lagrangians, small shapes (see differential.hpp for the checks and the norms).
#include "differential.hpp"

namespace eomtest {
namespace {

constexpr unsigned cases = 25;  // per shape: 250 random Lagrangians over both files

TEST(RandomLagrangians, OneCoordinate) { run_shape<RandomModel<1, 0, 0, false>>(1000, cases); }
TEST(RandomLagrangians, TwoWithInputAndForces) { run_shape<RandomModel<2, 0, 1, true>>(2000, cases); }
TEST(RandomLagrangians, TwoWithConstraint) { run_shape<RandomModel<2, 1, 0, false>>(3000, cases); }
TEST(RandomLagrangians, ThreeWithForces) { run_shape<RandomModel<3, 0, 0, true>>(4000, cases); }
TEST(RandomLagrangians, ThreeWithEverything) { run_shape<RandomModel<3, 1, 1, true>>(5000, cases); }

}  // namespace
}  // namespace eomtest
