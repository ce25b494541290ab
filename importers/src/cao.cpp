#include "cfuse/importers/cao.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "cfuse/constraints/model_builder.h"
#include "cfuse/kernel/so3.h"
#include "read_file.h"

namespace cfuse::importers {
namespace {

namespace fs = std::filesystem;

// [A-Za-z_][A-Za-z0-9_]*: other characters become '_', a leading digit gets '_' before it, and
// the DSL's reserved words (model_builder.h) a '_' after.
std::string Identifier(std::string_view name) {
  std::string out(name);
  for (char& c : out) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') c = '_';
  }
  if (out.empty() || std::isdigit(static_cast<unsigned char>(out[0]))) out = "_" + out;
  if (out == "in" || out == "nominal") out += "_";
  return out;
}

bool IsBlank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

bool StartsWith(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}

// A piece of input quoted in a message, cut short if long.
std::string Shown(std::string_view s) {
  return s.size() <= 40 ? std::string(s) : std::string(s.substr(0, 37)) + "...";
}

// The length of the decimal number at the start of `s`, 0 if none:
// [+-]? (digits [. digits?] | . digits) ([eE] [+-]? digits)?
size_t NumberLength(std::string_view s) {
  size_t i = 0;
  auto digits = [&] {
    const size_t start = i;
    while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i;
    return i > start;
  };
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  const bool whole = digits();
  bool fraction = false;
  if (i < s.size() && s[i] == '.') {
    ++i;
    fraction = digits();
  }
  if (!whole && !fraction) return 0;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    const size_t mark = i++;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    if (!digits()) i = mark;
  }
  return i;
}

// The value of a lexeme NumberLength() accepted; nullopt if beyond double's range.
std::optional<double> NumberValue(std::string_view lexeme) {
  if (!lexeme.empty() && lexeme[0] == '+') lexeme.remove_prefix(1);
  double value = 0;
  const auto [end, ec] = std::from_chars(lexeme.data(), lexeme.data() + lexeme.size(), value);
  if (ec != std::errc() || end != lexeme.data() + lexeme.size() || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

// A non-negative integer written with digits only. Once it reaches 10^17 it is returned as it
// stands: every limit is far below, and the next digit could overflow 2^63 from 10^18 on.
std::optional<int64_t> NonNegativeInteger(std::string_view s) {
  if (s.empty() || !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return std::nullopt;
  }
  int64_t value = 0;
  for (char c : s) {
    value = value * 10 + (c - '0');
    // Below 10^18 before the next digit: value * 10 + 9 stays below 2^63.
    if (value >= 100000000000000000) return value;
  }
  return value;
}

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

// The sections after the header and the loads, in file order.
struct Section {
  const char* name;  // in messages: "the number of 3D points", "the 3D points section"
  const char* rows;  // what one row is
};
constexpr Section kPoints{"3D points", "points"};
constexpr Section kLines{"3D lines", "lines"};
constexpr Section kFacesFromLines{"faces from 3D lines", "faces"};
constexpr Section kFacesFromPoints{"faces from 3D points", "faces"};
constexpr Section kCylinders{"3D cylinders", "cylinders"};
constexpr Section kCircles{"3D circles", "circles"};

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

void RequireText(std::string_view text, const std::string& file) {
  if (text.find('\0') != std::string_view::npos) {
    throw InputError(SourceLocation(file), "not a CAO file: it holds binary data");
  }
  // Names go into model files and JSON, which are UTF-8.
  cfuse::RequireText(file, text, "CAO file");
}

std::string ReadCaoFile(const std::string& path, const SourceLocation& included_from) {
  return ReadImportedFile(path, included_from, "CAO", kMaxCaoFileBytes);
}

class CaoReader {
 public:
  CaoReader(LoadContext* context, std::string file, std::string_view text, std::string base_dir)
      : context_(context), file_(std::move(file)), base_dir_(std::move(base_dir)) {
    Split(text);
  }

  Part Read() {
    const Row* header = Next();
    if (!header) Fail(1, 1, "not a CAO file: it is empty; expected the header 'V1'");
    const Token& v = header->tokens[0];
    if (v.text != "V1") {
      if (v.text.size() > 1 && v.text[0] == 'V' && NonNegativeInteger(v.text.substr(1))) {
        Fail(*header, v,
             fmt::format("unsupported CAO version '{}': cfuse reads version 1 ('V1')",
                         Shown(v.text)));
      }
      Fail(*header, v,
           fmt::format("not a CAO file: expected the header 'V1', found '{}'", Shown(v.text)));
    }
    NothingMore(*header, 1, "after the header 'V1'");

    int loads = 0;
    while (Peek() && StartsWith(Peek()->tokens[0].text, "load")) {
      ReadLoad(*Next());
      ++loads;
    }
    if (!Peek() && loads > 0) return std::move(part_);  // an assembly of loaded parts only

    ReadPoints(loads > 0);
    ReadLines();
    ReadFacesFromLines();
    ReadFacesFromPoints();
    // Files written before ViSP knew cylinders and circles end here.
    for (const Section* s : {&kCylinders, &kCircles}) {
      const Row* row = Next();
      if (!row) break;
      if (Count(*row, *s, std::numeric_limits<int64_t>::max()) > 0) {
        Fail(*row, row->tokens[0],
             fmt::format("{} are not supported: this file declares {}; cfuse reads points, lines "
                         "and faces (set the count to 0, or describe the shape with points and "
                         "faces)",
                         s->rows, Shown(row->tokens[0].text)));
      }
    }
    if (const Row* row = Next()) {
      Fail(*row, row->tokens[0],
           fmt::format("unexpected '{}' after the last section ({})", Shown(row->tokens[0].text),
                       kCircles.name));
    }
    return std::move(part_);
  }

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

  // Lines into rows of tokens. A token starting with '#' or "//" starts a comment, to the end of
  // the line; a double quote runs to the next one, blanks included.
  void Split(std::string_view text) {
    if (StartsWith(text, "\xEF\xBB\xBF")) text.remove_prefix(3);  // a UTF-8 byte order mark
    int line = 0;
    size_t start = 0;
    while (start <= text.size()) {
      const size_t newline = text.find('\n', start);
      const size_t stop = newline == std::string_view::npos ? text.size() : newline;
      std::string_view raw = text.substr(start, stop - start);
      ++line;
      Row row;
      row.line = line;
      row.raw = raw;
      size_t i = 0;
      while (i < raw.size()) {
        if (IsBlank(raw[i])) {
          ++i;
          continue;
        }
        if (raw[i] == '#' || StartsWith(raw.substr(i), "//")) break;
        const size_t begin = i;
        while (i < raw.size() && !IsBlank(raw[i])) {
          if (raw[i] == '"') {
            const size_t close = raw.find('"', i + 1);
            if (close == std::string_view::npos) {
              Fail(line, static_cast<int>(i) + 1, "unterminated quoted string: no closing '\"'");
            }
            i = close + 1;
          } else {
            ++i;
          }
        }
        row.tokens.push_back({raw.substr(begin, i - begin), static_cast<int>(begin) + 1});
      }
      if (!row.tokens.empty()) rows_.push_back(std::move(row));
      if (newline == std::string_view::npos) {
        end_line_ = line;
        end_column_ = static_cast<int>(raw.size()) + 1;
        break;
      }
      start = newline + 1;
    }
  }

  const Row* Peek() const { return next_ < rows_.size() ? &rows_[next_] : nullptr; }
  const Row* Next() { return next_ < rows_.size() ? &rows_[next_++] : nullptr; }

  // The next row of a section, or an error at the end of the file.
  const Row& SectionRow(const Section& s, int expected, int found) {
    const Row* row = Next();
    if (!row) {
      Fail(end_line_, end_column_,
           fmt::format("the file ends in the {} section: {} {} expected, {} found", s.name,
                       expected, s.rows, found));
    }
    return *row;
  }

  // Refuses tokens after the first `used` of a row.
  void NothingMore(const Row& row, size_t used, const std::string& after) const {
    if (row.tokens.size() > used) {
      const Token& t = row.tokens[used];
      Fail(row, t, fmt::format("unexpected '{}' {}", Shown(t.text), after));
    }
  }

  // A section's count: the row's only token.
  int64_t Count(const Row& row, const Section& s, int64_t limit) const {
    const Token& t = row.tokens[0];
    if (StartsWith(t.text, "load")) {
      Fail(row, t, "load(...) must come right after the header 'V1', before the 3D points");
    }
    const std::optional<int64_t> n = NonNegativeInteger(t.text);
    if (!n) {
      Fail(row, t,
           fmt::format("the number of {} must be a non-negative integer, found '{}'", s.name,
                       Shown(t.text)));
    }
    if (*n > limit) {
      Fail(row, t,
           fmt::format("the number of {}, {}, exceeds the limit of {}", s.name, Shown(t.text),
                       limit));
    }
    NothingMore(row, 1, fmt::format("after the number of {}", s.name));
    return *n;
  }

  double Number(const Row& row, const Token& t) const {
    if (NumberLength(t.text) != t.text.size()) {
      Fail(row, t, fmt::format("expected a number, found '{}'", Shown(t.text)));
    }
    const std::optional<double> v = NumberValue(t.text);
    if (!v) Fail(row, t, fmt::format("number '{}' is out of range", Shown(t.text)));
    return *v;
  }

  // An index into a table of `size` entries (`what`: "point", "line").
  int Index(const Row& row, const Token& t, const char* what, int size) const {
    const std::optional<int64_t> i = NonNegativeInteger(t.text);
    if (!i) {
      Fail(row, t,
           fmt::format("a {} index must be a non-negative integer, found '{}'", what,
                       Shown(t.text)));
    }
    if (*i >= size) {
      Fail(row, t,
           size == 0
               ? fmt::format("{} index {} is out of range: the file has no {}s", what,
                             Shown(t.text), what)
               : fmt::format("{} index {} is out of range: the file has {} {}{} (0 to {})", what,
                             Shown(t.text), size, what, size == 1 ? "" : "s", size - 1));
    }
    return static_cast<int>(*i);
  }

  // ViSP's `key=value` parameters after a row's values, from token `first` on. The
  // level-of-detail ones are checked and ignored; returns the name, if given.
  std::optional<std::string> Parameters(const Row& row, size_t first,
                                        const std::string& after) const {
    static const char* const kKeys[] = {"name", "useLod", "minLineLengthThreshold",
                                        "minPolygonAreaThreshold"};
    std::optional<std::string> name;
    std::unordered_set<std::string_view> seen;
    for (size_t k = first; k < row.tokens.size(); ++k) {
      const Token& t = row.tokens[k];
      const size_t eq = t.text.find('=');
      if (eq == std::string_view::npos) {
        Fail(row, t,
             fmt::format("unexpected '{}' {}: only name=, useLod=, minLineLengthThreshold= and "
                         "minPolygonAreaThreshold= may follow",
                         Shown(t.text), after));
      }
      const std::string_view key = t.text.substr(0, eq);
      std::string_view value = t.text.substr(eq + 1);
      if (std::none_of(std::begin(kKeys), std::end(kKeys),
                       [&](const char* known) { return key == known; })) {
        Fail(row, t,
             fmt::format("unknown parameter '{}': the parameters are name, useLod, "
                         "minLineLengthThreshold and minPolygonAreaThreshold",
                         Shown(key)));
      }
      if (!seen.insert(key).second) {
        Fail(row, t, fmt::format("parameter '{}' given twice", key));
      }
      if (StartsWith(value, "\"")) {
        if (value.size() < 2 || value.back() != '"' || value.find('"', 1) != value.size() - 1) {
          Fail(row, t, fmt::format("unexpected characters after the quoted value of '{}'", key));
        }
        value = value.substr(1, value.size() - 2);
      }
      if (key == "name") {
        if (value.empty()) Fail(row, t, "the name is empty");
        name = Identifier(value);
      } else if (key == "useLod") {
        std::string lower(value);
        for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        if (lower != "true" && lower != "false" && lower != "1" && lower != "0") {
          Fail(row, t, fmt::format("useLod is true or false, found '{}'", Shown(value)));
        }
      } else if (NumberLength(value) != value.size() || value.empty() || !NumberValue(value)) {
        Fail(row, t, fmt::format("{} is a number, found '{}'", key, Shown(value)));
      }
    }
    return name;
  }

  // `load("FILE", t=[x; y; z], tu=[x; y; z])`: ViSP separates the numbers with ';' (',' is
  // accepted too) and lets each of tu's end with `deg` or `rad`.
  void ReadLoad(const Row& row) {
    const std::string_view s = row.raw;
    size_t i = static_cast<size_t>(row.tokens[0].column - 1) + 4;  // after "load"
    auto fail = [&](size_t at, const std::string& message) {
      Fail(row.line, static_cast<int>(at) + 1, message);
    };
    auto skip = [&] {
      while (i < s.size() && IsBlank(s[i])) ++i;
    };
    auto found = [&]() -> std::string {
      if (i >= s.size()) return "the end of the line";
      size_t stop = i + 1;
      while (stop < s.size() && !IsBlank(s[stop])) ++stop;
      return "'" + Shown(s.substr(i, stop - i)) + "'";
    };
    skip();
    if (i >= s.size() || s[i] != '(') {
      fail(i, fmt::format("expected '(' after 'load', found {}: load(\"FILE.cao\", t=[x; y; z], "
                          "tu=[x; y; z])",
                          found()));
    }
    ++i;
    skip();
    if (i >= s.size() || s[i] != '"') {
      fail(i, fmt::format("expected the file name in double quotes, found {}", found()));
    }
    const size_t path_at = i;
    const size_t close = s.find('"', i + 1);
    if (close == std::string_view::npos) fail(i, "unterminated file name: no closing '\"'");
    const std::string relative(s.substr(i + 1, close - i - 1));
    if (relative.empty()) fail(i, "the file name is empty");
    i = close + 1;
    skip();

    Eigen::Vector3d t = Eigen::Vector3d::Zero(), tu = Eigen::Vector3d::Zero();
    std::unordered_set<std::string> seen;
    while (i < s.size() && s[i] == ',') {
      ++i;
      skip();
      const size_t key_at = i;
      while (i < s.size() && std::isalpha(static_cast<unsigned char>(s[i]))) ++i;
      const std::string key(s.substr(key_at, i - key_at));
      if (key != "t" && key != "tu") {
        i = key_at;
        fail(key_at, fmt::format("unknown load parameter {}: load takes t=[x; y; z] (metres) "
                                 "and tu=[x; y; z] (a rotation vector, radians or deg)",
                                 key.empty() ? found() : "'" + key + "'"));
      }
      if (!seen.insert(key).second) fail(key_at, fmt::format("'{}' given twice", key));
      skip();
      if (i >= s.size() || s[i] != '=') fail(i, fmt::format("expected '=' after '{}'", key));
      ++i;
      skip();
      if (i >= s.size() || s[i] != '[') fail(i, fmt::format("expected '[' after '{}='", key));
      ++i;
      Eigen::Vector3d& v = key == "t" ? t : tu;
      for (int k = 0; k < 3; ++k) {
        skip();
        const size_t length = NumberLength(s.substr(i));
        if (length == 0) {
          fail(i, fmt::format("expected a number in {}=[...], found {}", key, found()));
        }
        const std::optional<double> value = NumberValue(s.substr(i, length));
        if (!value) fail(i, fmt::format("number '{}' is out of range", s.substr(i, length)));
        v[k] = *value;
        i += length;
        skip();
        for (const char* unit : {"deg", "rad"}) {
          if (!StartsWith(s.substr(i), unit)) continue;
          if (key == "t") fail(i, "t is in metres: it takes no unit");
          if (unit[0] == 'd') v[k] *= M_PI / 180.0;
          i += 3;
          skip();
        }
        if (k < 2) {
          if (i >= s.size() || (s[i] != ';' && s[i] != ',')) {
            fail(i,
                 fmt::format("{}=[...] needs 3 numbers separated by ';', found {}", key, found()));
          }
          ++i;
        }
      }
      if (i >= s.size() || s[i] != ']') {
        fail(i,
             fmt::format("expected ']' after the 3 numbers of {}=[...], found {}", key, found()));
      }
      // More than a whole turn is no rotation a writer means, and a norm that overflows none at
      // all (Exp would give NaN points).
      if (key == "tu" && !(tu.norm() <= 2 * M_PI + 1e-9)) {
        fail(key_at, fmt::format("tu=[...] turns by {:g} rad, more than a whole turn (2π): a "
                                 "rotation vector's angle is at most 2π ('deg' marks degrees)",
                                 tu.norm()));
      }
      ++i;
      skip();
    }
    if (i >= s.size() || s[i] != ')') {
      fail(i, fmt::format("expected ',' or ')' in load(...), found {}", found()));
    }
    ++i;
    skip();
    if (i < s.size() && s[i] != '#' && !StartsWith(s.substr(i), "//")) {
      fail(i, fmt::format("unexpected {} after load(...)", found()));
    }

    const SourceLocation where(file_, row.line, static_cast<int>(path_at) + 1);
    const std::string display = fs::path(relative).is_absolute()
                                    ? relative
                                    : (fs::path(base_dir_) / relative).lexically_normal().string();
    if (static_cast<int>(context_->open_canonical.size()) >= kMaxCaoLoadDepth) {
      throw InputError(where, fmt::format("loads nest more than {} files deep", kMaxCaoLoadDepth));
    }
    if (++context_->files_read > kMaxCaoFilesRead) {
      throw InputError(where,
                       fmt::format("the model loads more than {} files in all", kMaxCaoFilesRead));
    }
    std::error_code ec;
    const std::string canonical = fs::weakly_canonical(display, ec).string();
    for (size_t k = 0; k < context_->open_canonical.size(); ++k) {
      if (context_->open_canonical[k] != canonical) continue;
      std::string chain;
      for (size_t j = k; j < context_->open_display.size(); ++j) {
        chain += context_->open_display[j] + " -> ";
      }
      throw InputError(where, fmt::format("load cycle: {}{}", chain, display));
    }
    const std::string text = ReadCaoFile(display, where);
    context_->open_canonical.push_back(canonical);
    context_->open_display.push_back(display);
    Part loaded =
        CaoReader(context_, display, text, fs::path(display).parent_path().string()).Read();
    context_->open_canonical.pop_back();
    context_->open_display.pop_back();
    Merge(std::move(loaded), display, Rigid3d(Eigen::Matrix3d(ExpSO3<double>(tu)), t), where);
  }

  // Adds a loaded file's part, mapped into this file's frame, its names prefixed.
  void Merge(Part loaded, const std::string& display, const Rigid3d& including_from_loaded,
             const SourceLocation& where) {
    const std::string stem = fs::path(display).stem().string();
    std::string prefix = Identifier(stem) + "_";
    for (int k = 2; !prefixes_.insert(prefix).second; ++k) {
      prefix = fmt::format("{}_{}_", Identifier(stem), k);
    }
    auto clash = [&](const char* what, const std::string& name) {
      throw InputError(where, fmt::format("the {} '{}' from '{}' is already defined: rename the "
                                          "file to change its prefix",
                                          what, name, display));
    };
    const int offset = static_cast<int>(part_.points.size());
    for (FeaturePoint& p : loaded.points) {
      p.name = prefix + p.name;
      if (!point_names_.insert(p.name).second) clash("point", p.name);
      p.position = including_from_loaded * p.position;
      part_.points.push_back(std::move(p));
    }
    for (Edge& e : loaded.edges) {
      e.name = prefix + e.name;
      if (!edge_names_.insert(e.name).second) clash("edge", e.name);
      e.a += offset;
      e.b += offset;
      part_.edges.push_back(std::move(e));
    }
    for (Face& f : loaded.faces) {
      f.name = prefix + f.name;
      if (!face_names_.insert(f.name).second) clash("face", f.name);
      for (int& p : f.loop) p += offset;
      part_.faces.push_back(std::move(f));
    }
    RequireModelSize(where, fmt::format("with '{}' loaded, ", display));
  }

  void RequireModelSize(const SourceLocation& where, const std::string& context) const {
    const std::tuple<const char*, size_t, int> sizes[] = {
        {"points", part_.points.size(), kMaxCaoPoints},
        {"edges", part_.edges.size(), kMaxCaoEdges},
        {"faces", part_.faces.size(), kMaxCaoFaces}};
    for (const auto& [what, size, limit] : sizes) {
      if (size > static_cast<size_t>(limit)) {
        throw InputError(where,
                         fmt::format("{}the model has more than {} {}", context, limit, what));
      }
    }
  }

  void ReadPoints(bool loaded_some) {
    const Row* count_row = Next();
    if (!count_row) {
      Fail(end_line_, end_column_,
           "the file ends before the 3D points section: expected the number of 3D points");
    }
    const int n = static_cast<int>(Count(*count_row, kPoints, kMaxCaoPoints));
    if (n == 0 && !loaded_some) {
      Fail(*count_row, count_row->tokens[0],
           "the model has no points: the number of 3D points is 0 and nothing is loaded");
    }
    first_point_ = static_cast<int>(part_.points.size());
    for (int k = 0; k < n; ++k) {
      const Row& row = SectionRow(kPoints, n, k);
      if (row.tokens.size() < 3) {
        Fail(row.line, row.tokens.back().end(),
             fmt::format("a 3D point needs 3 numbers (X Y Z), found {}", row.tokens.size()));
      }
      Eigen::Vector3d p;
      for (int j = 0; j < 3; ++j) p[j] = Number(row, row.tokens[j]);
      NothingMore(row, 3, "after the 3 coordinates of the point");
      const std::string name = fmt::format("p{}", k);
      point_names_.insert(name);
      part_.points.push_back({name, p, Where(row)});
    }
    RequireModelSize(Where(*count_row), "");
  }

  int OwnPoints() const { return static_cast<int>(part_.points.size()) - first_point_; }

  // An edge key that ignores direction.
  static uint64_t Key(int a, int b) {
    return (static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint32_t>(std::max(a, b));
  }

  // `preferred` if free, else preferred_2, preferred_3, ...; taken into `used`.
  static std::string Unique(const std::string& preferred, std::unordered_set<std::string>* used) {
    std::string name = preferred;
    for (int k = 2; !used->insert(name).second; ++k) name = fmt::format("{}_{}", preferred, k);
    return name;
  }

  // Each row's explicit name if no other row of the section has it and nothing loaded took
  // it, else `<automatic><number>`.
  static std::vector<std::string> Names(const std::vector<std::optional<std::string>>& given,
                                        const std::vector<int>& numbers, const char* automatic,
                                        std::unordered_set<std::string>* used) {
    std::unordered_map<std::string, int> count;
    for (const auto& name : given) {
      if (name) ++count[*name];
    }
    std::vector<std::string> names(given.size());
    for (size_t k = 0; k < given.size(); ++k) {
      if (given[k] && count[*given[k]] == 1 && used->insert(*given[k]).second) {
        names[k] = *given[k];
      }
    }
    for (size_t k = 0; k < given.size(); ++k) {
      if (names[k].empty()) names[k] = Unique(fmt::format("{}{}", automatic, numbers[k]), used);
    }
    return names;
  }

  void ReadLines() {
    const Row* count_row = Next();
    if (!count_row) {
      Fail(end_line_, end_column_,
           "the file ends before the 3D lines section: expected the number of 3D lines");
    }
    const int n = static_cast<int>(Count(*count_row, kLines, kMaxCaoEdges));
    std::unordered_set<uint64_t> seen;
    for (int k = 0; k < n; ++k) {
      const Row& row = SectionRow(kLines, n, k);
      if (row.tokens.size() < 2) {
        Fail(row.line, row.tokens.back().end(),
             fmt::format("a 3D line needs 2 point indices, found {}", row.tokens.size()));
      }
      const int a = Index(row, row.tokens[0], "point", OwnPoints());
      const int b = Index(row, row.tokens[1], "point", OwnPoints());
      if (a == b) {
        Fail(row, row.tokens[1],
             fmt::format("a 3D line joins two different points, found point {} twice", a));
      }
      LineRow line;
      line.a = first_point_ + a;
      line.b = first_point_ + b;
      line.name = Parameters(row, 2, "after the 2 point indices of the line");
      line.where = Where(row);
      line.duplicate = !seen.insert(Key(line.a, line.b)).second;
      lines_.push_back(std::move(line));
    }
    // A line repeating an earlier one's two points adds nothing; l<i> counts every row.
    std::vector<const LineRow*> kept;
    std::vector<std::optional<std::string>> given;
    std::vector<int> numbers;
    for (size_t k = 0; k < lines_.size(); ++k) {
      if (lines_[k].duplicate) continue;
      kept.push_back(&lines_[k]);
      given.push_back(lines_[k].name);
      numbers.push_back(static_cast<int>(k));
    }
    const std::vector<std::string> names = Names(given, numbers, "l", &edge_names_);
    for (size_t k = 0; k < kept.size(); ++k) {
      own_edges_.insert(Key(kept[k]->a, kept[k]->b));
      part_.edges.push_back({names[k], kept[k]->a, kept[k]->b, kept[k]->where});
    }
    RequireModelSize(Where(*count_row), "");
  }

  // The points of a face given by lines: walking the lines from the first one's start, in its
  // direction, through the points they share. Each point must be on exactly two of them.
  std::vector<int> Walk(const Row& row, const std::vector<int>& face_lines) const {
    const int n = static_cast<int>(face_lines.size());
    std::unordered_map<int, std::vector<int>> on;  // point -> positions in face_lines
    for (int j = 0; j < n; ++j) {
      on[lines_[face_lines[j]].a].push_back(j);
      on[lines_[face_lines[j]].b].push_back(j);
    }
    const char* kNotLoop = "the face's lines do not form one closed loop: ";
    for (int j = 0; j < n; ++j) {
      for (int p : {lines_[face_lines[j]].a, lines_[face_lines[j]].b}) {
        const size_t lines_on = on[p].size();
        if (lines_on == 1) {
          Fail(row, row.tokens[1 + j],
               fmt::format("{}point {} ends line {} and no other line of the face", kNotLoop,
                           p - first_point_, face_lines[j]));
        }
        if (lines_on > 2) {
          Fail(row, row.tokens[1 + j],
               fmt::format("{}point {} is on {} of its lines", kNotLoop, p - first_point_,
                           lines_on));
        }
      }
    }
    std::vector<bool> used(n, false);
    used[0] = true;
    std::vector<int> loop = {lines_[face_lines[0]].a};
    int at = lines_[face_lines[0]].b, previous = 0;
    while (at != loop[0]) {
      loop.push_back(at);
      const std::vector<int>& two = on[at];
      const int next = two[0] == previous ? two[1] : two[0];
      used[next] = true;
      const LineRow& l = lines_[face_lines[next]];
      at = l.a == at ? l.b : l.a;
      previous = next;
    }
    for (int j = 0; j < n; ++j) {
      if (!used[j]) {
        Fail(row, row.tokens[1 + j],
             fmt::format("{}line {} is not on the loop through line {}", kNotLoop, face_lines[j],
                         face_lines[0]));
      }
    }
    return loop;
  }

  // Refuses faces without area: coincident neighbours, or every point on one line.
  void CheckArea(const Row& row, const std::vector<int>& loop) const {
    Eigen::Vector3d lo = part_.points[loop[0]].position, hi = lo;
    for (int p : loop) {
      lo = lo.cwiseMin(part_.points[p].position);
      hi = hi.cwiseMax(part_.points[p].position);
    }
    const double size = (hi - lo).norm();
    // Relative to the first point, so that a face far from the origin loses no digits.
    const Eigen::Vector3d origin = part_.points[loop[0]].position;
    Eigen::Vector3d newell = Eigen::Vector3d::Zero();
    for (size_t k = 0; k < loop.size(); ++k) {
      const int a = loop[k], b = loop[(k + 1) % loop.size()];
      const Eigen::Vector3d pa = part_.points[a].position - origin;
      const Eigen::Vector3d pb = part_.points[b].position - origin;
      if ((pa - pb).norm() <= 1e-12 * size) {
        Fail(row, row.tokens[0],
             fmt::format("degenerate face: points {} and {} coincide", a - first_point_,
                         b - first_point_));
      }
      newell += pa.cross(pb);
    }
    // |Newell's normal| is twice the area; a sliver thinner than 1e-9 of its size has none.
    if (newell.norm() <= 2e-9 * size * size) {
      Fail(row, row.tokens[0], "degenerate face: its points are collinear (no area)");
    }
  }

  // A face row's count and its `n` indices.
  std::vector<Token> FaceIndices(const Row& row, const char* what) const {
    const Token& t = row.tokens[0];
    const std::optional<int64_t> n = NonNegativeInteger(t.text);
    if (!n) {
      Fail(row, t,
           fmt::format("the number of {}s of a face must be a non-negative integer, found '{}'",
                       what, Shown(t.text)));
    }
    if (*n > kMaxCaoPoints) {
      Fail(row, t,
           fmt::format("the number of {}s of a face, {}, exceeds the limit of {}", what,
                       Shown(t.text), kMaxCaoPoints));
    }
    if (*n < 3) {
      Fail(row, t, fmt::format("a face needs at least 3 {}s, found {}", what, *n));
    }
    if (row.tokens.size() < 1 + static_cast<size_t>(*n)) {
      Fail(row.line, row.tokens.back().end(),
           fmt::format("a face of {} {}s needs {} {} indices, found {}", *n, what, *n, what,
                       row.tokens.size() - 1));
    }
    return std::vector<Token>(row.tokens.begin() + 1, row.tokens.begin() + 1 + *n);
  }

  void ReadFacesFromLines() {
    const Row* count_row = Next();
    if (!count_row) {
      Fail(end_line_, end_column_,
           "the file ends before the faces from 3D lines section: expected the number of faces");
    }
    const int n = static_cast<int>(Count(*count_row, kFacesFromLines, kMaxCaoFaces));
    for (int k = 0; k < n; ++k) {
      const Row& row = SectionRow(kFacesFromLines, n, k);
      const std::vector<Token> indices = FaceIndices(row, "line");
      std::vector<int> face_lines;
      std::unordered_set<int> seen;
      for (const Token& t : indices) {
        const int l = Index(row, t, "line", static_cast<int>(lines_.size()));
        if (!seen.insert(l).second) {
          Fail(row, t, fmt::format("line {} appears twice in the face", l));
        }
        face_lines.push_back(l);
      }
      FaceRow face;
      face.name = Parameters(row, 1 + indices.size(), "after the line indices of the face");
      face.loop = Walk(row, face_lines);
      CheckArea(row, face.loop);
      face.where = Where(row);
      faces_.push_back(std::move(face));
    }
  }

  void ReadFacesFromPoints() {
    const Row* count_row = Next();
    if (!count_row) {
      Fail(end_line_, end_column_,
           "the file ends before the faces from 3D points section: expected the number of "
           "faces");
    }
    const int n = static_cast<int>(Count(*count_row, kFacesFromPoints, kMaxCaoFaces));
    for (int k = 0; k < n; ++k) {
      const Row& row = SectionRow(kFacesFromPoints, n, k);
      const std::vector<Token> indices = FaceIndices(row, "point");
      FaceRow face;
      std::unordered_set<int> seen;
      for (const Token& t : indices) {
        const int p = Index(row, t, "point", OwnPoints());
        if (!seen.insert(p).second) {
          Fail(row, t, fmt::format("point {} appears twice in the face", p));
        }
        face.loop.push_back(first_point_ + p);
      }
      face.name = Parameters(row, 1 + indices.size(), "after the point indices of the face");
      CheckArea(row, face.loop);
      face.where = Where(row);
      // Its sides that are not edges yet become edges.
      for (size_t j = 0; j < face.loop.size(); ++j) {
        const int a = face.loop[j], b = face.loop[(j + 1) % face.loop.size()];
        if (!own_edges_.insert(Key(a, b)).second) continue;
        part_.edges.push_back(
            {Unique(part_.points[a].name + "_" + part_.points[b].name, &edge_names_), a, b,
             face.where});
        if (part_.edges.size() > static_cast<size_t>(kMaxCaoEdges)) {
          RequireModelSize(face.where, "");
        }
      }
      faces_.push_back(std::move(face));
    }
    std::vector<std::optional<std::string>> given;
    std::vector<int> numbers;
    for (size_t k = 0; k < faces_.size(); ++k) {
      given.push_back(faces_[k].name);
      numbers.push_back(static_cast<int>(k));
    }
    const std::vector<std::string> names = Names(given, numbers, "f", &face_names_);
    for (size_t k = 0; k < faces_.size(); ++k) {
      part_.faces.push_back({names[k], std::move(faces_[k].loop), faces_[k].where});
    }
    RequireModelSize(Where(*count_row), "");
  }

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

ConstraintGraph Build(Part part, const std::string& display_name) {
  const std::string stem = fs::path(display_name).stem().string();
  ModelBuilder builder(stem, display_name);
  const int c =
      builder.AddRigidComponent(Identifier(stem), Rigid3d(), SourceLocation(display_name, 1, 1));
  for (const FeaturePoint& p : part.points) builder.AddFeaturePoint(c, p.name, p.position, p.where);
  for (const Edge& e : part.edges) builder.AddEdge(c, e.name, e.a, e.b, e.where);
  for (Face& f : part.faces) builder.AddFace(c, f.name, std::move(f.loop), f.where);
  return std::move(builder).Build();
}

}  // namespace

ConstraintGraph ImportCaoFromString(std::string_view text, const std::string& display_name,
                                    const std::string& base_directory) {
  RequireText(text, display_name);
  LoadContext context;
  std::error_code ec;
  context.open_canonical.push_back(fs::weakly_canonical(display_name, ec).string());
  context.open_display.push_back(display_name);
  return Build(CaoReader(&context, display_name, text, base_directory).Read(), display_name);
}

ConstraintGraph ImportCao(const std::string& path, const SourceLocation& included_from) {
  const std::string text = ReadCaoFile(path, included_from);
  return ImportCaoFromString(text, path, fs::path(path).parent_path().string());
}

}  // namespace cfuse::importers
