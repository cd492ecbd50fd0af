// eomgen-urdf: a URDF file as a model header in the spatial body form.
//
//   eomgen-urdf <robot.urdf> [--class <Name>] [--namespace <ns>] [--floating-base]
//               [--inertia error|warn|nearest] [--ground <height>]
//               [--collision-pair <linkA>:<linkB>]... [-o <model.hpp>]
//
// --floating-base frees the root link (a free joint, docs/CONTRACT.md §1) of a file without a
// floating joint. --inertia: what to do with a moving link whose inertia is not physically
// consistent (eom::urdf::InertiaPolicy; default error). Warnings (Robot::warnings) go to standard
// error, one a line. --ground and --collision-pair (add_eom_model's GROUND and COLLISION_PAIRS)
// add the scene for eom::contact_step: the links' <collision> geoms, a ground plane z = height
// against every moving one, the pairs of links whose geoms may touch (docs/CONTRACT.md §1, "URDF:
// the scene").
// Without -o the header goes to standard output. With -o it is written only when its content
// changes (by rename, so no reader sees half a file), and removed when the file has a problem, so
// that a build never goes on with a stale model. A problem is one line on standard error naming
// the file, the line, the joint or link; exit code 1.
#include <cmath>
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "eomgen/urdf.hpp"
#include "eomgen/write_file.hpp"

namespace {

int usage() {
  std::cerr << "usage: eomgen-urdf <robot.urdf> [--class <Name>] [--namespace <ns>] "
               "[--floating-base] [--inertia error|warn|nearest] [--ground <height>] "
               "[--collision-pair <linkA>:<linkB>]... [-o <model.hpp>]\n";
  return 2;
}


}  // namespace

int main(int argc, char** argv) {
  std::string input, output;
  eom::urdf::HeaderOptions options;
  eom::urdf::ReadOptions read_options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string& to) {
      if (i + 1 >= argc) return false;
      to = argv[++i];
      return true;
    };
    if (a == "--class") { if (!value(options.class_name)) return usage(); }
    else if (a == "--namespace") { if (!value(options.ns)) return usage(); }
    else if (a == "-o") { if (!value(output)) return usage(); }
    else if (a == "--floating-base") read_options.free_root = true;
    else if (a == "--ground") {
      std::string h;
      if (!value(h)) return usage();
      std::size_t end = 0;
      double height = 0;
      try { height = std::stod(h, &end); } catch (const std::exception&) { end = 0; }
      if (end != h.size() || h.empty() || !std::isfinite(height)) {
        std::cerr << "eomgen-urdf: --ground " << h << ": expected a finite height in metres\n";
        return 2;
      }
      options.ground = height;
    }
    else if (a == "--collision-pair") {
      std::string pair;
      if (!value(pair)) return usage();
      options.collision_pairs.push_back(pair);
    }
    else if (a == "--inertia") {
      std::string policy;
      if (!value(policy)) return usage();
      if (policy == "error") read_options.inertia = eom::urdf::InertiaPolicy::error;
      else if (policy == "warn") read_options.inertia = eom::urdf::InertiaPolicy::warn;
      else if (policy == "nearest") read_options.inertia = eom::urdf::InertiaPolicy::nearest;
      else {
        std::cerr << "eomgen-urdf: --inertia " << policy << ": expected error, warn or nearest\n";
        return 2;
      }
    }
    else if (!a.empty() && a[0] == '-') return usage();
    else if (input.empty()) input = a;
    else return usage();
  }
  if (input.empty()) return usage();
  read_options.collisions = options.ground || !options.collision_pairs.empty();
  return eom::gen::write_tool_output("eomgen-urdf", output, [&] {
    const eom::urdf::Robot robot = eom::urdf::read(input, read_options);
    for (const std::string& w : robot.warnings) std::cerr << "eomgen-urdf: warning: " << w << '\n';
    std::vector<std::string> warnings;
    std::string header = eom::urdf::model_header(robot, options, &warnings);
    for (const std::string& w : warnings) std::cerr << "eomgen-urdf: warning: " << w << '\n';
    return header;
  });
}
