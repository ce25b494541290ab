// Numbers in input files: what a YAML or JSON scalar reads as, and each refusal at its node (a
// string, YAML's .inf and .nan, an overflow, trailing characters, a list of the wrong length).
#include "yaml_numbers.h"

#include <catch2/catch.hpp>
#include <string>

#include "test_util.h"

namespace cfuse {
namespace {

const FileKind kKind{"test", "nothing", 1 << 20};

double Read(const std::string& value) {
  const Document doc("n.yaml", "x: " + value + "\n", kKind);
  return Number(doc, doc.Parse()["x"], "x");
}

TEST_CASE("yaml numbers: the written forms", "[dsl]") {
  CHECK(Read("12") == 12);
  CHECK(Read("-0.25") == -0.25);
  CHECK(Read("1.5e-3") == 1.5e-3);
  CHECK(Read("+3E2") == 300);
  CHECK(Read(".5") == 0.5);
  CHECK(Read("1.7976931348623157e308") == 1.7976931348623157e308);
  CHECK(Read("4.9e-324") == 4.9e-324);  // subnormal, yet finite
}

TEST_CASE("yaml numbers: refused at the value, with why", "[dsl]") {
  const testing::BadCase cases[] = {
      {"x: \"0.5\"", 1, 4, "x must be a number, got the string \"0.5\""},
      {"x: '7'", 1, 4, "x must be a number, got the string \"7\""},
      {"x: .inf", 1, 4, "x must be finite, got '.inf'"},
      {"x: -.Inf", 1, 4, "x must be finite, got '-.Inf'"},
      {"x: .NaN", 1, 4, "x must be finite, got '.NaN'"},
      {"x: nan", 1, 4, "x must be finite, got 'nan'"},
      {"x: 1e999", 1, 4, "x must be finite, got '1e999'"},
      {"x: 12 mm", 1, 4, "x must be a number, got '12 mm'"},
      {"x: 1.5.2", 1, 4, "x must be a number, got '1.5.2'"},
      {"x: yes", 1, 4, "x must be a number, got 'yes'"},
      {"x: [1]", 1, 4, "x must be a number"},
      {"x:\n  a: 1", 2, 3, "x must be a number"},
  };
  testing::ExpectRefused(std::begin(cases), std::end(cases), [](const char* text, const char* f) {
    const Document doc(f, text, kKind);
    return Number(doc, doc.Parse()["x"], "x");
  });
}

TEST_CASE("yaml numbers: a list of exactly n, each element checked", "[dsl]") {
  const Document doc("n.yaml", "a: [1, 2.5, -3]\nb: [1, 2]\nc: 4\nd: [1, x, 3]\n", kKind);
  const YAML::Node root = doc.Parse();
  CHECK(Numbers(doc, root["a"], 3, "xyz") == Eigen::Vector3d(1, 2.5, -3));
  const testing::BadCase cases[] = {
      {"b", 2, 4, "xyz must be a list of 3 numbers, got 2"},
      {"c", 3, 4, "xyz must be a list of 3 numbers"},
      {"d", 4, 8, "xyz must be a number, got 'x'"},
  };
  for (const auto& c : cases) {
    INFO(c.text);
    try {
      Numbers(doc, root[c.text], 3, "xyz");
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().ToString() ==
            "n.yaml:" + std::to_string(c.line) + ":" + std::to_string(c.column));
      CHECK(e.message() == c.message);
    }
  }
}

}  // namespace
}  // namespace cfuse
