// Internal contract checks (error tier 2 of 3).
//
// Tier 1, bad user input, is cfuse/kernel/error.h's InputError. Tier 3, solver and search outcomes,
// are status structs. A failed CFUSE_CHECK is a bug in cfuse, never the user's fault: it throws
// InternalError with the source location so that the CLI can report it and exit non-zero
// instead of aborting with half-written output.
#pragma once

#include <fmt/format.h>

#include <stdexcept>
#include <string>
#include <type_traits>

namespace cfuse {

class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

namespace internal {
[[noreturn]] void CheckFailed(const char* file, int line, const char* condition,
                              const std::string& message);

// "a vs b" for CFUSE_CHECK_EQ and its kin: the values that broke the contract, where fmt can
// print them (numbers); other types give only the condition.
template <typename A, typename B>
std::string Operands(const A& a, const B& b) {
  if constexpr (std::is_arithmetic_v<A> && std::is_arithmetic_v<B>) {
    return fmt::format("{} vs {}", a, b);
  } else {
    return "";
  }
}
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

// CFUSE_CHECK_EQ(a, b) and its kin: a failed comparison names both values ("check 'rows == n'
// failed: 3 vs 4"). Each operand is evaluated once.
#define CFUSE_CHECK_OP(a, op, b)                                                                 \
  do {                                                                                           \
    const auto& cfuse_check_a = (a);                                                             \
    const auto& cfuse_check_b = (b);                                                             \
    if (!(cfuse_check_a op cfuse_check_b)) {                                                     \
      ::cfuse::internal::CheckFailed(__FILE__, __LINE__, #a " " #op " " #b,                      \
                                     ::cfuse::internal::Operands(cfuse_check_a, cfuse_check_b)); \
    }                                                                                            \
  } while (false)
#define CFUSE_CHECK_EQ(a, b) CFUSE_CHECK_OP(a, ==, b)
#define CFUSE_CHECK_NE(a, b) CFUSE_CHECK_OP(a, !=, b)
#define CFUSE_CHECK_LT(a, b) CFUSE_CHECK_OP(a, <, b)
#define CFUSE_CHECK_LE(a, b) CFUSE_CHECK_OP(a, <=, b)
#define CFUSE_CHECK_GT(a, b) CFUSE_CHECK_OP(a, >, b)
#define CFUSE_CHECK_GE(a, b) CFUSE_CHECK_OP(a, >=, b)
