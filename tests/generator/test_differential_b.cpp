// Random Lagrangians, larger shapes (see differential.hpp for the checks and the norms).
#include "differential.hpp"

namespace eomtest {
namespace {

constexpr unsigned cases = 25;  // per shape: 250 random Lagrangians over both files

TEST(RandomLagrangiansLarge, FourWithTwoConstraints) { run_shape<RandomModel<4, 2, 0, false>>(6000, cases); }
TEST(RandomLagrangiansLarge, FourWithInputs) { run_shape<RandomModel<4, 0, 2, true>>(7000, cases); }
TEST(RandomLagrangiansLarge, FiveWithEverything) { run_shape<RandomModel<5, 2, 1, true>>(8000, cases); }
TEST(RandomLagrangiansLarge, SixWithForces) { run_shape<RandomModel<6, 0, 1, true>>(9000, cases); }
TEST(RandomLagrangiansLarge, SixWithConstraints) { run_shape<RandomModel<6, 2, 0, false>>(10000, cases); }

}  // namespace
}  // namespace eomtest
