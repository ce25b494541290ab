#include "yaml_document.h"

#include <yaml-cpp/eventhandler.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <vector>

namespace cfuse {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Raw file checks: everything that must be refused before YAML sees the bytes.

std::string ReadTextFile(const std::string& path, const SourceLocation& where,
                         const FileKind& kind) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) {
    throw InputError(where.known() ? where : SourceLocation(path),
                     where.known() ? fmt::format("cannot open '{}': no such file", path)
                                   : "cannot open: no such file");
  }
  if (fs::is_directory(status)) {
    throw InputError(SourceLocation(path), fmt::format("is a directory, not a {} file", kind.name));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(SourceLocation(path), fmt::format("cannot open: {}", std::strerror(errno)));
  std::string text;
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    text.append(buffer, static_cast<size_t>(in.gcount()));
    if (text.size() > kind.max_bytes) {
      throw InputError(SourceLocation(path), fmt::format("file is larger than the {} MiB limit for "
                                                         "{} files",
                                                         kind.max_bytes >> 20, kind.name));
    }
  }
  return text;
}

void CheckText(const std::string& file, std::string_view text, const FileKind& kind) {
  RequireText(file, text, fmt::format("YAML {}", kind.name));
  bool blank = true;
  std::istringstream lines{std::string(text)};
  for (std::string line; std::getline(lines, line);) {
    const size_t first = line.find_first_not_of(" \t\r");
    if (first != std::string::npos && line[first] != '#') blank = false;
  }
  if (blank)
    throw InputError(SourceLocation(file), fmt::format("file is empty: {}", kind.empty_hint));
}

// ---------------------------------------------------------------------------------------------
// A YAML document with the helpers that turn shape errors into located messages.

namespace {

// Where each document of the stream starts, from yaml-cpp's events (no nodes are built).
class DocumentStarts : public YAML::EventHandler {
 public:
  std::vector<YAML::Mark> starts;  // of each document's first node
  std::vector<bool> has_content;   // a document that is more than a null
  void OnDocumentStart(const YAML::Mark&) override { first_ = true; }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t) override { Node(mark, false); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { Node(mark, true); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                const std::string&) override {
    Node(mark, true);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {
    Node(mark, true);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {
    Node(mark, true);
  }
  void OnMapEnd() override {}

 private:
  void Node(const YAML::Mark& mark, bool content) {
    if (!first_) return;
    first_ = false;
    starts.push_back(mark);
    has_content.push_back(content);
  }
  bool first_ = false;
};

// yaml-cpp stops where its parser gives up, often a line or two after the mistake. Two
// mistakes it reports so: a tab in the indentation, and a key missing its ':'. The line that
// shows one, at or before `error_line` (0-based), as (line, column, message), 1-based.
struct Cause {
  int line, column;
  std::string message;
};

std::optional<Cause> LikelyCause(const std::string& text, int error_line) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
  }
  const int last = std::min(error_line, static_cast<int>(lines.size()) - 1);
  auto indent = [&](int i) { return static_cast<int>(lines[i].find_first_not_of(" \t")); };
  auto blank = [&](int i) {
    const size_t k = lines[i].find_first_not_of(" \t");
    return k == std::string::npos || lines[i][k] == '#';
  };
  for (int i = 0; i <= last; ++i) {
    if (blank(i)) continue;
    const size_t tab = lines[i].find('\t');
    if (tab != std::string::npos && static_cast<int>(tab) < indent(i)) {
      return Cause{i + 1, static_cast<int>(tab) + 1,
                   "a tab in the indentation: YAML indents with spaces only"};
    }
  }
  auto is_key = [&](int i) {
    const std::string& l = lines[i];
    const size_t colon = l.find(':');
    return colon != std::string::npos && (colon + 1 == l.size() || l[colon + 1] == ' ');
  };
  for (int i = std::max(0, last - 2); i <= last; ++i) {
    if (blank(i) || is_key(i)) continue;
    const char first = lines[i][indent(i)];
    if (first == '-' || first == '[' || first == '{' || first == '"' || first == '\'' ||
        first == ']' || first == '}') {
      continue;
    }
    // In a block mapping: the next line at this indentation is a key.
    int next = i + 1;
    while (next < static_cast<int>(lines.size()) && blank(next)) ++next;
    if (next >= static_cast<int>(lines.size()) || indent(next) != indent(i) || !is_key(next)) {
      continue;
    }
    return Cause{i + 1, indent(i) + 1,
                 fmt::format("'{}' is not 'key: value': is a ':' missing?",
                             lines[i].substr(indent(i)))};
  }
  return std::nullopt;
}

}  // namespace

YAML::Node Document::Parse() const {
  const auto syntax_error = [&](const YAML::Mark& mark, const std::string& message) {
    return InputError(SourceLocation(file_, mark.line + 1, mark.column + 1),
                      fmt::format("YAML syntax error: {}", message));
  };
  try {
    // yaml-cpp 0.7's LoadAll loops forever, allocating, on a token no rule takes at the top of a
    // document (a ',' outside brackets: yaml-cpp issue 1040, fixed upstream after 0.7 by PR
    // 1319): the parser reports an empty document there again and again without moving. So the
    // documents are walked here first, and one that starts where the last one did is that token.
    std::istringstream stream(text_);
    YAML::Parser parser(stream);
    DocumentStarts documents;
    while (parser.HandleNextDocument(documents)) {
      const size_t n = documents.starts.size();
      if (n >= 2 && documents.starts[n - 1].pos == documents.starts[n - 2].pos) {
        const YAML::Mark mark = documents.starts[n - 1];
        const size_t pos = static_cast<size_t>(mark.pos);
        throw syntax_error(mark, pos < text_.size() ? fmt::format("unexpected '{}'", text_[pos])
                                                    : std::string("unexpected end of the file"));
      }
      // A second document after '---' would otherwise be dropped without a word.
      if (n >= 2 && documents.has_content[n - 1]) {
        throw InputError(SourceLocation(file_, documents.starts[n - 1].line + 1,
                                        documents.starts[n - 1].column + 1),
                         "a " + std::string(kind_.name) +
                             " file holds one YAML document, this is a second one (after "
                             "'---'); split it into files and use include");
      }
    }
    return YAML::Load(text_);
  } catch (const YAML::DeepRecursion& e) {
    // yaml-cpp's own message for this is "bad file".
    throw syntax_error(e.mark, fmt::format("nested more than {} levels deep", e.depth() - 1));
  } catch (const YAML::ParserException& e) {
    if (const auto cause = LikelyCause(text_, e.mark.line)) {
      throw InputError(SourceLocation(file_, cause->line, cause->column),
                       fmt::format("YAML syntax error: {} (yaml-cpp: {} at line {})",
                                   cause->message, e.msg, e.mark.line + 1));
    }
    throw syntax_error(e.mark, e.msg);
  }
}

}  // namespace cfuse
