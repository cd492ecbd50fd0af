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
#include <sstream>
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
  const int per_seed = std::atoi(argv[1]);
  const std::filesystem::path folder = argv[2];
  std::filesystem::create_directories(folder);
  const std::string path = (folder / "case.xml").string();
  std::mt19937_64 rng(20261208);
  int models = 0, errors = 0;
  for (int f = 3; f < argc; ++f) {
    std::ifstream in(argv[f], std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    if (!in || text.str().empty()) {
      std::fprintf(stderr, "fuzz_mjcf: cannot read %s\n", argv[f]);
      return 2;
    }
    for (int k = 0; k < per_seed; ++k) {
      const std::string mutated = eom::test::mutate_text(text.str(), rng, values, elements, 3, 2, true);
      std::ofstream(path, std::ios::binary | std::ios::trunc) << mutated;
      try {
        std::vector<std::string> warnings;
        const std::string header = eom::mjcf::model_header(path, {}, &warnings);
        if (header.find("struct ") == std::string::npos) throw std::logic_error("no model in the header");
        if (const std::string at = eom::test::non_finite_number(header); !at.empty())
          throw std::logic_error("a non-finite number in the header: '" + at + "'");
        ++models;
      } catch (const eom::mjcf::MjcfError& e) {
        if (std::string(e.what()).rfind(path, 0) != 0) {
          std::fprintf(stderr, "fuzz_mjcf: message without the file's path: %s\n", e.what());
          return 1;
        }
        ++errors;
      } catch (const std::exception& e) {
        std::fprintf(stderr, "fuzz_mjcf: case %d of %s: unexpected %s\n--- input ---\n%s\n", k, argv[f],
                     e.what(), mutated.c_str());
        return 1;
      }
    }
  }
  std::printf("fuzz_mjcf: %d cases: %d models, %d clear errors\n", models + errors, models, errors);
  return 0;
}
