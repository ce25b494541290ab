#include "file_storage_screen.h"

#include <fmt/format.h>

#include <cctype>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cfuse/kernel/error.h"

namespace cfuse {
namespace {

bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

// The length of the UTF-8 sequence starting with byte `c` (the text is valid UTF-8).
size_t Utf8Length(unsigned char c) { return c < 0xC0 ? 1 : c < 0xE0 ? 2 : c < 0xF0 ? 3 : 4; }

// What stands at `pos` in a message: a character in quotes, or the end of the file.
std::string FoundAt(std::string_view text, size_t pos) {
  if (pos >= text.size()) return "the end of the file";
  const char c = text[pos];
  if (c == '\n' || c == '\r') return "the end of the line";
  if (static_cast<unsigned char>(c) < 0x20) return fmt::format("byte 0x{:02X}", c);
  return fmt::format("'{}'", text.substr(pos, Utf8Length(static_cast<unsigned char>(c))));
}

// The parts of a text's screen that every format shares: its position and located failures.
class Scanner {
 public:
  Scanner(const std::string& file, std::string_view text, size_t start)
      : file_(file), text_(text), pos_(start) {}

 protected:
  [[noreturn]] void Fail(size_t at, const std::string& message) const {
    throw InputError(LocationOfOffset(file_, text_, at), message);
  }
  // "L:C", for a construct opened at `at` and left open.
  std::string Where(size_t at) const {
    const SourceLocation where = LocationOfOffset(file_, text_, at);
    return fmt::format("{}:{}", where.line, where.column);
  }
  // cv::FileStorage parses nested collections by recursion: 10^5 levels (200 KB of '[')
  // overflow its stack. Calibration files nest 2 or 3 deep.
  void RequireDepth(size_t depth, size_t at) const {
    if (depth > kMaxFileStorageDepth) {
      Fail(at, fmt::format("nested more than {} levels deep: cv::FileStorage reads nesting by "
                           "recursion, and a calibration file nests 2 or 3",
                           kMaxFileStorageDepth));
    }
  }
  bool AtEnd() const { return pos_ >= text_.size(); }
  bool At(char c) const { return pos_ < text_.size() && text_[pos_] == c; }
  bool StartsWith(std::string_view s) const { return text_.substr(pos_).starts_with(s); }
  std::string Found() const { return FoundAt(text_, pos_); }
  // Skips white space; whether there was any.
  bool SkipSpace() {
    const size_t from = pos_;
    while (!AtEnd() && IsSpace(text_[pos_])) ++pos_;
    return pos_ > from;
  }

  const std::string& file_;
  std::string_view text_;
  size_t pos_;
};

// XML 1.0 well-formedness, for what cv::FileStorage's XML form can hold.
class XmlScreen : Scanner {
 public:
  using Scanner::Scanner;

  void Run() {
    Declaration();
    bool root_seen = false;
    for (;;) {
      SkipSpace();
      if (AtEnd()) break;
      if (StartsWith("<!--")) {
        Comment();
      } else if (StartsWith("<?")) {
        ProcessingInstruction();
      } else if (StartsWith("<!DOCTYPE")) {
        Fail(pos_, "a document type declaration (<!DOCTYPE ...>): cv::FileStorage reads none");
      } else if (StartsWith("</")) {
        Fail(pos_, "an end tag with no element open");
      } else if (At('<')) {
        if (root_seen) {
          Fail(pos_, "a second root element: an XML document has one (<opencv_storage>)");
        }
        Element();
        root_seen = true;
      } else {
        Fail(pos_, fmt::format("text {} the root element: an XML document's text is inside it",
                               root_seen ? "after" : "before"));
      }
    }
    if (!root_seen) {
      Fail(pos_, "the file ends before the root element: an XML document has one");
    }
  }

 private:
  struct Open {
    std::string_view name;
    size_t at;
  };

  static bool IsNameStart(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_' || c == ':' ||
           static_cast<unsigned char>(c) >= 0x80;
  }
  static bool IsNameChar(char c) {
    return IsNameStart(c) || (c >= '0' && c <= '9') || c == '-' || c == '.';
  }

  // A name at the position, or a failure saying what `what` needed.
  std::string_view Name(const std::string& what) {
    if (AtEnd() || !IsNameStart(text_[pos_])) {
      Fail(pos_, fmt::format("expected {} (a letter or '_' first), found {}", what, Found()));
    }
    const size_t from = pos_;
    while (!AtEnd() && IsNameChar(text_[pos_])) ++pos_;
    return text_.substr(from, pos_ - from);
  }

  // `<?xml` at the start: pseudo-attributes like a tag's, closed by `?>`.
  void Declaration() {
    const size_t at = pos_;
    pos_ += 5;                                  // "<?xml"
    if (!AtEnd() && IsNameChar(text_[pos_])) {  // `<?xml-stylesheet ...?>`: not a declaration
      pos_ = at;
      ProcessingInstruction();
      return;
    }
    std::set<std::string_view> seen;
    for (;;) {
      const bool space = SkipSpace();
      if (StartsWith("?>")) {
        pos_ += 2;
        return;
      }
      if (AtEnd() || !space || !IsNameStart(text_[pos_])) {
        Fail(pos_,
             fmt::format("expected {}'?>' to close the XML declaration opened at {}, found {}",
                         space ? "an attribute or " : "", Where(at), Found()));
      }
      Attribute("the XML declaration", &seen);
    }
  }

  // name = "value" (or 'value'), at an attribute's name.
  void Attribute(const std::string& owner, std::set<std::string_view>* seen) {
    const size_t at = pos_;
    const std::string_view name = Name("an attribute name");
    if (!seen->insert(name).second) {
      Fail(at, fmt::format("attribute '{}' given twice in {}", name, owner));
    }
    SkipSpace();
    if (!At('=')) {
      Fail(pos_, fmt::format("expected '=' after attribute '{}' of {}, found {} (an attribute is "
                             "name=\"value\")",
                             name, owner, Found()));
    }
    ++pos_;
    SkipSpace();
    if (!At('"') && !At('\'')) {
      Fail(pos_, fmt::format("expected the value of attribute '{}' of {} in quotes (\" or '), "
                             "found {}",
                             name, owner, Found()));
    }
    const char quote = text_[pos_];
    const size_t open = pos_++;
    for (;;) {
      if (AtEnd()) {
        Fail(pos_, fmt::format("the value of attribute '{}', opened at {}, is not closed: expected "
                               "{}, found the end of the file",
                               name, Where(open), quote == '"' ? "'\"'" : "\"'\""));
      }
      const char c = text_[pos_];
      if (c == quote) break;
      if (c == '<')
        Fail(pos_, fmt::format("'<' in the value of attribute '{}': write '&lt;'", name));
      if (c == '&') {
        Reference();
      } else {
        ++pos_;
      }
    }
    ++pos_;
  }

  // `&name;`, `&#N;` or `&#xH;`.
  void Reference() {
    const size_t at = pos_++;
    bool ok = false;
    if (At('#')) {
      ++pos_;
      const bool hex = At('x');
      if (hex) ++pos_;
      const size_t digits = pos_;
      while (!AtEnd() && (std::isdigit(static_cast<unsigned char>(text_[pos_])) ||
                          (hex && std::isxdigit(static_cast<unsigned char>(text_[pos_]))))) {
        ++pos_;
      }
      ok = pos_ > digits && At(';');
    } else if (!AtEnd() && IsNameStart(text_[pos_])) {
      while (!AtEnd() && IsNameChar(text_[pos_])) ++pos_;
      ok = At(';');
    }
    if (!ok) {
      Fail(at,
           "'&' starts a reference such as '&amp;' or '&#38;', ended by ';': write '&amp;' "
           "for an '&'");
    }
    ++pos_;
  }

  // `<!-- ... -->`, without `--` inside.
  void Comment() {
    const size_t at = pos_;
    pos_ += 4;
    for (;;) {
      if (AtEnd()) {
        Fail(pos_, fmt::format("the comment opened at {} is not closed: expected '-->', found the "
                               "end of the file",
                               Where(at)));
      }
      if (StartsWith("--")) {
        if (!StartsWith("-->")) {
          Fail(pos_, fmt::format("'--' inside the comment opened at {}: an XML comment may not "
                                 "hold '--'",
                                 Where(at)));
        }
        pos_ += 3;
        return;
      }
      ++pos_;
    }
  }

  // `<?target ...?>`.
  void ProcessingInstruction() {
    const size_t at = pos_;
    pos_ += 2;
    Name("the name of a processing instruction after '<?'");
    const size_t end = text_.find("?>", pos_);
    if (end == std::string_view::npos) {
      pos_ = text_.size();
      Fail(pos_, fmt::format("the processing instruction opened at {} is not closed: expected "
                             "'?>', found the end of the file",
                             Where(at)));
    }
    pos_ = end + 2;
  }

  // `<![CDATA[ ... ]]>`.
  void Cdata() {
    const size_t at = pos_;
    const size_t end = text_.find("]]>", pos_ + 9);
    if (end == std::string_view::npos) {
      pos_ = text_.size();
      Fail(pos_, fmt::format("the CDATA section opened at {} is not closed: expected ']]>', found "
                             "the end of the file",
                             Where(at)));
    }
    pos_ = end + 3;
  }

  // `<name attributes>` or `<name attributes/>`; an element left open goes on `open`.
  void StartTag(std::vector<Open>* open) {
    const size_t at = pos_++;
    const std::string_view name = Name("a tag's name after '<' (write '&lt;' for a '<' in text)");
    const std::string owner = fmt::format("the tag <{}> opened at {}", name, Where(at));
    std::set<std::string_view> seen;
    for (;;) {
      const bool space = SkipSpace();
      if (At('>')) {
        ++pos_;
        open->push_back({name, at});
        RequireDepth(open->size(), at);
        return;
      }
      if (StartsWith("/>")) {
        pos_ += 2;
        return;
      }
      if (AtEnd() || !space || !IsNameStart(text_[pos_])) {
        Fail(pos_, fmt::format("expected {}'>' or '/>' to close {}, found {}",
                               space ? "an attribute, " : "", owner, Found()));
      }
      Attribute(owner, &seen);
    }
  }

  // `</name>`, closing the innermost open element.
  void EndTag(std::vector<Open>* open) {
    const size_t at = pos_;
    pos_ += 2;
    const std::string_view name = Name("the element's name after '</'");
    SkipSpace();
    if (!At('>')) {
      Fail(pos_, fmt::format("expected '>' to close the end tag </{}>, found {}", name, Found()));
    }
    ++pos_;
    if (name != open->back().name) {
      Fail(at, fmt::format("</{}> where <{}>, opened at {}, must close first: elements close in "
                           "the reverse order of their opening",
                           name, open->back().name, Where(open->back().at)));
    }
    open->pop_back();
  }

  // The root element and everything in it, without recursion (depth is bounded by the size).
  void Element() {
    std::vector<Open> open;
    StartTag(&open);
    while (!open.empty()) {
      if (AtEnd()) {
        Fail(pos_, fmt::format("expected </{}> to close the element opened at {}, found the end "
                               "of the file",
                               open.back().name, Where(open.back().at)));
      }
      const char c = text_[pos_];
      if (c == '<') {
        if (StartsWith("<!--")) {
          Comment();
        } else if (StartsWith("<![CDATA[")) {
          Cdata();
        } else if (StartsWith("<?")) {
          ProcessingInstruction();
        } else if (StartsWith("</")) {
          EndTag(&open);
        } else if (StartsWith("<!")) {
          Fail(pos_,
               "'<!' in an element starts a comment '<!--' or a CDATA section "
               "'<![CDATA[' only");
        } else {
          StartTag(&open);
        }
      } else if (c == '&') {
        Reference();
      } else if (StartsWith("]]>")) {
        Fail(pos_, "']]>' in text: write ']]&gt;'");
      } else {
        ++pos_;
      }
    }
  }
};

// JSON's strings and brackets.
class JsonScreen : Scanner {
 public:
  using Scanner::Scanner;

  void Run() {
    std::vector<std::pair<char, size_t>> open;
    while (!AtEnd()) {
      const char c = text_[pos_];
      if (c == '"') {
        String();
        continue;
      }
      if (c == '[' || c == '{') {
        open.emplace_back(c, pos_);
        RequireDepth(open.size(), pos_);
      } else if (c == ']' || c == '}') {
        Close(c, &open);
      }
      ++pos_;
    }
    if (!open.empty()) {
      const auto [bracket, at] = open.back();
      Fail(pos_,
           fmt::format("expected '{}' to close the {} opened at {}, found the end of the "
                       "file",
                       bracket == '[' ? ']' : '}', bracket == '[' ? "array" : "object", Where(at)));
    }
  }

 private:
  void String() {
    const size_t at = pos_++;
    for (;;) {
      if (AtEnd() || At('\n')) {
        Fail(pos_, fmt::format("expected '\"' to close the string opened at {}, found {} (a JSON "
                               "string is on one line)",
                               Where(at), Found()));
      }
      if (At('\\')) {
        pos_ += 2;
        continue;
      }
      if (At('"')) break;
      ++pos_;
    }
    ++pos_;
  }

  void Close(char c, std::vector<std::pair<char, size_t>>* open) {
    if (open->empty()) Fail(pos_, fmt::format("'{}' closes nothing", c));
    const auto [bracket, at] = open->back();
    const char expected = bracket == '[' ? ']' : '}';
    if (c != expected) {
      Fail(pos_, fmt::format("'{}' where the {} opened at {} needs '{}'", c,
                             bracket == '[' ? "array" : "object", Where(at), expected));
    }
    open->pop_back();
  }
};

// YAML's quoted scalars and flow collections, the rest skipped token by token. A quote or a
// bracket opens something only where a node starts (a plain scalar may hold them later on).
class YamlScreen : Scanner {
 public:
  using Scanner::Scanner;

  void Run() {
    const size_t start = pos_;
    bool node_start = true;   // a node may begin here
    size_t line_entries = 0;  // `-` and `?` indicators on this line
    while (!AtEnd()) {
      const char c = text_[pos_];
      const bool flow = !open_.empty();
      const bool line_start = pos_ == start || text_[pos_ - 1] == '\n';
      if (c == '\n') {
        ++pos_;
        if (!flow) node_start = true;
        line_entries = 0;
      } else if (c == ' ' || c == '\t' || c == '\r') {
        ++pos_;
      } else if (c == '#') {
        SkipLine();
      } else if (!flow && line_start && c == '%') {
        SkipLine();  // a directive: `%YAML:1.0`
      } else if (!flow && line_start && StartsWith("---")) {
        DocumentStart();
        node_start = true;
      } else if (!flow && line_start && StartsWithWord("...")) {
        pos_ += 3;
        node_start = true;
      } else if (node_start && (c == '"' || c == '\'')) {
        Quoted();
        node_start = false;
      } else if (node_start && (c == '[' || c == '{')) {
        open_.emplace_back(c, pos_);
        RequireDepth(open_.size() + line_entries, pos_++);
      } else if (c == ']' || c == '}') {
        Close(c);
        node_start = false;
      } else if (flow && c == ',') {
        ++pos_;
        node_start = true;
      } else if (c == ':' && (!node_start || Indicator(pos_ + 1, flow))) {
        ++pos_;
        node_start = true;
      } else if (node_start && (c == '-' || c == '?') && Indicator(pos_ + 1, false)) {
        // A block sequence's entry or a complex key: the node follows, and may be another
        // (`- - - 1` nests three sequences on one line).
        RequireDepth(open_.size() + ++line_entries, pos_++);
      } else if (node_start && (c == '!' || c == '&')) {
        SkipToken(flow);  // a tag (`!!opencv-matrix`) or an anchor: the node follows
      } else if (node_start && !flow && (c == '|' || c == '>')) {
        Fail(pos_, fmt::format("a block scalar ('{}', text on the lines below): cv::FileStorage "
                               "reads no multi-line text",
                               c));
      } else {
        Plain(flow);
        node_start = false;
      }
    }
    if (!open_.empty()) {
      const auto [bracket, at] = open_.back();
      Fail(pos_, fmt::format("expected '{}' to close the {} opened at {}, found the end of the "
                             "file",
                             bracket == '[' ? ']' : '}',
                             bracket == '[' ? "flow sequence" : "flow mapping", Where(at)));
    }
  }

 private:
  static bool IsFlowIndicator(char c) {
    return c == ',' || c == '[' || c == ']' || c == '{' || c == '}';
  }
  // Whether the character at `i` ends an indicator before it (':', '-', '?'): white space, the
  // end, or in a flow collection a flow indicator.
  bool Indicator(size_t i, bool flow) const {
    return i >= text_.size() || IsSpace(text_[i]) || (flow && IsFlowIndicator(text_[i]));
  }
  bool StartsWithWord(std::string_view word) const {
    return StartsWith(word) && Indicator(pos_ + word.size(), false);
  }
  // `---` alone on its line (or before a comment). cv::FileStorage takes any line starting with
  // `---` for a document's start and parses what follows it there; on `--- -x` (or `----x`)
  // followed by another line its YAML parser loops forever (fuzz/camera_fuzz.cpp).
  void DocumentStart() {
    pos_ += 3;
    const size_t content = text_.find_first_not_of(" \t\r", pos_);
    if (content != std::string_view::npos && text_[content] != '\n' &&
        !(text_[content] == '#' && content > pos_)) {
      Fail(content, fmt::format("'---' (a document's start) stands alone on its line for "
                                "cv::FileStorage, found {} after it",
                                FoundAt(text_, content)));
    }
  }
  void SkipLine() {
    while (!AtEnd() && !At('\n')) ++pos_;
  }
  void SkipToken(bool flow) {
    while (!AtEnd() && !IsSpace(text_[pos_]) && !(flow && IsFlowIndicator(text_[pos_]))) ++pos_;
  }

  // "..." with backslash escapes, '...' with '' for a quote; on one line, as cv::FileStorage
  // reads them.
  void Quoted() {
    const char quote = text_[pos_];
    const size_t at = pos_++;
    for (;;) {
      if (AtEnd() || At('\n')) {
        Fail(pos_, fmt::format("expected {} to close the string opened at {}, found {} "
                               "(cv::FileStorage reads strings on one line)",
                               quote == '"' ? "'\"'" : "\"'\"", Where(at), Found()));
      }
      if (quote == '"' && At('\\')) {
        pos_ += 2;
        continue;
      }
      if (At(quote)) {
        if (quote == '\'' && StartsWith("''")) {
          pos_ += 2;
          continue;
        }
        break;
      }
      ++pos_;
    }
    ++pos_;
  }

  // A plain scalar: to the end of the line, a comment, a ': ', or in a flow collection its
  // next indicator.
  void Plain(bool flow) {
    const size_t from = pos_;
    while (!AtEnd() && !At('\n')) {
      const char c = text_[pos_];
      if (flow && IsFlowIndicator(c)) break;
      if (c == ':' && Indicator(pos_ + 1, flow)) break;
      if (c == '#' && pos_ > from && IsSpace(text_[pos_ - 1])) break;
      ++pos_;
    }
    if (pos_ == from) ++pos_;  // a lone character no rule above takes: skipped
  }

  void Close(char c) {
    if (open_.empty()) Fail(pos_, fmt::format("'{}' closes nothing", c));
    const auto [bracket, at] = open_.back();
    const char expected = bracket == '[' ? ']' : '}';
    if (c != expected) {
      Fail(pos_,
           fmt::format("'{}' where the {} opened at {} needs '{}'", c,
                       bracket == '[' ? "flow sequence" : "flow mapping", Where(at), expected));
    }
    open_.pop_back();
    ++pos_;
  }

  std::vector<std::pair<char, size_t>> open_;
};

}  // namespace

void ScreenFileStorageText(const std::string& display_name, std::string_view text) {
  size_t start = 0;
  if (text.starts_with("\xEF\xBB\xBF")) start = 3;  // cv::FileStorage skips a UTF-8 BOM
  const std::string_view head = text.substr(start);
  if (head.starts_with("<?xml")) {
    XmlScreen(display_name, text, start).Run();
  } else if (head.starts_with("{")) {
    JsonScreen(display_name, text, start).Run();
  } else if (head.starts_with("%YAML")) {
    YamlScreen(display_name, text, start).Run();
  } else {
    throw InputError(LocationOfOffset(display_name, text, start),
                     fmt::format("not a cv::FileStorage file: it must begin with '%YAML:1.0', "
                                 "'<?xml' or '{{' (nothing before them, not even white space), "
                                 "found {}",
                                 FoundAt(text, start)));
  }
}

}  // namespace cfuse
