#include "kernel/error.h"

#include <fmt/format.h>

#include "kernel/check.h"

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

namespace internal {
void CheckFailed(const char* file, int line, const char* condition, const std::string& message) {
  throw InternalError(fmt::format("internal error at {}:{}: check '{}' failed{}{}", file, line,
                                  condition, message.empty() ? "" : ": ", message));
}
}  // namespace internal

}  // namespace cfuse
