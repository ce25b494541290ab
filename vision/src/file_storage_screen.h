// The text cv::FileStorage may be given (internal to vision/): a screen that refuses, at its line
// and column, what OpenCV 4.6's parsers would crash on rather than report.
//
// cv::FileStorage's parsers are not safe on malformed text. Found so far: a NUL byte (fuzz
// finding, refused by RequireText), and an XML attribute whose '=' is followed by nothing but
// white space to the end of the text, e.g. the 9 bytes `<?xml rr=` (a crash found by a user): its XML parser
// reads the character after the white space without checking for the end, a null dereference
// inside cv::FileStorage::Impl::open. Both are the same class of problem: the parser meets the
// end of the text inside a construct. The screen makes sure it never does, by checking that the
// text's structure is complete for the format OpenCV will pick, which it picks from the first
// bytes after a UTF-8 byte order mark, with nothing before them (not even white space):
//
//   `<?xml`  XML, well formed (XML 1.0): the declaration closed by `?>` with its attributes
//            quoted; every tag closed by `>`, its name a name, its attributes name="value" or
//            name='value' (each once) separated by white space; elements nested and closed by
//            their own end tag, one root element; comments closed by `-->` (no `--` inside);
//            references `&name;` or `&#N;`; no `<` in attribute values. Processing instructions
//            and CDATA sections are checked too; a document type declaration is refused
//            (cv::FileStorage reads none, and its internal subset is a language of its own).
//   `{`      JSON: every string closed (with its backslash escapes), every '[' and '{' closed by
//            its own kind.
//   `%YAML`  YAML (OpenCV's `%YAML:1.0`): every quoted scalar closed, every flow collection
//            ('[', '{') closed by its own kind; comments, tags (`!!opencv-matrix`) and plain
//            scalars (which may hold quotes and brackets after their first character) skipped.
//            A document marker `---` stands alone on its line: OpenCV's parser loops forever on
//            `--- -x` (or `----x`) followed by another line (a fuzz finding).
//
// anything else is refused as cv::FileStorage would refuse it, with the first bytes it needs. In
// every format, nesting deeper than kMaxFileStorageDepth is refused: OpenCV's parsers recurse
// into each level, and 10^5 levels (200 KB of '[', or of YAML's `- - - ...`) overflow the stack.
// What is complete but wrong for OpenCV (a missing <opencv_storage>, a bad number) is left to
// OpenCV, which reports it with its own words. Errors are at the problem's line and column
// (1-based, bytes), the construct left open named with where it opened.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace cfuse {

// Elements, brackets or `- ` entries inside one another (cv::FileStorage recurses into each).
inline constexpr size_t kMaxFileStorageDepth = 256;

// Throws InputError at `display_name`:LINE:COLUMN for text cv::FileStorage must not be given.
// `text` is already known to be UTF-8 without NUL bytes (RequireText).
void ScreenFileStorageText(const std::string& display_name, std::string_view text);

}  // namespace cfuse
