// Shared by the fuzz targets: the contract every parser must keep on arbitrary bytes.
//
// A parser may accept the input or refuse it with an InputError that names the file (the
// display name given). Anything else escaping (another exception, a crash, a sanitizer report, a
// hang past libFuzzer's -timeout) is a finding.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <string_view>

#include "cfuse/kernel/error.h"

namespace cfuse::fuzz {

// Inputs larger than this are skipped: the readers' byte limits are tested directly, and
// libFuzzer's -max_len keeps inputs far below it anyway.
inline constexpr size_t kMaxFuzzInput = 1u << 20;

[[noreturn]] inline void Finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz finding: %s: %s\n", what, detail.c_str());
  std::abort();
}

// Runs `parse`, allowing InputError only, which must name a file and say something. True when
// the input was accepted.
template <typename Parse>
bool AcceptedOrRefused(Parse&& parse) {
  try {
    parse();
    return true;
  } catch (const InputError& e) {
    // An error may sit in an included file, so any file will do, but one must be named.
    if (!e.where().known()) Finding("InputError without a file", e.what());
    if (e.message().empty()) Finding("InputError without a message", e.what());
    return false;
  } catch (const std::exception& e) {
    Finding("exception other than InputError", e.what());
  } catch (...) {
    Finding("non-standard exception", "(unknown)");
  }
}

inline std::string_view AsText(const uint8_t* data, size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

}  // namespace cfuse::fuzz
