// Error tiers 1 and 2 at their source: a location printed the compiler's way, InputError's
// message with and without it, the screen for text that is not UTF-8 (RFC 3629, strictly), byte
// offsets turned into lines and columns, and the message of a failed contract check.
#include "cfuse/kernel/error.h"

#include <catch2/catch.hpp>
#include <string>

#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

TEST_CASE("error: a location prints as file:line:column, then the element", "[kernel]") {
  CHECK(SourceLocation("m.yaml", 3, 7).ToString() == "m.yaml:3:7");
  CHECK(SourceLocation("m.yaml", 3).ToString() == "m.yaml:3");
  CHECK(SourceLocation("m.yaml", 0, 7).ToString() == "m.yaml");  // a column needs its line
  CHECK(SourceLocation("r.urdf", 0, 0, "joint 'elbow'").ToString() == "r.urdf: joint 'elbow'");
  CHECK(SourceLocation("m.json", 2, 5, "points[3]").ToString() == "m.json:2:5: points[3]");
  CHECK(SourceLocation().ToString() == "<input>");
  CHECK_FALSE(SourceLocation().known());
  CHECK(SourceLocation("m.yaml").known());

  const InputError e(SourceLocation("m.yaml", 4, 2), "unknown key 'lable'");
  CHECK(std::string(e.what()) == "m.yaml:4:2: error: unknown key 'lable'");
  CHECK(e.message() == "unknown key 'lable'");
  CHECK(e.where().line == 4);
  CHECK(e.where().column == 2);
}

TEST_CASE("error: byte offsets become lines and columns", "[kernel]") {
  const std::string text = "ab\ncd\r\nef";
  auto at = [&](size_t offset) { return LocationOfOffset("t", text, offset).ToString(); };
  CHECK(at(0) == "t:1:1");
  CHECK(at(2) == "t:1:3");  // the line feed itself ends line 1
  CHECK(at(3) == "t:2:1");
  CHECK(at(5) == "t:2:3");  // a carriage return is a column like any byte
  CHECK(at(7) == "t:3:1");
  CHECK(at(9) == "t:3:3");  // the end of the text
  CHECK(at(1000) == "t:3:3");
}

// The InputError RequireText throws on `text`, or a failure.
InputError Refusal(const std::string& text) {
  try {
    RequireText("f.txt", text, "model");
  } catch (const InputError& e) {
    return e;
  }
  FAIL("accepted: " << text);
  return InputError(SourceLocation(), "");
}

TEST_CASE("error: text is UTF-8 without NUL bytes, strictly by RFC 3629", "[kernel]") {
  // The edges of every range are accepted: U+007F, U+0080, U+07FF, U+0800, U+D7FF, U+E000,
  // U+FFFF, U+10000 and U+10FFFF.
  for (const char* ok : {"plain ascii\n\x7F", "\xC2\x80", "\xDF\xBF", "\xE0\xA0\x80",
                         "\xED\x9F\xBF", "\xEE\x80\x80", "\xEF\xBF\xBF", "\xF0\x90\x80\x80",
                         "\xF4\x8F\xBF\xBF", "caf\xC3\xA9 \xE2\x82\xAC \xF0\x9F\x98\x80", ""}) {
    INFO(ok);
    CHECK_NOTHROW(RequireText("f.txt", ok, "model"));
  }
  const InputError nul = Refusal(std::string("ab\n\0cd", 6));
  CHECK(nul.where().ToString() == "f.txt");
  CHECK(nul.message() == "is a binary file, not a model (NUL byte at offset 3)");

  // Each refused at its first byte, which the message names.
  const struct {
    const char* text;
    const char* where;
    const char* byte;
  } bad[] = {
      {"\x80", "f.txt:1:1", "0x80"},              // a continuation byte alone
      {"x\xC0\xAF", "f.txt:1:2", "0xC0"},         // overlong '/'
      {"\xC1\xBF", "f.txt:1:1", "0xC1"},          // overlong
      {"\xE0\x9F\xBF", "f.txt:1:1", "0xE0"},      // overlong three bytes
      {"\xED\xA0\x80", "f.txt:1:1", "0xED"},      // a surrogate, U+D800
      {"\xF0\x8F\xBF\xBF", "f.txt:1:1", "0xF0"},  // overlong four bytes
      {"\xF4\x90\x80\x80", "f.txt:1:1", "0xF4"},  // U+110000
      {"\xF5\x80\x80\x80", "f.txt:1:1", "0xF5"},  // no such lead byte
      {"\xFF", "f.txt:1:1", "0xFF"},
      {"ok\nab\xE2\x82", "f.txt:2:3", "0xE2"},        // cut short by the end
      {"\xE2\x82x", "f.txt:1:1", "0xE2"},             // a continuation missing
      {"\xF0\x9F\x98\xC3\xA9", "f.txt:1:1", "0xF0"},  // a lead byte where one continues
  };
  for (const auto& b : bad) {
    INFO(b.where);
    const InputError e = Refusal(b.text);
    CHECK(e.where().ToString() == b.where);
    CHECK(e.message() ==
          std::string("is not UTF-8 text (byte ") + b.byte + "); is it a binary file?");
  }
}

TEST_CASE("error: a failed check names its place, its condition and why", "[kernel]") {
  CHECK_THROWS_AS(internal::CheckFailed("f.cpp", 12, "a < b", ""), InternalError);
  CHECK_THROWS_WITH(internal::CheckFailed("f.cpp", 12, "a < b", ""),
                    "internal error at f.cpp:12: check 'a < b' failed");
  CHECK_THROWS_WITH(internal::CheckFailed("f.cpp", 12, "a < b", "3 vs 2"),
                    "internal error at f.cpp:12: check 'a < b' failed: 3 vs 2");
}

}  // namespace
}  // namespace cfuse
