// Fuzz target: the constraint-expression parser on its own (faster than through YAML). Every
// expression accepted must print canonically: the printed text parses to the same print.
#include "expr_parser.h"
#include "fuzz/fuzz_util.h"

namespace {

void CheckCanonical(const cfuse::AstNode* node) {
  using namespace cfuse;
  if (node == nullptr) return;
  const std::string printed = ToString(*node);
  // The print spaces its operators, so it may outgrow the length bound that the text met.
  if (printed.size() > static_cast<size_t>(kMaxExpressionLength)) return;
  std::string reprinted;
  try {
    reprinted = ToString(*ParseExpression(printed));
  } catch (const ExprSyntaxError& e) {
    fuzz::Finding("canonical print does not parse", printed + " : " + e.what());
  }
  if (reprinted != printed) fuzz::Finding("print is not canonical", printed + " -> " + reprinted);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace cfuse;
  if (size > fuzz::kMaxFuzzInput) return 0;
  const std::string_view text = fuzz::AsText(data, size);
  try {
    const AstConstraint c = ParseConstraint(text);
    for (const auto* node : {&c.lhs, &c.rhs, &c.lo, &c.hi, &c.call}) CheckCanonical(node->get());
  } catch (const ExprSyntaxError& e) {
    if (e.offset() < 0 || static_cast<size_t>(e.offset()) > text.size()) {
      fuzz::Finding("syntax error offset outside the text", e.what());
    }
  } catch (const std::exception& e) {
    fuzz::Finding("exception other than ExprSyntaxError", e.what());
  }
  try {
    CheckCanonical(ParseExpression(text).get());
  } catch (const ExprSyntaxError&) {
  } catch (const std::exception& e) {
    fuzz::Finding("exception other than ExprSyntaxError", e.what());
  }
  return 0;
}
