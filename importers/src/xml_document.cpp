#include "xml_document.h"

#include <fmt/format.h>

#include <cctype>

#include "cfuse/kernel/error.h"

namespace cfuse {
namespace {

// Where an element opens TinyXML's way (TiXmlNode::Identify): '<' then a letter, '_' or a byte
// of a UTF-8 sequence; ':' counted too, to count no fewer elements than TinyXML parses.
bool OpensElement(std::string_view text, size_t i) {
  if (i + 1 >= text.size()) return false;
  const unsigned char c = static_cast<unsigned char>(text[i + 1]);
  return std::isalpha(c) || c == '_' || c == ':' || c >= 0x80;
}

// Skips from `from` past `end`, or to the end of the text.
size_t Past(std::string_view text, size_t from, std::string_view end) {
  const size_t at = text.find(end, from);
  return at == std::string_view::npos ? text.size() : at + end.size();
}

// The offset of the first element nested deeper than kMaxXmlDepth, or npos. A count, not a
// parse: quotes matter only in a start tag's attribute values, as TinyXML reads them.
size_t TooDeep(std::string_view text) {
  int depth = 0;
  for (size_t i = 0; i < text.size();) {
    if (text[i] != '<') {
      ++i;
    } else if (text.substr(i).starts_with("<!--")) {
      i = Past(text, i + 4, "-->");
    } else if (text.substr(i).starts_with("<![CDATA[")) {
      i = Past(text, i + 9, "]]>");
    } else if (text.substr(i).starts_with("<?")) {
      i = Past(text, i + 2, "?>");
    } else if (text.substr(i).starts_with("</")) {
      if (depth > 0) --depth;
      i = Past(text, i + 2, ">");
    } else if (OpensElement(text, i)) {
      const size_t open = i++;
      bool after_equals = false;
      while (i < text.size() && text[i] != '>') {
        const char c = text[i];
        if (after_equals && (c == '"' || c == '\'')) {
          i = Past(text, i + 1, std::string_view(&c, 1));
          after_equals = false;
          continue;
        }
        if (c == '=')
          after_equals = true;
        else if (c != ' ' && c != '\t' && c != '\r' && c != '\n')
          after_equals = false;
        ++i;
      }
      const bool empty = i < text.size() && text[i - 1] == '/';
      if (!empty && ++depth > kMaxXmlDepth) return open;
      if (i < text.size()) ++i;
    } else {
      i = Past(text, i + 1, ">");  // `<!DOCTYPE ...>` and what TinyXML takes as unknown
    }
  }
  return std::string_view::npos;
}

}  // namespace

void ParseXml(const std::string& file, std::string_view text, TiXmlDocument* doc) {
  if (const size_t at = TooDeep(text); at != std::string_view::npos) {
    throw InputError(LocationOfOffset(file, text, at),
                     fmt::format("elements nested more than {} deep", kMaxXmlDepth));
  }
  doc->Parse(std::string(text).c_str(), nullptr, TIXML_ENCODING_UTF8);
  if (!doc->Error()) return;
  // Row 0: TinyXML stopped at the end of the text, inside something left open.
  const bool at_end = doc->ErrorRow() <= 0;
  const SourceLocation where = at_end ? LocationOfOffset(file, text, text.size())
                                      : SourceLocation(file, doc->ErrorRow(), doc->ErrorCol());
  const bool open_element = doc->ErrorId() == TiXmlBase::TIXML_ERROR_READING_ELEMENT_VALUE ||
                            doc->ErrorId() == TiXmlBase::TIXML_ERROR_READING_END_TAG;
  std::string_view desc = doc->ErrorDesc();
  if (desc.ends_with('.')) desc.remove_suffix(1);
  throw InputError(where, at_end && open_element
                              ? "not well-formed XML: the file ends inside an element left open"
                              : fmt::format("not well-formed XML: {}", desc));
}

}  // namespace cfuse
