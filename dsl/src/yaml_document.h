// Reading YAML (and JSON, a subset of it) input files with located errors: the raw checks every
// file needs before a YAML parser sees its bytes (size, binary, UTF-8, empty), and a Document
// whose helpers turn shape errors into messages naming file:line:column. Internal to dsl/.
#pragma once

#include <fmt/format.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "cfuse/kernel/did_you_mean.h"
#include "cfuse/kernel/error.h"
#include "lower.h"

namespace cfuse {

// What kind of file is being read, for messages and limits.
struct FileKind {
  const char* name;        // "model", "measurement"
  const char* empty_hint;  // what an empty file lacks
  size_t max_bytes;
};

// The file's bytes; refuses a missing file, a directory and a file over kind.max_bytes.
std::string ReadTextFile(const std::string& path, const SourceLocation& where,
                         const FileKind& kind);
// Refuses binary and non-UTF-8 text (with the position of the bad byte) and empty files.
void CheckText(const std::string& file, std::string_view text, const FileKind& kind);

class Document {
 public:
  Document(std::string file, std::string text, FileKind kind)
      : file_(std::move(file)), text_(std::move(text)), kind_(kind) {}

  const std::string& file() const { return file_; }

  // The file's one document. Refuses a syntax error, nesting beyond yaml-cpp's depth guard and a
  // second document (after '---'), each at its place.
  YAML::Node Parse() const;

  SourceLocation Loc(const YAML::Node& node) const {
    const YAML::Mark m = node.Mark();
    if (m.is_null()) return SourceLocation(file_);
    return SourceLocation(file_, m.line + 1, m.column + 1);
  }

  // Where the characters of a scalar start, exactly when they appear verbatim in the file.
  TextOrigin Origin(const YAML::Node& node) const {
    TextOrigin o{file_, 0, 0, false};
    const YAML::Mark m = node.Mark();
    if (m.is_null()) return o;
    o.line = m.line + 1;
    o.column = m.column + 1;
    const std::string& s = node.Scalar();
    const size_t pos = static_cast<size_t>(m.pos);
    if (text_.compare(pos, s.size(), s) == 0) {
      o.exact = true;
    } else if (pos < text_.size() && (text_[pos] == '"' || text_[pos] == '\'') &&
               text_.compare(pos + 1, s.size(), s) == 0) {
      o.exact = true;
      o.column += 1;
    }
    return o;
  }

  [[noreturn]] void Fail(const YAML::Node& node, const std::string& message) const {
    throw InputError(Loc(node), message);
  }

  void RequireMap(const YAML::Node& node, const std::string& what) const {
    if (!node.IsMap()) Fail(node, fmt::format("{} must be a mapping (key: value)", what));
  }
  void RequireSequence(const YAML::Node& node, const std::string& what) const {
    if (!node.IsSequence()) Fail(node, fmt::format("{} must be a list", what));
  }
  std::string Scalar(const YAML::Node& node, const std::string& what) const {
    if (!node.IsScalar()) Fail(node, fmt::format("{} must be a single value", what));
    return node.Scalar();
  }

  // Entries of a mapping in file order, refusing duplicate keys and keys not in `allowed`
  // (when given).
  std::vector<std::pair<YAML::Node, YAML::Node>> Entries(
      const YAML::Node& map, const std::string& what,
      const std::vector<std::string>& allowed) const {
    RequireMap(map, what);
    std::vector<std::pair<YAML::Node, YAML::Node>> out;
    std::set<std::string> seen;
    for (auto it = map.begin(); it != map.end(); ++it) {
      const YAML::Node key = it->first;
      const std::string k = Scalar(key, fmt::format("a key of {}", what));
      if (!seen.insert(k).second) Fail(key, fmt::format("duplicate key '{}' in {}", k, what));
      if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), k) == allowed.end()) {
        const std::string s = Suggest(k, allowed);
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
        Fail(key, fmt::format("unknown key '{}' in {}{}; expected one of: {}", k, what,
                              s.empty() ? "" : fmt::format(" (did you mean '{}'?)", s), list));
      }
      out.emplace_back(key, it->second);
    }
    return out;
  }

  static YAML::Node Find(const std::vector<std::pair<YAML::Node, YAML::Node>>& entries,
                         const std::string& key) {
    for (const auto& [k, v] : entries) {
      if (k.Scalar() == key) return v;
    }
    return YAML::Node(YAML::NodeType::Undefined);
  }

 private:
  std::string file_;
  std::string text_;
  FileKind kind_;
};

inline bool Present(const YAML::Node& n) { return n.IsDefined(); }

}  // namespace cfuse
