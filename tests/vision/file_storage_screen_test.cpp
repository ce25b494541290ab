// The screen in front of cv::FileStorage (vision/src/file_storage_screen.h): what OpenCV 4.6's
// parsers would crash or loop on is refused at its line and column, in XML, JSON and YAML, and
// what is well formed passes, whatever it holds.
#include "file_storage_screen.h"

#include <catch2/catch.hpp>
#include <string>

#include "cfuse/vision/camera_file.h"
#include "test_util.h"

namespace cfuse {
namespace {

void Screen(const char* text, const char* name) { ScreenFileStorageText(name, text); }

// cv::FileStorage (OpenCV 4.6) dereferences null where its parser meets the end of the text
// inside a construct, e.g. after an XML attribute's '='. Each of these inputs is refused by the
// screen at its place, before OpenCV sees it; the first crashed the program before the screen.
TEST_CASE("OpenCV camera files: malformed text is refused at its place, never parsed", "[vision]") {
  const std::string h = "<?xml version=\"1.0\"?>\n<opencv_storage>\n";
  const std::string cases_text[] = {
      "<?xml rr=",
      "<?xml version=\"1.0\"",
      "<?xml version=1.0?>\n<opencv_storage/>\n",
      h + "<camera_matrix type_id=",
      h + "<camera_matrix type_id=  \n",
      h + "<camera_matrix type_id=\"opencv-matrix",
      h + "<image_width",
      h + "<image_width>640</image_width>\n",
      h + "<a>1</b>\n</opencv_storage>\n",
      h + "<a b=c>1</a>\n</opencv_storage>\n",
      h + "<a b=\"1\"c=\"2\">1</a>\n</opencv_storage>\n",
      h + "<a b=\"1\" b=\"2\">1</a>\n</opencv_storage>\n",
      h + "<!-- a comment",
      h + "<a>1 & 2</a>\n</opencv_storage>\n",
      h + "</opencv_storage>\n<second/>\n",
      h + "</opencv_storage>\ntext\n",
      "<?xml version=\"1.0\"?>\n<!DOCTYPE opencv_storage>\n<opencv_storage/>\n",
      "<?xml version=\"1.0\"?>\n",
      "{\"image_width\": 640, \"camera_matrix\": {\"data\": [1, 2",
      "{\"image_width\": 640, \"name\": \"abc",
      "{\"image_width\": [640}",
      "%YAML:1.0\n---\ncamera_matrix: !!opencv-matrix\n   data: [ 1., 2.,\n",
      "%YAML:1.0\n---\nname: \"abc\n",
      "%YAML:1.0\n---\nname: 'it''s\n",
      "%YAML:1.0\n---\nm: { rows: 3 ]\n",
      "%YAML:1.0\n---\nnote: |\n  text\n",
      "\n%YAML:1.0\n",
      "",
      // OpenCV's YAML parser loops forever on these (found by fuzz/camera_fuzz.cpp).
      "%YAML:1.\n----V\n<\n-",
      "%YAML:1.0\n--- -V\nx\n-",
  };
  const testing::BadCase cases[] = {
      {cases_text[0].c_str(), 1, 10,
       "expected the value of attribute 'rr' of the XML declaration in quotes (\" or '), found "
       "the end of the file"},
      {cases_text[1].c_str(), 1, 20,
       "expected '?>' to close the XML declaration opened at 1:1, found the end of the file"},
      {cases_text[2].c_str(), 1, 15,
       "expected the value of attribute 'version' of the XML declaration in quotes (\" or '), "
       "found '1'"},
      {cases_text[3].c_str(), 3, 24,
       "expected the value of attribute 'type_id' of the tag <camera_matrix> opened at 3:1 in "
       "quotes"},
      {cases_text[4].c_str(), 4, 1, "expected the value of attribute 'type_id'"},
      {cases_text[5].c_str(), 3, 38,
       "the value of attribute 'type_id', opened at 3:24, is not closed: expected '\"', found the "
       "end of the file"},
      {cases_text[6].c_str(), 3, 13,
       "expected '>' or '/>' to close the tag <image_width> opened at 3:1, found the end of the "
       "file"},
      {cases_text[7].c_str(), 4, 1,
       "expected </opencv_storage> to close the element opened at 2:1, found the end of the file"},
      {cases_text[8].c_str(), 3, 5, "</b> where <a>, opened at 3:1, must close first"},
      {cases_text[9].c_str(), 3, 6,
       "expected the value of attribute 'b' of the tag <a> opened at 3:1 in quotes (\" or '), "
       "found 'c'"},
      {cases_text[10].c_str(), 3, 9,
       "expected '>' or '/>' to close the tag <a> opened at 3:1, found 'c'"},
      {cases_text[11].c_str(), 3, 10, "attribute 'b' given twice in the tag <a>"},
      {cases_text[12].c_str(), 3, 15, "the comment opened at 3:1 is not closed"},
      {cases_text[13].c_str(), 3, 6, "'&' starts a reference such as '&amp;'"},
      {cases_text[14].c_str(), 4, 1, "a second root element"},
      {cases_text[15].c_str(), 4, 1, "text after the root element"},
      {cases_text[16].c_str(), 2, 1, "a document type declaration (<!DOCTYPE ...>)"},
      {cases_text[17].c_str(), 2, 1, "the file ends before the root element"},
      {cases_text[18].c_str(), 1, 53,
       "expected ']' to close the array opened at 1:48, found the end of the file"},
      {cases_text[19].c_str(), 1, 34, "expected '\"' to close the string opened at 1:30"},
      {cases_text[20].c_str(), 1, 21, "'}' where the array opened at 1:17 needs ']'"},
      {cases_text[21].c_str(), 5, 1,
       "expected ']' to close the flow sequence opened at 4:10, found the end of the file"},
      {cases_text[22].c_str(), 3, 11,
       "expected '\"' to close the string opened at 3:7, found the end of the line"},
      {cases_text[23].c_str(), 3, 13, "expected \"'\" to close the string opened at 3:7"},
      {cases_text[24].c_str(), 3, 14, "']' where the flow mapping opened at 3:4 needs '}'"},
      {cases_text[25].c_str(), 3, 7, "a block scalar ('|', text on the lines below)"},
      {cases_text[26].c_str(), 1, 1,
       "not a cv::FileStorage file: it must begin with '%YAML:1.0', '<?xml' or '{' (nothing "
       "before them, not even white space), found the end of the line"},
      {cases_text[27].c_str(), 1, 1, "not a cv::FileStorage file"},
      {cases_text[28].c_str(), 2, 4,
       "'---' (a document's start) stands alone on its line for cv::FileStorage, found '-' "
       "after it"},
      {cases_text[29].c_str(), 2, 5, "'---' (a document's start) stands alone on its line"},
  };
  static_assert(std::size(cases) == std::size(cases_text));
  testing::ExpectRefused(
      std::begin(cases), std::end(cases),
      [](const char* text, const char* name) { return ReadOpenCvCameraFromString(text, name); });
}

// cv::FileStorage parses nesting by recursion: 10^5 levels, well within the 1 MiB a camera file
// may have, overflow its stack in each format. The screen refuses what is deeper than 256 levels
// at the level that goes too deep; this test crashed before it.
TEST_CASE("OpenCV camera files: nesting deeper than 256 levels is refused, in every format",
          "[vision]") {
  const int n = 100000;
  auto repeat = [](const std::string& s, int times) {
    std::string out;
    for (int i = 0; i < times; ++i) out += s;
    return out;
  };
  const std::string xml = "<?xml version=\"1.0\"?>\n<opencv_storage>" + repeat("<a>", n) + "1" +
                          repeat("</a>", n) + "</opencv_storage>\n";
  const std::string json = "{\"a\": " + repeat("[", n) + "1" + repeat("]", n) + "}";
  const std::string yaml = "%YAML:1.0\n---\na: " + repeat("[", n) + "1" + repeat("]", n) + "\n";
  const std::string entries = "%YAML:1.0\n---\na:\n  " + repeat("- ", n) + "1\n";
  const testing::BadCase cases[] = {
      // The 256th <a> is the 257th element, <opencv_storage> the first.
      {xml.c_str(), 2, 16 + 255 * 3 + 1, "nested more than 256 levels deep"},
      // The 256th '[' is the 257th level, the object the first.
      {json.c_str(), 1, 6 + 255 + 1, "nested more than 256 levels deep"},
      {yaml.c_str(), 3, 4 + 256, "nested more than 256 levels deep"},
      {entries.c_str(), 4, 3 + 2 * 256, "nested more than 256 levels deep"},
  };
  testing::ExpectRefused(
      std::begin(cases), std::end(cases),
      [](const char* text, const char* name) { return ReadOpenCvCameraFromString(text, name); });
  // 256 levels are read by OpenCV (and refused for what they hold, not for their depth).
  const std::string deep_enough = "{\"a\": " + repeat("[", 255) + "1" + repeat("]", 255) + "}";
  CHECK_THROWS_WITH(ReadOpenCvCameraFromString(deep_enough, "deep.json"),
                    Catch::Matchers::Contains("camera_matrix: error: missing"));
}

TEST_CASE("file storage screen: the rest of XML's constructs, each refused where it breaks",
          "[vision]") {
  const std::string d = "<?xml version=\"1.0\"?>\n";
  const std::string text[] = {
      d + "<a>]]></a>",
      d + "<a><![CDATA[ x </a>",
      d + "<?pi data",
      d + "<a><!ELEMENT></a>",
      d + "</a>",
      d + "x<a/>",
      d + "<!-- a -- b -->\n<a/>",
      d + "<a x=\"<\"/>",
      d + "<a x y=\"1\"/>",
      d + "<a></a x>",
      d + "<a>&#;</a>",
      d + "<a>&#12</a>",
      d + "<1a/>",
  };
  const testing::BadCase cases[] = {
      {text[0].c_str(), 2, 4, "']]>' in text: write ']]&gt;'"},
      {text[1].c_str(), 2, 20,
       "the CDATA section opened at 2:4 is not closed: expected ']]>', found the end of the file"},
      {text[2].c_str(), 2, 10,
       "the processing instruction opened at 2:1 is not closed: expected '?>', found the end of "
       "the file"},
      {text[3].c_str(), 2, 4, "'<!' in an element starts a comment '<!--' or a CDATA section"},
      {text[4].c_str(), 2, 1, "an end tag with no element open"},
      {text[5].c_str(), 2, 1, "text before the root element: an XML document's text is inside it"},
      {text[6].c_str(), 2, 8, "'--' inside the comment opened at 2:1: an XML comment may not hold"},
      {text[7].c_str(), 2, 7, "'<' in the value of attribute 'x': write '&lt;'"},
      {text[8].c_str(), 2, 6,
       "expected '=' after attribute 'x' of the tag <a> opened at 2:1, found 'y' (an attribute is "
       "name=\"value\")"},
      {text[9].c_str(), 2, 8, "expected '>' to close the end tag </a>, found 'x'"},
      {text[10].c_str(), 2, 4, "'&' starts a reference such as '&amp;' or '&#38;', ended by ';'"},
      {text[11].c_str(), 2, 4, "'&' starts a reference"},
      {text[12].c_str(), 2, 2,
       "expected a tag's name after '<' (write '&lt;' for a '<' in text) (a letter or '_' "
       "first), found '1'"},
  };
  static_assert(std::size(cases) == std::size(text));
  testing::ExpectRefused(std::begin(cases), std::end(cases), Screen);
}

TEST_CASE("file storage screen: JSON and YAML brackets and strings; what begins no format",
          "[vision]") {
  const testing::BadCase cases[] = {
      {"{\"a\": 1}}", 1, 9, "'}' closes nothing"},
      {"{\"a\": \"x\ny\"}", 1, 9,
       "expected '\"' to close the string opened at 1:7, found the end of the line (a JSON "
       "string is on one line)"},
      {"%YAML:1.0\na: ]", 2, 4, "']' closes nothing"},
      {"%YAML:1.0\na: [1, {b: 2]]", 2, 13, "']' where the flow mapping opened at 2:8 needs '}'"},
      {"%YAML:1.0\na: >\n  x\n", 2, 4, "a block scalar ('>', text on the lines below)"},
      {"\xEF\xBB\xBF {}", 1, 4, "not a cv::FileStorage file: it must begin with"},
      {"# %YAML:1.0", 1, 1,
       "not a cv::FileStorage file: it must begin with '%YAML:1.0', '<?xml' "
       "or '{' (nothing before them, not even white space), found '#'"},
      {"\xC3\xA9", 1, 1,
       "not a cv::FileStorage file: it must begin with '%YAML:1.0', '<?xml' or "
       "'{' (nothing before them, not even white space), found '\xC3\xA9'"},
      {"\x01", 1, 1,
       "not a cv::FileStorage file: it must begin with '%YAML:1.0', '<?xml' or '{' "
       "(nothing before them, not even white space), found byte 0x01"},
      {"", 1, 1,
       "not a cv::FileStorage file: it must begin with '%YAML:1.0', '<?xml' or '{' "
       "(nothing before them, not even white space), found the end of the file"},
  };
  testing::ExpectRefused(std::begin(cases), std::end(cases), Screen);
}

TEST_CASE("file storage screen: well-formed text passes, whatever its strings hold", "[vision]") {
  const char* const good[] = {
      // XML: declaration, comments, a processing instruction, references, CDATA, empty tags.
      "<?xml version=\"1.0\" encoding='UTF-8'?>\n<!-- c -->\n<?pi x?>\n<opencv_storage "
      "a=\"&lt;&#38;&#x26;\">t &amp; u<![CDATA[ <raw> & ]]><b/><c x='\"'></c></opencv_storage>\n"
      "<!-- after -->\n",
      "<?xml-stylesheet href='s.css'?>\n<a/>",      // not a declaration: a processing instruction
      "\xEF\xBB\xBF<?xml version=\"1.0\"?>\n<a/>",  // after a byte order mark
      // JSON: escapes, and brackets inside strings.
      "{\"a\": \"x\\\"y [{\", \"b\": [1, {\"c\": []}]}",
      // YAML: quotes and brackets inside plain scalars, tags, quoted strings, comments, entries
      // inside one another on one line, document markers.
      "%YAML:1.0\n---\na: it's fine\nb: x[1]\nc: \"q\\\"\" # ' [\nd: !!opencv-matrix\n"
      "  data: [1, 2, {e: 'it''s'}]\n- - - 1\n...\n",
      "%YAML:1.0\n--- # a comment after the marker\na: 1\n",
  };
  for (const char* text : good) {
    INFO(text);
    CHECK_NOTHROW(ScreenFileStorageText("good", text));
  }
}

}  // namespace
}  // namespace cfuse
