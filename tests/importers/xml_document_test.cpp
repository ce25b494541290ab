// XML parsed with every problem located (importers/src/xml_document.cpp): nesting counted
// before TinyXML recurses (comments, declarations, CDATA, quoted attribute values and empty
// elements not counted), refused at the element that goes too deep; TinyXML's errors at its row
// and column, and the ones it places nowhere at the end of the text.
#include "xml_document.h"

#include <catch2/catch.hpp>
#include <string>

#include "cfuse/kernel/error.h"

namespace cfuse {
namespace {

std::string Opened(int depth) {
  std::string s;
  for (int i = 0; i < depth; ++i) s += "<a>";
  return s;
}
std::string Closed(int depth) {
  std::string s;
  for (int i = 0; i < depth; ++i) s += "</a>";
  return s;
}

TEST_CASE("xml document: well-formed text parses, with or without an element", "[importers]") {
  TiXmlDocument doc;
  ParseXml("r.urdf", "<?xml version=\"1.0\"?>\n<robot name=\"r\"><link name=\"a\"/></robot>\n",
           &doc);
  REQUIRE(doc.RootElement() != nullptr);
  CHECK(std::string(doc.RootElement()->Value()) == "robot");
  CHECK(std::string(doc.RootElement()->Attribute("name")) == "r");
  TiXmlDocument empty;
  ParseXml("e.xml", "<?xml version=\"1.0\"?>\n<!-- nothing -->\n", &empty);
  CHECK(empty.RootElement() == nullptr);
}

TEST_CASE("xml document: nesting refused beyond 256 elements, at the element", "[importers]") {
  // 256 levels parse; the 257th is refused at its '<'.
  TiXmlDocument doc;
  CHECK_NOTHROW(ParseXml("d.xml", Opened(kMaxXmlDepth) + Closed(kMaxXmlDepth), &doc));
  try {
    TiXmlDocument deep;
    ParseXml("d.xml", "<?xml version=\"1.0\"?>\n" + Opened(kMaxXmlDepth + 1), &deep);
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(e.where().ToString() == "d.xml:2:" + std::to_string(3 * kMaxXmlDepth + 1));
    CHECK(e.message() == "elements nested more than 256 deep");
  }
  // What is not an element does not count: comments, CDATA, processing instructions, a
  // DOCTYPE, '<' in quoted attribute values, empty elements; closing tags count down.
  std::string text = "<!DOCTYPE r><r>";
  for (int i = 0; i < 300; ++i) {
    text += "<!-- <a> --><![CDATA[<a>]]><?pi <a>?><b x=\"<a>\" y='>'/><c>text</c>";
  }
  text += Opened(kMaxXmlDepth - 1) + Closed(kMaxXmlDepth - 1) + "</r>";
  TiXmlDocument many;
  CHECK_NOTHROW(ParseXml("m.xml", text, &many));
  CHECK(std::string(many.RootElement()->Value()) == "r");
}

TEST_CASE("xml document: TinyXML's errors, located", "[importers]") {
  // At TinyXML's row and column, its description without the final period.
  try {
    TiXmlDocument doc;
    ParseXml("x.xml", "<r>\n  <a b=\"1\" b>\n</r>\n", &doc);
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(e.where().ToString() == "x.xml:2:13");
    CHECK(e.message() == "not well-formed XML: Error reading Attributes");
  }
  // An element left open: TinyXML stops at the end of the text and says nowhere.
  for (const std::string text : {"<r>\n  <a>text", "<r>", "<r>\n<a/>"}) {
    INFO(text);
    try {
      TiXmlDocument doc;
      ParseXml("o.xml", text, &doc);
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().ToString() == LocationOfOffset("o.xml", text, text.size()).ToString());
      CHECK(e.message() == "not well-formed XML: the file ends inside an element left open");
    }
  }
}

}  // namespace
}  // namespace cfuse
