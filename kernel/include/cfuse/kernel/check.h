// Internal contract checks (error tier 2 of 3).
//
// Tier 1, bad user input, is cfuse/kernel/error.h's InputError. Tier 3, solver and search outcomes,
// are status structs. A failed CFUSE_CHECK is a bug in cfuse, never the user's fault: it throws
// InternalError with the source location so that the CLI can report it and exit non-zero
// instead of aborting with half-written output.
#pragma once

#include <stdexcept>
#include <string>

namespace cfuse {

class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

namespace internal {
[[noreturn]] void CheckFailed(const char* file, int line, const char* condition,
                              const std::string& message);
}  // namespace internal

}  // namespace cfuse

#define CFUSE_CHECK(condition)                                            \
  do {                                                                    \
    if (!(condition)) {                                                   \
      ::cfuse::internal::CheckFailed(__FILE__, __LINE__, #condition, ""); \
    }                                                                     \
  } while (false)

#define CFUSE_CHECK_MSG(condition, message)                                      \
  do {                                                                           \
    if (!(condition)) {                                                          \
      ::cfuse::internal::CheckFailed(__FILE__, __LINE__, #condition, (message)); \
    }                                                                            \
  } while (false)
