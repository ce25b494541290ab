// XML read with TinyXML, every problem located (internal to importers/; not installed, since it
// names TinyXML's types).
//
// TinyXML reports most syntax errors at their row and column, but none where its parser met the
// end of the text (an element left open: row 0), and it parses nested elements by recursion, so
// that 10^5 nested elements (300 KB) overflow the stack. ParseXml refuses nesting deeper than
// kMaxXmlDepth before TinyXML sees the text, and puts an error without a place at the end of the
// text, where the parser stopped.
#pragma once

#include <tinyxml.h>

#include <string>
#include <string_view>

namespace cfuse {

// Elements inside elements: URDF and ViSP's files nest 3 to 5 deep.
inline constexpr int kMaxXmlDepth = 256;

// Parses `text` (already checked by RequireText) into `doc`, or throws InputError at
// `file`:LINE:COLUMN: "not well-formed XML: ..." (TinyXML's words), or "elements nested more than
// 256 deep". A text without any element parses (doc->RootElement() is null).
void ParseXml(const std::string& file, std::string_view text, TiXmlDocument* doc);

}  // namespace cfuse
