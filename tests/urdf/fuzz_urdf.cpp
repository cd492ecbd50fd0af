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
#include <random>
#include <span>
#include <string>

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
  return eom::test::fuzz_run<eom::urdf::UrdfError>(
      "fuzz_urdf", std::atoi(argv[1]), std::span(argv + 2, argv + argc), 20261124, "case.urdf",
      [](const std::string& text, std::mt19937_64& rng) { return eom::test::mutate_text(text, rng, tokens, tokens); },
      [](int k, const std::string& mutated) {
        // every inertia policy and both roots in turn, so that each path of the reader is fuzzed
        // and every other six cases with the <collision>s read and a ground (the scene's path)
        const bool scene = (k / 6) % 2 == 1;
        const eom::urdf::ReadOptions options{.free_root = k % 2 == 1,
                                             .inertia = static_cast<eom::urdf::InertiaPolicy>((k / 2) % 3),
                                             .collisions = scene};
        eom::urdf::HeaderOptions header_options;
        if (scene) header_options.ground = 0.0;
        return eom::urdf::model_header(eom::urdf::parse(mutated, "case.urdf", options), header_options);
      });
}
