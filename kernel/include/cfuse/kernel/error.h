// Bad user input (error tier 1 of 3): a typed exception carrying where the problem is.
//
// Every reader of user files (model DSL, URDF, measurements, images, cameras) throws InputError
// with a SourceLocation; the CLI prints InputError::what() as one line and exits with status 2.
// The message format is the compiler convention, so editors can jump to it:
//   FILE:LINE:COLUMN: error: MESSAGE            (line and column 1-based, when known)
//   FILE: ELEMENT: error: MESSAGE               (for formats without positions, e.g. XML elements)
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

namespace cfuse {

struct SourceLocation {
  SourceLocation() = default;
  explicit SourceLocation(std::string file_, int line_ = 0, int column_ = 0,
                          std::string element_ = "")
      : file(std::move(file_)), line(line_), column(column_), element(std::move(element_)) {}

  std::string file;     // path as the user gave it
  int line = 0;         // 1-based; 0 = unknown
  int column = 0;       // 1-based; 0 = unknown
  std::string element;  // e.g. "joint 'elbow'" or "points[3]"; may be empty

  // "file:line:col" / "file:line" / "file: element" / "file".
  std::string ToString() const;
  bool known() const { return !file.empty(); }
};

class InputError : public std::runtime_error {
 public:
  InputError(SourceLocation where, const std::string& message);

  const SourceLocation& where() const { return where_; }
  // The message without the location prefix.
  const std::string& message() const { return message_; }

 private:
  SourceLocation where_;
  std::string message_;
};

// Refuses bytes that are not text: a NUL byte ("is a binary file, not a WHAT (NUL byte at
// offset N)") or a sequence that is not UTF-8 (RFC 3629, strictly: no overlong forms,
// surrogates or code points above U+10FFFF), at its line and column. Every reader of text runs
// it first: parsers in other libraries are not safe on such bytes (cv::FileStorage crashes on a
// NUL; TinyXML passes invalid UTF-8 into names that would then be written out).
void RequireText(const std::string& file, std::string_view text, const std::string& what);

// The line and column (1-based, in bytes) of a byte offset in a text.
SourceLocation LocationOfOffset(const std::string& file, std::string_view text, size_t offset);

}  // namespace cfuse
