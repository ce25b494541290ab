// Keeps docs/dsl.md honest: every ```yaml block in it must load, every ```yaml error block must
// be refused with the message quoted on the `> ` line after it, and every construct of the
// language must appear in at least one loading example.
#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/kernel/error.h"
#include "test_util.h"

namespace {

struct DocBlock {
  int line = 0;        // 1-based line of the opening fence in docs/dsl.md
  bool error = false;  // ```yaml error
  std::string text;    // the block's content
  std::string quote;   // error blocks: the `> ` lines after the block, joined by spaces
};

struct Doc {
  std::vector<DocBlock> blocks;
  std::vector<std::string> problems;  // malformed fences or quotes, with their line
};

std::string Trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

Doc ReadDoc() {
  Doc doc;
  const std::string path = cfuse::testing::SourcePath("docs/dsl.md");
  std::ifstream in(path);
  if (!in) {
    doc.problems.push_back("cannot open " + path);
    return doc;
  }
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
  }
  const int n = static_cast<int>(lines.size());
  for (int i = 0; i < n; ++i) {
    const std::string trimmed = Trim(lines[i]);
    if (trimmed.rfind("```", 0) != 0) continue;
    const std::string info = Trim(trimmed.substr(3));
    const bool tested = info == "yaml" || info == "yaml error";
    if (info.rfind("yaml", 0) == 0 && !tested) {
      doc.problems.push_back("line " + std::to_string(i + 1) + ": unknown yaml fence '" + trimmed +
                             "' (use ```yaml or ```yaml error)");
    }
    if (tested && lines[i] != trimmed) {
      doc.problems.push_back("line " + std::to_string(i + 1) +
                             ": tested fences must start at column 1");
    }
    DocBlock block;
    block.line = i + 1;
    block.error = info == "yaml error";
    int j = i + 1;
    for (; j < n && Trim(lines[j]) != "```"; ++j) block.text += lines[j] + "\n";
    if (j >= n) {
      doc.problems.push_back("line " + std::to_string(i + 1) + ": unclosed code fence");
      break;
    }
    i = j;  // the closing fence
    if (!tested) continue;
    if (block.error) {
      int k = j + 1;
      while (k < n && Trim(lines[k]).empty()) ++k;
      while (k < n && lines[k].rfind(">", 0) == 0) {
        const std::string part = Trim(lines[k].substr(1));
        if (!part.empty()) block.quote += (block.quote.empty() ? "" : " ") + part;
        ++k;
      }
      if (block.quote.empty()) {
        doc.problems.push_back("line " + std::to_string(block.line) +
                               ": a yaml error block must be followed by a '> ' line quoting "
                               "the message");
      }
    }
    doc.blocks.push_back(std::move(block));
  }
  return doc;
}

const Doc& TheDoc() {
  static const Doc doc = ReadDoc();
  return doc;
}

cfuse::ConstraintGraph Load(const DocBlock& b) {
  return cfuse::LoadModelFromString(b.text, "model.yaml",
                                         cfuse::testing::SourcePath("examples"));
}

}  // namespace

TEST_CASE("docs: dsl.md is well formed and has enough examples") {
  const Doc& doc = TheDoc();
  for (const std::string& p : doc.problems) FAIL_CHECK(p);
  int loading = 0, refused = 0;
  for (const DocBlock& b : doc.blocks) (b.error ? refused : loading) += 1;
  INFO("yaml blocks: " << loading << ", yaml error blocks: " << refused);
  CHECK(loading + refused >= 15);
  CHECK(loading >= 1);
  CHECK(refused >= 1);
}

TEST_CASE("docs: every yaml example in dsl.md loads") {
  for (const DocBlock& b : TheDoc().blocks) {
    if (b.error) continue;
    INFO("docs/dsl.md:" << b.line << ": ```yaml block");
    try {
      const cfuse::ConstraintGraph graph = Load(b);
      CHECK(!graph.components.empty());
    } catch (const cfuse::InputError& e) {
      FAIL_CHECK("refused: " << e.what());
    } catch (const std::exception& e) {
      FAIL_CHECK("unexpected exception: " << e.what());
    }
  }
}

TEST_CASE("docs: every yaml error example in dsl.md is refused with the quoted message") {
  for (const DocBlock& b : TheDoc().blocks) {
    if (!b.error) continue;
    INFO("docs/dsl.md:" << b.line << ": ```yaml error block, quoted: " << b.quote);
    try {
      Load(b);
      FAIL_CHECK("the model loaded, but the doc says it is refused");
    } catch (const cfuse::InputError& e) {
      INFO("actual: " << e.what());
      CHECK(b.quote.find(e.message()) != std::string::npos);
      // When the error is in the example itself, the quote must give the whole line as the
      // tool prints it, position included.
      if (e.where().file == "model.yaml") CHECK(b.quote.find(e.what()) != std::string::npos);
    } catch (const std::exception& e) {
      FAIL_CHECK("unexpected exception (not an InputError): " << e.what());
    }
  }
}

TEST_CASE("docs: every construct of the language appears in a loading example") {
  const std::vector<std::string> keywords = {
      // relations
      "==", "<=", ">=", " in [", "parallel(", "perpendicular(", "coplanar(", "collinear(", "rigid(",
      // functions
      "distance(", "angle(", "angle_between(", "dot(", "cross(", "norm(",
      // expressions
      "nominal", " mm", " cm", " deg", " rad", "name:", "expr:",
      // model structure
      "units:", "components:", "points:", "pose:", "xyz:", "rpy:", "quaternion:", "edges:",
      "faces:", "joints:", "fixed:", "constraints:", "include:", "prefix:", "file:",
      // joints
      "revolute", "continuous", "prismatic", "spherical", "type: fixed",
      "origin:", "axis:", "limits:", "position:",
      // fixed entries
      "component:", "point:", "fix: position", "fix: orientation", "at:"};
  const Doc& doc = TheDoc();
  for (const std::string& k : keywords) {
    bool found = false;
    for (const DocBlock& b : doc.blocks) {
      if (!b.error && b.text.find(k) != std::string::npos) found = true;
    }
    INFO("construct: '" << k << "'");
    CHECK(found);
  }
}
