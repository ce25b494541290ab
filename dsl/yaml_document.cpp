#include "dsl/yaml_document.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace cfuse::dsl {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Raw file checks: everything that must be refused before YAML sees the bytes.

std::string ReadTextFile(const std::string& path, const SourceLocation& where,
                         const FileKind& kind) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) {
    throw InputError(where.known() ? where : SourceLocation(path),
                     where.known() ? fmt::format("cannot open '{}': no such file", path)
                                   : "cannot open: no such file");
  }
  if (fs::is_directory(status)) {
    throw InputError(SourceLocation(path), fmt::format("is a directory, not a {} file", kind.name));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(SourceLocation(path), fmt::format("cannot open: {}", std::strerror(errno)));
  std::string text;
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    text.append(buffer, static_cast<size_t>(in.gcount()));
    if (text.size() > kind.max_bytes) {
      throw InputError(SourceLocation(path), fmt::format("file is larger than the {} MiB limit for "
                                                         "{} files",
                                                         kind.max_bytes >> 20, kind.name));
    }
  }
  return text;
}

SourceLocation LocationOfOffset(const std::string& file, std::string_view text, size_t offset) {
  int line = 1, column = 1;
  for (size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return SourceLocation(file, line, column);
}

void CheckText(const std::string& file, std::string_view text, const FileKind& kind) {
  const size_t nul = text.find('\0');
  if (nul != std::string_view::npos) {
    throw InputError(
        SourceLocation(file),
        fmt::format("is a binary file, not a YAML {} (NUL byte at offset {})", kind.name, nul));
  }
  // UTF-8 validation: YAML text must be UTF-8, strictly (RFC 3629: no overlong forms,
  // surrogates or code points above U+10FFFF, which would otherwise pass into names and messages).
  for (size_t i = 0; i < text.size();) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    const int extra = c < 0x80   ? 0
                      : c < 0xC2 ? -1
                      : c < 0xE0 ? 1
                      : c < 0xF0 ? 2
                      : c < 0xF5 ? 3
                                 : -1;
    // The range of the second byte; the later ones are 0x80..0xBF.
    unsigned char lo = 0x80, hi = 0xBF;
    if (c == 0xE0) lo = 0xA0;
    if (c == 0xED) hi = 0x9F;
    if (c == 0xF0) lo = 0x90;
    if (c == 0xF4) hi = 0x8F;
    bool ok = extra >= 0;
    for (int k = 1; ok && k <= extra; ++k) {
      const unsigned char b = i + k < text.size() ? static_cast<unsigned char>(text[i + k]) : 0;
      ok = k == 1 ? (b >= lo && b <= hi) : (b >= 0x80 && b <= 0xBF);
    }
    if (!ok) {
      throw InputError(LocationOfOffset(file, text, i),
                       fmt::format("is not UTF-8 text (byte 0x{:02X}); is it a binary file?", c));
    }
    i += extra + 1;
  }
  bool blank = true;
  std::istringstream lines{std::string(text)};
  for (std::string line; std::getline(lines, line);) {
    const size_t first = line.find_first_not_of(" \t\r");
    if (first != std::string::npos && line[first] != '#') blank = false;
  }
  if (blank)
    throw InputError(SourceLocation(file), fmt::format("file is empty: {}", kind.empty_hint));
}

// ---------------------------------------------------------------------------------------------
// A YAML document with the helpers that turn shape errors into located messages.

}  // namespace cfuse::dsl
