// Writing a generated file the way every eomgen tool does (the tracer, eomgen-urdf, eomgen-mjcf):
// only when its content changed, so that a build stays incremental, and by rename, so that no
// reader ever sees half a file.
#pragma once

#include <exception>
#include <filesystem>
#include <iostream>
#include <string>
#include <string_view>
#include <system_error>

namespace eom::gen {

// Writes `content` to `path` unless it is there already: to `path`.tmp, then renamed over `path`.
// Throws std::runtime_error ("cannot write <path>.tmp") when the temporary cannot be written.
void write_if_changed(const std::filesystem::path& path, const std::string& content);

// Removes a tool's output and its temporary, if there: after a failure, nothing half-made stays.
inline void remove_output(const std::string& output) noexcept {
  if (output.empty()) return;
  std::error_code ignored;
  std::filesystem::remove(output, ignored);
  std::filesystem::remove(output + ".tmp", ignored);
}

// A command-line tool's output (eomgen-urdf, eomgen-mjcf): make_text() written to `output` by
// write_if_changed, or to stdout when `output` is empty. Returns the exit code: 0, or 1 with
// "<tool>: <what>" on stderr when make_text or the write throws, and nothing left at `output`
// (nor its temporary), so that a build never takes a stale file for a fresh one.
template <class MakeText> int write_tool_output(std::string_view tool, const std::string& output, MakeText&& make_text) {
  try {
    const std::string text = make_text();
    if (output.empty()) {
      std::cout << text;
      return std::cout.good() ? 0 : 1;
    }
    write_if_changed(output, text);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << tool << ": " << e.what() << '\n';
    remove_output(output);
    return 1;
  }
}

}  // namespace eom::gen
