#include "eomgen/write_file.hpp"

#include <fstream>
#include <stdexcept>
#include <system_error>

namespace eom::gen {

void write_if_changed(const std::filesystem::path& path, const std::string& content) {
  {  // compared only when the sizes agree, read in one piece
    std::error_code no_file;
    std::ifstream in;
    if (std::filesystem::file_size(path, no_file) == content.size() && !no_file)
      in.open(path, std::ios::binary);
    std::string old(in ? content.size() : 0, '\0');
    if (in && in.read(old.data(), static_cast<std::streamsize>(old.size())) && old == content) return;
  }
  std::filesystem::path tmp = path;
  tmp += ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << content;
    out.close();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(tmp, ignored);
      throw std::runtime_error("cannot write " + tmp.string());
    }
  }
  std::filesystem::rename(tmp, path);
}

}  // namespace eom::gen
