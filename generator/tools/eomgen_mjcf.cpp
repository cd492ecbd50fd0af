// eomgen-mjcf: a MuJoCo model file (MJCF) as a model header in the tree form, compiled by MuJoCo.
//
//   eomgen-mjcf <model.xml> [--class <Name>] [--namespace <ns>] [-o <model.hpp>]
//
// Without -o the header goes to standard output. With -o it is written only when its content
// changes (by rename, so no reader sees half a file), and removed when the file has a problem, so
// that a build never goes on with a stale model. A problem is one line on standard error naming
// the file and MuJoCo's message (with its line) or the element refused; exit code 1. MuJoCo's
// warnings go to standard error too (not to stdout, nor to a MUJOCO_LOG.TXT).
#include <mujoco/mujoco.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "eomgen/mjcf.hpp"
#include "eomgen/write_file.hpp"

namespace {

std::string output;  // for MuJoCo's fatal error handler: nothing half-written stays

void on_warning(const char* message) {
  std::cerr << "eomgen-mjcf: MuJoCo warning: " << message << '\n';
}
void on_error(const char* message) {  // MuJoCo cannot go on after mju_error
  std::cerr << "eomgen-mjcf: MuJoCo error: " << message << '\n';
  eom::gen::remove_output(output);
  std::_Exit(1);
}

int usage() {
  std::cerr
      << "usage: eomgen-mjcf <model.xml> [--class <Name>] [--namespace <ns>] [-o <model.hpp>] "
         "[--depfile <file.d>]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string input, depfile;
  eom::mjcf::HeaderOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string& to) {
      if (i + 1 >= argc) return false;
      to = argv[++i];
      return true;
    };
    if (a == "--class") {
      if (!value(options.class_name)) return usage();
    } else if (a == "--namespace") {
      if (!value(options.ns)) return usage();
    } else if (a == "-o") {
      if (!value(output)) return usage();
    } else if (a == "--depfile") {
      if (!value(depfile)) return usage();
    } else if (!a.empty() && a[0] == '-')
      return usage();
    else if (input.empty())
      input = a;
    else
      return usage();
  }
  if (input.empty()) return usage();
  mju_user_warning = on_warning;
  mju_user_error = on_error;
  const int status = eom::gen::write_tool_output("eomgen-mjcf", output, [&] {
    std::vector<std::string> warnings;
    std::string text = eom::mjcf::model_header(input, options, &warnings);
    for (const std::string& w : warnings) std::cerr << "eomgen-mjcf: warning: " << w << '\n';
    return text;
  });
  if (status == 0 && !depfile.empty() && !output.empty()) {  // the files read, for the build
    std::ofstream d(depfile);
    d << output << ":";
    for (const std::string& f : eom::mjcf::files_read(input)) d << " \\\n  " << f;
    d << "\n";
    if (!d) {
      std::cerr << "eomgen-mjcf: cannot write " << depfile << '\n';
      return 1;
    }
  }
  return status;
}
