// The CAO reader, shared by its three files (internal to importers/; not installed): the rows of
// tokens and their checks (cao_tokens.cpp), the sections (cao_sections.cpp), and the loads and
// the model built from what was read (cao.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_set>
#include <utility>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/error.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse::internal {

// [A-Za-z_][A-Za-z0-9_]*: other characters become '_', a leading digit gets '_' before it, and
// the DSL's reserved words (model_builder.h) a '_' after.
std::string Identifier(std::string_view name);

bool IsBlank(char c);

bool StartsWith(std::string_view s, std::string_view prefix);

// A piece of input quoted in a message, cut short if long.
std::string Shown(std::string_view s);

// The length of the decimal number at the start of `s`, 0 if none:
// [+-]? (digits [. digits?] | . digits) ([eE] [+-]? digits)?
size_t NumberLength(std::string_view s);

// The value of a lexeme NumberLength() accepted; nullopt if beyond double's range.
std::optional<double> NumberValue(std::string_view lexeme);

// A non-negative integer written with digits only. Once it reaches 10^17 it is returned as it
// stands: every limit is far below, and the next digit could overflow 2^63 from 10^18 on.
std::optional<int64_t> NonNegativeInteger(std::string_view s);

struct Token {
  std::string_view text;
  int column = 0;  // 1-based
  int end() const { return column + static_cast<int>(text.size()); }
};

// A line with something on it besides blanks and comments.
struct Row {
  int line = 0;  // 1-based
  std::string_view raw;
  std::vector<Token> tokens;
};

// One of the sections after the header and the loads (cao_sections.cpp has them in file order).
struct Section {
  const char* name;  // in messages: "the number of 3D points", "the 3D points section"
  const char* rows;  // what one row is
};

// What the files read so far hold, in the including file's frame, with final names.
struct Part {
  std::vector<FeaturePoint> points;
  std::vector<Edge> edges;
  std::vector<Face> faces;
};

// Shared by a file and the files it loads.
struct LoadContext {
  std::vector<std::string> open_canonical;  // the files being read, the top one first
  std::vector<std::string> open_display;
  int files_read = 1;
};

class CaoReader {
 public:
  CaoReader(LoadContext* context, std::string file, std::string_view text, std::string base_dir)
      : context_(context), file_(std::move(file)), base_dir_(std::move(base_dir)) {
    Split(text);
  }

  Part Read();

 private:
  // This file's own lines and faces as read, before they are named.
  struct LineRow {
    int a = 0, b = 0;  // point indices in part_
    std::optional<std::string> name;
    SourceLocation where;
    bool duplicate = false;  // the same two points as an earlier line
  };
  struct FaceRow {
    std::vector<int> loop;  // point indices in part_
    std::optional<std::string> name;
    SourceLocation where;
  };

  [[noreturn]] void Fail(int line, int column, const std::string& message) const {
    throw InputError(SourceLocation(file_, line, column), message);
  }
  [[noreturn]] void Fail(const Row& row, const Token& token, const std::string& message) const {
    Fail(row.line, token.column, message);
  }
  SourceLocation Where(const Row& row) const {
    return SourceLocation(file_, row.line, row.tokens[0].column);
  }

  // The rows and the tokens in them (cao_tokens.cpp).
  void Split(std::string_view text);
  const Row* Peek() const { return next_ < rows_.size() ? &rows_[next_] : nullptr; }
  const Row* Next() { return next_ < rows_.size() ? &rows_[next_++] : nullptr; }
  const Row& SectionRow(const Section& s, int expected, int found);
  void NothingMore(const Row& row, size_t used, const std::string& after) const;
  int64_t Count(const Row& row, const Section& s, int64_t limit) const;
  double Number(const Row& row, const Token& t) const;
  int Index(const Row& row, const Token& t, const char* what, int size) const;
  std::optional<std::string> Parameters(const Row& row, size_t first,
                                        const std::string& after) const;

  // Loads (cao.cpp).
  void ReadLoad(const Row& row);
  void Merge(Part loaded, const std::string& display, const Rigid3d& including_from_loaded,
             const SourceLocation& where);

  // The sections (cao_sections.cpp).
  void RequireModelSize(const SourceLocation& where, const std::string& context) const;
  void ReadPoints(bool loaded_some);
  int OwnPoints() const { return static_cast<int>(part_.points.size()) - first_point_; }
  void ReadLines();
  std::vector<int> Walk(const Row& row, const std::vector<int>& face_lines) const;
  void CheckArea(const Row& row, const std::vector<int>& loop) const;
  std::vector<Token> FaceIndices(const Row& row, const char* what) const;
  void ReadFacesFromLines();
  void ReadFacesFromPoints();

  LoadContext* context_;
  std::string file_;
  std::string base_dir_;
  std::vector<Row> rows_;
  size_t next_ = 0;
  int end_line_ = 1, end_column_ = 1;  // just past the last character

  Part part_;
  int first_point_ = 0;  // this file's point 0 in part_ (after the loaded ones)
  std::vector<LineRow> lines_;
  std::vector<FaceRow> faces_;  // from lines, then from points
  std::unordered_set<uint64_t> own_edges_;
  std::unordered_set<std::string> point_names_, edge_names_, face_names_, prefixes_;
};

}  // namespace cfuse::internal
