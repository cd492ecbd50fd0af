// Writing a generated file the way every eomgen tool does (the tracer, eomgen-urdf, eomgen-mjcf):
// only when its content changed, so that a build stays incremental, and by rename, so that no
// reader ever sees half a file.
#pragma once

#include <filesystem>
#include <string>

namespace eom::gen {

// Writes `content` to `path` unless it is there already: to `path`.tmp, then renamed over `path`.
// Throws std::runtime_error ("cannot write <path>.tmp") when the temporary cannot be written.
void write_if_changed(const std::filesystem::path& path, const std::string& content);

}  // namespace eom::gen
