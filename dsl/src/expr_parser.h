// Lexer and recursive-descent parser for the constraint strings of the model DSL.
//
// Syntax only: function names, reference targets and units are not checked here (the semantic
// pass does that), so a typo such as "distanse(a, b)" parses fine. Every node carries the byte
// span it came from so later passes can report file:line:column.
//
// Grammar (EBNF; whitespace = space, tab, CR, LF, insignificant between tokens):
//   constraint := expr ('==' | '<=' | '>=') expr
//               | expr 'in' '[' expr ',' expr ']'
//               | call                                 (whole text, e.g. "parallel(u, v)")
//   expr       := term (('+' | '-') term)*             (left-associative)
//   term       := unary (('*' | '/') unary)*           (left-associative)
//   unary      := ('-' | '+') unary | primary          (unary '+' is dropped)
//   primary    := number [unit]
//               | '[' expr ',' expr ',' expr ']' [unit] (vector literal)
//               | 'nominal'
//               | call
//               | ident ['.' ident]                     (reference, e.g. "lid.c3")
//               | '(' expr ')'
//   call       := ident '(' [expr (',' expr)*] ')'
//   unit       := ident                                 (not a keyword; "30 deg", "12.5mm")
//   number     := (digits ['.' [digits]] | '.' digits) [('e' | 'E') ['+' | '-'] digits]
//   ident      := [A-Za-z_][A-Za-z0-9_]*
// Keywords: 'in', 'nominal' (never a reference, call name or unit).
//
// Resource bounds: texts longer than kMaxExpressionLength bytes and nesting deeper than
// kMaxExpressionDepth (parentheses, calls, vectors and unary signs each add a level) are
// rejected with ExprSyntaxError, so hostile input cannot overflow the stack.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace cfuse {

inline constexpr int kMaxExpressionLength = 4096;
inline constexpr int kMaxExpressionDepth = 64;

// Byte range in the parsed string, 0-based.
struct Span {
  int offset = 0;
  int length = 0;
};

struct AstNode {
  enum class Kind { kNumber, kVector, kNominal, kRef, kCall, kUnary, kBinary };
  Kind kind;
  // Covers the whole sub-expression, including enclosing parentheses and (for kNumber/kVector)
  // the unit.
  Span span;
  double number = 0;   // kNumber: the value as written (no unit conversion).
  std::string unit;    // kNumber, kVector: unit identifier written after it, "" if none.
  Span unit_span;      // Where the unit is (length 0 if none).
  std::string name;    // kRef: first identifier; kCall: function name.
  std::string member;  // kRef: identifier after '.', "" if none (e.g. "lid.c3").
  char op = 0;         // kUnary: '-'; kBinary: '+', '-', '*', '/'.
  Span op_span;        // kBinary: where the operator is.
  // kVector: exactly 3 elements; kCall: the arguments (0 or more); kUnary: 1; kBinary: lhs, rhs.
  std::vector<std::unique_ptr<AstNode>> args;
};

struct AstConstraint {
  enum class Relation { kEqual, kLessEqual, kGreaterEqual, kIn, kCall };
  Relation relation;
  std::unique_ptr<AstNode> lhs, rhs;  // kEqual, kLessEqual, kGreaterEqual; kIn: lhs only.
  std::unique_ptr<AstNode> lo, hi;    // kIn: `lhs in [lo, hi]`.
  // kCall: the whole text is a single function call with no relation, e.g.
  // "parallel(a - b, c - d)" or "rigid(p1, p2, p3)"; call->kind == kCall.
  std::unique_ptr<AstNode> call;
  Span relation_span;  // The relation operator / `in` keyword (kCall: the call's name).
};

// Thrown for any syntax error. offset() is the 0-based byte offset of the offending token (the
// end of the string for an unexpected end); what() says what was expected and what was found,
// without location prefix, e.g. "expected ')' to close '(' at column 9, found ','".
class ExprSyntaxError : public std::runtime_error {
 public:
  ExprSyntaxError(int offset, const std::string& message);
  int offset() const;

 private:
  int offset_;
};

// e.what() for a message about a text whose byte 0 is at (line, column) of a file: a column of
// the text that the message names (e.g. "to close '(' at column 9") becomes the file's "line L,
// column C" when `exact` (the text appears verbatim there), else "column 9 of the expression".
std::string SyntaxMessageInFile(const ExprSyntaxError& e, int line, int column, bool exact);

// Parses a whole constraint string.
AstConstraint ParseConstraint(std::string_view text);

// Parses a bare expression; the whole string must be consumed.
std::unique_ptr<AstNode> ParseExpression(std::string_view text);

// Canonical re-printing, e.g. "distance(a.b, c) + 2 mm", parenthesised only where precedence
// requires. Meant for messages; re-parsing the result gives the same tree.
std::string ToString(const AstNode& node);

}  // namespace cfuse
