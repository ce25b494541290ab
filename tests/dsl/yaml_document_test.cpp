// Reading YAML with located errors (dsl/src/yaml_document.cpp): the raw file checks before any
// parser (missing, a directory, over the size limit, not text, empty), one document per file,
// yaml-cpp's syntax errors moved to their likely cause, and the shape helpers: where a node
// and a scalar's characters are, mappings, lists, keys (duplicate, unknown, a suggestion).
#include "yaml_document.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

const FileKind kKind{"model", "a model needs 'points' or 'components'", 1024};

using testing::ErrorOf;

TEST_CASE("yaml document: the raw checks of a file", "[dsl]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_yaml_document_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string missing = (dir / "missing.yaml").string();
  InputError e = ErrorOf([&] { ReadTextFile(missing, {}, kKind); });
  CHECK(e.where().ToString() == missing);
  CHECK(e.message() == "cannot open: no such file");
  e = ErrorOf([&] { ReadTextFile(missing, SourceLocation("top.yaml", 4, 10), kKind); });
  CHECK(e.where().ToString() == "top.yaml:4:10");  // where it was asked for
  CHECK(e.message() == "cannot open '" + missing + "': no such file");
  e = ErrorOf([&] { ReadTextFile(dir.string(), {}, kKind); });
  CHECK(e.message() == "is a directory, not a model file");
  std::ofstream(dir / "big.yaml") << "# " << std::string(1 << 20, 'x') << "\n";
  std::ofstream(dir / "ok.yaml") << "points: {}\n";
  const FileKind small{"model", "", 1 << 20};
  e = ErrorOf([&] { ReadTextFile((dir / "big.yaml").string(), {}, small); });
  CHECK(e.where().ToString() == (dir / "big.yaml").string());
  CHECK(e.message() == "file is larger than the 1 MiB limit for model files");
  CHECK(ReadTextFile((dir / "ok.yaml").string(), {}, kKind) == "points: {}\n");
  fs::remove_all(dir);

  CHECK_NOTHROW(CheckText("m.yaml", "points: {}\n", kKind));
  e = ErrorOf([] { CheckText("m.yaml", std::string("a: 1\n\0", 6), kKind); });
  CHECK(e.message() == "is a binary file, not a YAML model (NUL byte at offset 5)");
  e = ErrorOf([] { CheckText("m.yaml", "a: 1\n# caf\xE9\n", kKind); });
  CHECK(e.where().ToString() == "m.yaml:2:6");
  for (const char* blank : {"", "\n\n", "  # just a comment\n\t\r\n# another"}) {
    e = ErrorOf([&] { CheckText("m.yaml", blank, kKind); });
    CHECK(e.where().ToString() == "m.yaml");
    CHECK(e.message() == "file is empty: a model needs 'points' or 'components'");
  }
}

TEST_CASE("yaml document: one document, syntax errors at their likely cause", "[dsl]") {
  auto parse = [](const char* text) { return Document("m.yaml", text, kKind).Parse(); };
  CHECK(parse("a: 1\n---\n")["a"].as<int>() == 1);  // an empty second document is nothing
  const testing::BadCase cases[] = {
      {"a: 1\n---\nb: 2\n", 3, 1,
       "a model file holds one YAML document, this is a second one (after '---'); split it "
       "into files and use include"},
      {"a:\n  b: 1\n\tc: 2\n", 3, 1,
       "YAML syntax error: a tab in the indentation: YAML indents with spaces only (yaml-cpp: "},
      {"points:\n  a [0, 0, 0]\n  b: [1, 0, 0]\n", 2, 3,
       "YAML syntax error: 'a [0, 0, 0]' is not 'key: value': is a ':' missing? (yaml-cpp: "},
      {"a: [1, 2\n", 0, 0, "YAML syntax error: "},
      {", a: 1\n", 1, 1, "YAML syntax error: unexpected ','"},
  };
  for (const testing::BadCase& c : cases) {
    INFO(c.text);
    const InputError e = ErrorOf([&] { parse(c.text); });
    if (c.line > 0) CHECK(e.where().ToString() == fmt::format("m.yaml:{}:{}", c.line, c.column));
    CHECK_THAT(e.message(), Catch::Matchers::StartsWith(c.message));
  }
  // Nesting beyond yaml-cpp's depth guard, refused rather than recursed into.
  const std::string deep = "a: " + std::string(5000, '[') + "\n";
  CHECK_THAT(ErrorOf([&] { parse(deep.c_str()); }).message(),
             Catch::Matchers::StartsWith("YAML syntax error: nested more than "));
}

TEST_CASE("yaml document: where nodes and a scalar's characters are", "[dsl]") {
  const Document doc("m.yaml",
                     "plain: distance(a, b) == 1 m\n"
                     "quoted: \"distance(a, b) == 2 m\"\n"
                     "single:   'a == b'\n"
                     "escaped: \"a\\u0020== b\"\n"
                     "folded: >\n  a ==\n  b\n",
                     kKind);
  const YAML::Node root = doc.Parse();
  CHECK(doc.Loc(root["quoted"]).ToString() == "m.yaml:2:9");
  const struct {
    const char* key;
    int line, column;
    bool exact;
  } expected[] = {{"plain", 1, 8, true},
                  {"quoted", 2, 10, true},  // after the quote
                  {"single", 3, 12, true},
                  {"escaped", 4, 10, false},  // its characters are not the file's
                  {"folded", 5, 9, false}};
  for (const auto& e : expected) {
    INFO(e.key);
    const TextOrigin o = doc.Origin(root[e.key]);
    CHECK(o.file == "m.yaml");
    CHECK(o.line == e.line);
    CHECK(o.column == e.column);
    CHECK(o.exact == e.exact);
  }
  // An exact origin maps offsets into the text; another stays at the scalar.
  CHECK(doc.Origin(root["plain"]).At(9).ToString() == "m.yaml:1:17");
  CHECK(doc.Origin(root["escaped"]).At(9).ToString() == "m.yaml:4:10");
}

TEST_CASE("yaml document: mappings, lists, values and keys", "[dsl]") {
  const Document doc("m.yaml",
                     "map: {label: p, sigma: 1}\n"
                     "list: [1, 2]\n"
                     "dup: {label: 1, label: 2}\n"
                     "typo: {lable: p}\n"
                     "odd: {[1]: 2}\n",
                     kKind);
  const YAML::Node root = doc.Parse();
  const std::vector<std::string> keys = {"label", "sigma", "cov"};
  const auto entries = doc.Entries(root["map"], "the point", keys);
  REQUIRE(entries.size() == 2);
  CHECK(entries[0].first.Scalar() == "label");  // in file order
  CHECK(Document::Find(entries, "sigma").as<int>() == 1);
  CHECK_FALSE(Present(Document::Find(entries, "cov")));
  CHECK(doc.Entries(root["typo"], "anything", {}).size() == 1);  // no list: any key
  CHECK(doc.Scalar(root["map"]["label"], "label") == "p");

  auto refused = [&](const std::function<void()>& f, const char* where, const char* message) {
    const InputError e = ErrorOf(f);
    CHECK(e.where().ToString() == where);
    CHECK(e.message() == message);
  };
  refused([&] { doc.Entries(root["dup"], "the point", keys); }, "m.yaml:3:17",
          "duplicate key 'label' in the point");
  refused([&] { doc.Entries(root["typo"], "the point", keys); }, "m.yaml:4:8",
          "unknown key 'lable' in the point (did you mean 'label'?); expected one of: label, "
          "sigma, cov");
  refused([&] { doc.Entries(root["odd"], "the point", {}); }, "m.yaml:5:7",
          "a key of the point must be a single value");
  refused([&] { doc.Entries(root["list"], "the point", keys); }, "m.yaml:2:7",
          "the point must be a mapping (key: value)");
  refused([&] { doc.RequireSequence(root["map"], "points"); }, "m.yaml:1:6",
          "points must be a list");
  refused([&] { doc.Scalar(root["list"], "label"); }, "m.yaml:2:7", "label must be a single value");
  CHECK_NOTHROW(doc.RequireMap(root["map"], "x"));
  CHECK_NOTHROW(doc.RequireSequence(root["list"], "x"));
}

}  // namespace
}  // namespace cfuse
