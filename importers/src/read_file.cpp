#include "read_file.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace cfuse {

namespace fs = std::filesystem;

std::string ReadImportedFile(const std::string& path, const SourceLocation& named_at,
                             const char* format, size_t max_bytes) {
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    throw InputError(named_at.known() ? named_at : SourceLocation(path),
                     named_at.known() ? fmt::format("cannot open '{}': no such file", path)
                                      : "cannot open: no such file");
  }
  if (fs::is_directory(path, ec)) {
    throw InputError(SourceLocation(path), fmt::format("is a directory, not a {} file", format));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputError(SourceLocation(path), fmt::format("cannot open: {}", std::strerror(errno)));
  }
  std::string text;
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    text.append(buffer, static_cast<size_t>(in.gcount()));
    if (text.size() > max_bytes) {
      throw InputError(SourceLocation(path),
                       fmt::format("file is larger than the {} MiB limit for {} files",
                                   max_bytes >> 20, format));
    }
  }
  if (in.bad()) throw InputError(SourceLocation(path), "cannot read the file");
  if (text.find('\0') != std::string::npos) {
    throw InputError(SourceLocation(path),
                     fmt::format("not a {} file: it holds binary data", format));
  }
  return text;
}

}  // namespace cfuse
