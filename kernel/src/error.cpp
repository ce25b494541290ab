#include "cfuse/kernel/error.h"

#include <fmt/format.h>

#include "cfuse/kernel/check.h"

namespace cfuse {

std::string SourceLocation::ToString() const {
  std::string out = file.empty() ? std::string("<input>") : file;
  if (line > 0) {
    out += fmt::format(":{}", line);
    if (column > 0) out += fmt::format(":{}", column);
  }
  if (!element.empty()) out += ": " + element;
  return out;
}

InputError::InputError(SourceLocation where, const std::string& message)
    : std::runtime_error(fmt::format("{}: error: {}", where.ToString(), message)),
      where_(std::move(where)),
      message_(message) {}

void RequireText(const std::string& file, std::string_view text, const std::string& what) {
  const size_t nul = text.find('\0');
  if (nul != std::string_view::npos) {
    throw InputError(SourceLocation(file),
                     fmt::format("is a binary file, not a {} (NUL byte at offset {})", what, nul));
  }
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

namespace internal {
void CheckFailed(const char* file, int line, const char* condition, const std::string& message) {
  throw InternalError(fmt::format("internal error at {}:{}: check '{}' failed{}{}", file, line,
                                  condition, message.empty() ? "" : ": ", message));
}
}  // namespace internal

}  // namespace cfuse
