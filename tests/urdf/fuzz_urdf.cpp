// A fuzz run of the URDF reader and writer: seed files mutated in many small ways (truncated,
// spans deleted or repeated, tags swapped, numbers and names replaced, mimic, dynamics and limit
// elements inserted, bytes flipped), each case fed to eom::urdf::parse (each inertia policy, the
// root fixed and freed, in turn; half of them with the <collision>s read) and model_header (with a
// ground for those). Every case must end in a model header (with no non-finite number in it) or a
// UrdfError whose message starts with the file name; anything else (another exception, a crash, a
// sanitizer report: this program is built with AddressSanitizer and UndefinedBehaviorSanitizer)
// fails the run. Deterministic: the mutations come from a fixed seed.
//
//   fuzz_urdf <cases per seed> <seed.urdf>...
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <eomgen/urdf.hpp>

#include "fuzz_text.hpp"

namespace {

const char* const tokens[] = {"", "nan", "inf", "-1", "1e999", "1e-400", "abc", "0 0", "1 2 3 4", "-0",
                              "0x10", "+", "revolute", "fixed", "floating", "\"", "<", "&amp;", "<joint>",
                              "</link>", "<mimic joint=\"j1\"/>", "<mimic/>", "<dynamics friction=\"-1\"/>",
                              "<limit lower=\"1\" upper=\"0\"/>", "<limit effort=\"nan\"/>", "shoulder",
                              "finger1_joint", "continuous", "prismatic"};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: fuzz_urdf <cases per seed> <seed.urdf>...\n");
    return 2;
  }
  const int per_seed = std::atoi(argv[1]);
  std::mt19937_64 rng(20261124);
  int models = 0, errors = 0;
  for (int f = 2; f < argc; ++f) {
    std::ifstream in(argv[f], std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    if (!in || text.str().empty()) {
      std::fprintf(stderr, "fuzz_urdf: cannot read %s\n", argv[f]);
      return 2;
    }
    for (int k = 0; k < per_seed; ++k) {
      const std::string mutated = eom::test::mutate_text(text.str(), rng, tokens, tokens);
      try {
        // every inertia policy and both roots in turn, so that each path of the reader is fuzzed
        // and every other six cases with the <collision>s read and a ground (the scene's path)
        const bool scene = (k / 6) % 2 == 1;
        const eom::urdf::ReadOptions options{
            .free_root = k % 2 == 1,
            .inertia = static_cast<eom::urdf::InertiaPolicy>((k / 2) % 3),
            .collisions = scene};
        eom::urdf::HeaderOptions header_options;
        if (scene) header_options.ground = 0.0;
        const std::string header = eom::urdf::model_header(
            eom::urdf::parse(mutated, "case.urdf", options), header_options);
        if (header.find("struct ") == std::string::npos) throw std::logic_error("empty header");
        if (const std::string at = eom::test::non_finite_number(header); !at.empty())
          throw std::logic_error("a non-finite number in the header: '" + at + "'");
        ++models;
      } catch (const eom::urdf::UrdfError& e) {
        if (std::string(e.what()).rfind("case.urdf", 0) != 0) {
          std::fprintf(stderr, "fuzz_urdf: message without the file name: %s\n", e.what());
          return 1;
        }
        ++errors;
      } catch (const std::exception& e) {
        std::fprintf(stderr, "fuzz_urdf: case %d of %s: unexpected %s\n--- input ---\n%s\n", k,
                     argv[f], e.what(), mutated.c_str());
        return 1;
      }
    }
  }
  std::printf("fuzz_urdf: %d cases: %d models, %d clear errors\n", models + errors, models, errors);
  return 0;
}
