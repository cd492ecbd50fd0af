// A fuzz run of the MJCF import (eom::mjcf::model_header: MuJoCo's compiler, then eomgen's reading
// of the mjModel into a model header): seed files mutated in many small ways (truncated, spans
// deleted or repeated, tags swapped, values and elements replaced or inserted: joint and geom
// kinds, actuators, equalities, tendons, options, numbers out of range, bytes flipped), each case
// written to a file and imported. Every case must end in a model header (with no non-finite
// number in it) or an MjcfError whose message starts with the file's path; anything else (another
// exception, a crash, a sanitizer report: eomgen's reader is built here with AddressSanitizer and
// UndefinedBehaviorSanitizer; MuJoCo is Debian's build) fails the run. Deterministic: the
// mutations come from a fixed seed.
//
//   fuzz_mjcf <cases per seed> <work folder> <seed.xml>...
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <span>
#include <string>
#include <vector>

#include <eomgen/mjcf.hpp>

#include "fuzz_text.hpp"

namespace {

const char* const values[] = {
    "", "nan", "inf", "-1", "0", "1e308", "1e-300", "abc", "0 0", "1 2 3 4", "-0", "1 0 0 0",
    "0 0 0 0", "hinge", "slide", "ball", "free", "sphere", "capsule", "box", "plane", "cylinder",
    "ellipsoid", "mesh", "true", "false", "elliptic", "RK4", "implicit", "0.5 -0.5", "1 0", "0.3",
    "2", "0 0 1", "1 1 1", "-0.5 0.5", "0.1 0.2 0.3", "0 0 0 0 0 1", "world", "1e-9"};
const char* const elements[] = {
    "<freejoint/>", "<joint type=\"ball\"/>", "<joint type=\"slide\" axis=\"0 0 1\"/>",
    "<joint axis=\"0 0 0\"/>", "<joint type=\"ball\" limited=\"true\" range=\"0 1\"/>",
    "<joint armature=\"-1\" damping=\"nan\"/>", "<geom size=\"0.1\"/>",
    "<geom type=\"capsule\" fromto=\"0 0 0 0 0 0\" size=\"0.1\"/>",
    "<geom type=\"box\" size=\"0 0 0\"/>", "<geom type=\"cylinder\" size=\"0.1 0.1\"/>",
    "<geom type=\"ellipsoid\" size=\"0.1 0.2 0.3\"/>", "<geom type=\"plane\" size=\"1 1 1\"/>",
    "<site name=\"s\"/>", "<body><geom size=\"0.1\"/></body>", "<inertial pos=\"0 0 0\" mass=\"0\"/>",
    "<inertial pos=\"0 0 0\" mass=\"1\" diaginertia=\"1 1 3\"/>",
    "<option timestep=\"0\" gravity=\"0 0 1e308\"/>", "<option cone=\"elliptic\" impratio=\"-1\"/>",
    "<option integrator=\"RK4\"/>", "<actuator><motor joint=\"j0\"/></actuator>",
    "<actuator><position joint=\"j0\" kp=\"nan\"/></actuator>",
    "<equality><weld body1=\"b0\"/></equality>", "<equality><joint joint1=\"j0\"/></equality>",
    "<tendon><fixed name=\"t\"><joint joint=\"j0\" coef=\"1\"/></fixed></tendon>",
    "<contact><pair geom1=\"g0\" geom2=\"g1\"/></contact>",
    "<contact><exclude body1=\"b0\" body2=\"b1\"/></contact>",
    "<keyframe><key qpos=\"1 2\"/></keyframe>", "<default><geom condim=\"6\"/></default>"};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: fuzz_mjcf <cases per seed> <work folder> <seed.xml>...\n");
    return 2;
  }
  const std::filesystem::path folder = argv[2];
  std::filesystem::create_directories(folder);
  const std::string path = (folder / "case.xml").string();  // model_header reads a file
  return eom::test::fuzz_run<eom::mjcf::MjcfError>(
      "fuzz_mjcf", std::atoi(argv[1]), std::span(argv + 3, argv + argc), 20261208, path,
      [](const std::string& text, std::mt19937_64& rng) {
        return eom::test::mutate_text(text, rng, values, elements, 3, 2, true);
      },
      [&](int, const std::string& mutated) {
        std::ofstream(path, std::ios::binary | std::ios::trunc) << mutated;
        std::vector<std::string> warnings;
        return eom::mjcf::model_header(path, {}, &warnings);
      });
}
