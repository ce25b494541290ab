// The CAO reader's lexical side: numbers and names in the text, the text into rows of tokens, and
// the checks of a token as a count, a number, an index or a parameter, each failing at its place.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <optional>
#include <unordered_set>

#include "cao_internal.h"

namespace cfuse::internal {

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

std::string Shown(std::string_view s) {
  return s.size() <= 40 ? std::string(s) : std::string(s.substr(0, 37)) + "...";
}

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

std::optional<double> NumberValue(std::string_view lexeme) {
  if (!lexeme.empty() && lexeme[0] == '+') lexeme.remove_prefix(1);
  double value = 0;
  const auto [end, ec] = std::from_chars(lexeme.data(), lexeme.data() + lexeme.size(), value);
  if (ec != std::errc() || end != lexeme.data() + lexeme.size() || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

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

// Lines into rows of tokens. A token starting with '#' or "//" starts a comment, to the end of
// the line; a double quote runs to the next one, blanks included.
void CaoReader::Split(std::string_view text) {
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

// The next row of a section, or an error at the end of the file.
const Row& CaoReader::SectionRow(const Section& s, int expected, int found) {
  const Row* row = Next();
  if (!row) {
    Fail(end_line_, end_column_,
         fmt::format("the file ends in the {} section: {} {} expected, {} found", s.name, expected,
                     s.rows, found));
  }
  return *row;
}

// Refuses tokens after the first `used` of a row.
void CaoReader::NothingMore(const Row& row, size_t used, const std::string& after) const {
  if (row.tokens.size() > used) {
    const Token& t = row.tokens[used];
    Fail(row, t, fmt::format("unexpected '{}' {}", Shown(t.text), after));
  }
}

// A section's count: the row's only token.
int64_t CaoReader::Count(const Row& row, const Section& s, int64_t limit) const {
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
    Fail(
        row, t,
        fmt::format("the number of {}, {}, exceeds the limit of {}", s.name, Shown(t.text), limit));
  }
  NothingMore(row, 1, fmt::format("after the number of {}", s.name));
  return *n;
}

double CaoReader::Number(const Row& row, const Token& t) const {
  if (NumberLength(t.text) != t.text.size()) {
    Fail(row, t, fmt::format("expected a number, found '{}'", Shown(t.text)));
  }
  const std::optional<double> v = NumberValue(t.text);
  if (!v) Fail(row, t, fmt::format("number '{}' is out of range", Shown(t.text)));
  return *v;
}

// An index into a table of `size` entries (`what`: "point", "line").
int CaoReader::Index(const Row& row, const Token& t, const char* what, int size) const {
  const std::optional<int64_t> i = NonNegativeInteger(t.text);
  if (!i) {
    Fail(row, t,
         fmt::format("a {} index must be a non-negative integer, found '{}'", what, Shown(t.text)));
  }
  if (*i >= size) {
    Fail(row, t,
         size == 0 ? fmt::format("{} index {} is out of range: the file has no {}s", what,
                                 Shown(t.text), what)
                   : fmt::format("{} index {} is out of range: the file has {} {}{} (0 to {})",
                                 what, Shown(t.text), size, what, size == 1 ? "" : "s", size - 1));
  }
  return static_cast<int>(*i);
}

// ViSP's `key=value` parameters after a row's values, from token `first` on. The
// level-of-detail ones are checked and ignored; returns the name, if given.
std::optional<std::string> CaoReader::Parameters(const Row& row, size_t first,
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

}  // namespace cfuse::internal
