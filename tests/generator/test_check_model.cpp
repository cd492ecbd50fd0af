// The tracer's check of a model at its generic point (eomgen/tracer.hpp check_model): a kinetic
// energy that is not positive definite stops generation, naming the coordinate of the failing
// pivot and whether M is indefinite or singular.
#include <gtest/gtest.h>

#include <string>

#include <eomgen/tracer.hpp>
#include <models/chain.hpp>
#include <models/spring_pendulum.hpp>

#include "not_positive_definite.hpp"  // tests/consumer/bad

namespace {

template <class Model> std::string check_error() {
  try {
    eom::gen::check_model<Model>({});
  } catch (const eom::gen::TracerError& e) {
    return e.what();
  }
  return "no error";
}

TEST(CheckModel, IndefiniteKineticEnergyNamesTheCoordinate) {
  const std::string e = check_error<SignError>();
  // M = [[2, c], [c, −1]] at the defaults: the second pivot −1 − c²/2 is negative.
  EXPECT_NE(e.find("kinetic energy is not positive definite: M's pivot for coordinate 'theta2' "
                   "(velocity 1) is -1."),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("negative: M is indefinite"), std::string::npos) << e;
  EXPECT_NE(e.find("kinetic_energy()"), std::string::npos) << e;
}

TEST(CheckModel, SingularKineticEnergyNamesTheCoordinate) {
  const std::string e = check_error<Degenerate>();
  EXPECT_NE(e.find("kinetic energy is not positive definite: M's pivot for coordinate 'y' "
                   "(velocity 1) is "),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("(zero to rounding: M is singular; its diagonal entry 2)"), std::string::npos) << e;
}

TEST(CheckModel, PositiveDefiniteModelsPass) {
  EXPECT_EQ(check_error<eom::models::SpringPendulum>(), "no error");
  EXPECT_EQ(check_error<eom::models::Chain<10>>(), "no error");
  EXPECT_EQ(check_error<eom::models::Chain<40>>(), "no error");  // M's AD numbers on the heap stack
}

}  // namespace
