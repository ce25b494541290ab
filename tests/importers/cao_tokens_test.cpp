// The CAO reader's lexical side (importers/src/cao_tokens.cpp): names made identifiers, numbers
// and counts as ViSP writes them, pieces of input shown in messages, and the text split into
// rows of tokens (comments, quotes, blanks, a byte-order mark, the end of the file), each token
// checked as an index or a parameter at its line and column.
#include <catch2/catch.hpp>
#include <string>

#include "cao_internal.h"
#include "cfuse/importers/cao.h"

namespace cfuse::internal {
namespace {

TEST_CASE("cao tokens: names made identifiers", "[importers][cao]") {
  CHECK(Identifier("cube") == "cube");
  CHECK(Identifier("2x4-brick") == "_2x4_brick");
  CHECK(Identifier("front face") == "front_face");
  CHECK(Identifier("caf\xC3\xA9") == "caf__");  // each byte of a UTF-8 sequence
  CHECK(Identifier("") == "_");
  CHECK(Identifier("in") == "in_");  // the DSL's reserved words
  CHECK(Identifier("nominal") == "nominal_");
  CHECK(Identifier("inside") == "inside");
  for (char c : {' ', '\t', '\r', '\v', '\f'}) CHECK(IsBlank(c));
  for (char c : {'\n', 'a', '0', '#', '\0'}) CHECK_FALSE(IsBlank(c));
  CHECK(StartsWith("load(", "load"));
  CHECK_FALSE(StartsWith("lo", "load"));
  CHECK(Shown(std::string(40, 'x')) == std::string(40, 'x'));
  CHECK(Shown(std::string(41, 'x')) == std::string(37, 'x') + "...");
}

TEST_CASE("cao tokens: numbers and counts", "[importers][cao]") {
  const struct {
    const char* text;
    size_t length;
  } lengths[] = {{"12", 2}, {"-1.5", 4}, {"+.5", 3},   {"5.", 2},   {"1e5", 3}, {"2E-3", 4},
                 {"1e", 1}, {"1e+", 1},  {"1.2.3", 3}, {"0x10", 1}, {"e5", 0},  {"-", 0},
                 {".", 0},  {"", 0},     {"-.e1", 0},  {"7,", 1},   {"3 4", 1}, {"1.5e-3x", 6}};
  for (const auto& l : lengths) {
    INFO(l.text);
    CHECK(NumberLength(l.text) == l.length);
  }
  CHECK(NumberValue("+.5") == 0.5);
  CHECK(NumberValue("-2.5e2") == -250);
  CHECK(NumberValue("5.") == 5);
  CHECK(NumberValue("1e308") == 1e308);
  CHECK_FALSE(NumberValue("1e309"));  // beyond a double
  CHECK_FALSE(NumberValue("-1e999"));

  CHECK(NonNegativeInteger("0") == 0);
  CHECK(NonNegativeInteger("007") == 7);
  CHECK(NonNegativeInteger("99999999999999999") == 99999999999999999);
  // From 10^17 on the value is returned as it stands, beyond every limit and without overflow.
  CHECK(NonNegativeInteger("100000000000000000") == 100000000000000000);
  CHECK(NonNegativeInteger("100000000000000000000000") == 100000000000000000);
  for (const char* bad : {"", "+1", "-1", "1.0", "1e3", " 1", "12a"}) {
    INFO(bad);
    CHECK_FALSE(NonNegativeInteger(bad));
  }
}

// The InputError importing `text` throws: "LINE:COLUMN: message".
std::string Error(const std::string& text) {
  try {
    ImportCaoFromString(text, "t.cao");
  } catch (const InputError& e) {
    return std::to_string(e.where().line) + ":" + std::to_string(e.where().column) + ": " +
           e.message();
  }
  return "accepted";
}

TEST_CASE("cao tokens: rows of tokens", "[importers][cao]") {
  // Blanks of every kind, Windows line ends, a byte-order mark, comments of both kinds, a name
  // quoted with blanks in it, a last line without its line feed.
  const ConstraintGraph g = ImportCaoFromString(
      "\xEF\xBB\xBFV1\r\n3 // three\r\n0\t0\v0\n1\f0 0 # x\n0 1 0\n"
      "1\n0 1 name=\"front edge\" useLod=TRUE minLineLengthThreshold=0.5\n"
      "0\n1\n3 0 1 2 name=\"f 1\" useLod=0 minPolygonAreaThreshold=1e-3\n0\n0",
      "t.cao");
  const Component& c = g.components.at(0);
  REQUIRE(c.points.size() == 3);
  CHECK(c.points[1].position == Eigen::Vector3d(1, 0, 0));
  CHECK(c.points[1].where.ToString() == "t.cao:4:1");
  REQUIRE(c.edges.size() == 3);
  CHECK(c.edges[0].name == "front_edge");
  CHECK(c.faces.at(0).name == "f_1");
  // A '#' inside a token is no comment.
  CHECK(Error("V1\n1\n0 0 0#\n") == "3:5: expected a number, found '0#'");
}

TEST_CASE("cao tokens: indices and counts at their token", "[importers][cao]") {
  const std::string two = "V1\n2\n0 0 0\n1 0 0\n";
  CHECK(Error("V1\n1\n0 0 0\n1\n0 0\n") ==
        "5:3: a 3D line joins two different points, found point 0 twice");
  CHECK(Error("V1\n1\n0 0 0\n1\n0 1\n") ==
        "5:3: point index 1 is out of range: the file has 1 point (0 to 0)");
  CHECK(Error(two + "1\n0 99999999999999999999\n") ==
        "6:3: point index 99999999999999999999 is out of range: the file has 2 points (0 to 1)");
  CHECK(Error(two + "0\n1\n3 0 1 2\n") ==
        "7:3: line index 0 is out of range: the file has no lines");
  CHECK(Error(two + "0\n0\n40001\n") ==
        "7:1: the number of faces from 3D points, 40001, exceeds the limit of 40000");
  CHECK(Error(two + "0 7\n") == "5:3: unexpected '7' after the number of 3D lines");
  // An unquoted value runs to the token's end, '=' and all.
  CHECK(ImportCaoFromString(two + "1\n0 1 name=a=b\n0\n0\n", "t.cao").components[0].edges[0].name ==
        "a_b");
  CHECK(Error(two + "1\n0 1 name=\"a\"b\n") ==
        "6:5: unexpected characters after the quoted value of 'name'");
  CHECK(Error(two + "1\n0 1 minPolygonAreaThreshold=\n") ==
        "6:5: minPolygonAreaThreshold is a number, found ''");
  CHECK(Error(two + "1\n0 1 minLineLengthThreshold=1e999\n") ==
        "6:5: minLineLengthThreshold is a number, found '1e999'");
  CHECK(Error(two + "1\n0 1 =x\n") ==
        "6:5: unknown parameter '': the parameters are name, useLod, minLineLengthThreshold and "
        "minPolygonAreaThreshold");
}

}  // namespace
}  // namespace cfuse::internal
