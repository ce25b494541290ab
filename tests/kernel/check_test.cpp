// The contract checks (error tier 2): a failed check throws InternalError naming the condition
// and, for a comparison, both values.
#include "cfuse/kernel/check.h"

#include <catch2/catch.hpp>
#include <string>

namespace cfuse {
namespace {

TEST_CASE("checks: a failed comparison names the condition and both values", "[kernel]") {
  const int rows = 3;
  const long n = 4;
  CHECK_THROWS_WITH([&] { CFUSE_CHECK_EQ(rows, n); }(),
                    Catch::Contains("check 'rows == n' failed: 3 vs 4"));
  CHECK_THROWS_AS([&] { CFUSE_CHECK_EQ(rows, n); }(), InternalError);
  CHECK_THROWS_WITH([] { CFUSE_CHECK_GT(0.5, 2.0); }(),
                    Catch::Contains("'0.5 > 2.0' failed: 0.5 vs 2"));
  CHECK_THROWS_WITH([&] { CFUSE_CHECK_LE(n, rows); }(), Catch::Contains("4 vs 3"));
  CHECK_THROWS([&] { CFUSE_CHECK_NE(rows, 3); }());
  CHECK_THROWS([&] { CFUSE_CHECK_LT(rows, 3); }());
  CHECK_THROWS([&] { CFUSE_CHECK_GE(rows, 4); }());
  // Holding, they do nothing; each operand is evaluated once.
  int calls = 0;
  CHECK_NOTHROW([&] { CFUSE_CHECK_EQ(++calls, 1); }());
  CHECK(calls == 1);
  CHECK_NOTHROW([&] { CFUSE_CHECK_LE(rows, n); }());
  CHECK_NOTHROW([&] { CFUSE_CHECK_GE(n, rows); }());
  CHECK_NOTHROW([&] { CFUSE_CHECK_NE(rows, n); }());
  // A type fmt cannot print gives the condition alone.
  struct Opaque {
    bool operator==(const Opaque&) const { return false; }
  };
  CHECK_THROWS_WITH([] { CFUSE_CHECK_EQ(Opaque{}, Opaque{}); }(),
                    Catch::EndsWith("check 'Opaque{} == Opaque{}' failed"));
}

}  // namespace
}  // namespace cfuse
