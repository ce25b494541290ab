#include "expr_parser.h"

#include <catch2/catch.hpp>
#include <ostream>
#include <string>

namespace {

using cfuse::AstConstraint;
using cfuse::AstNode;
using cfuse::ExprSyntaxError;
using cfuse::kMaxExpressionDepth;
using cfuse::kMaxExpressionLength;
using cfuse::ParseConstraint;
using cfuse::ParseExpression;
using cfuse::Span;
using cfuse::ToString;
using Kind = AstNode::Kind;
using Relation = AstConstraint::Relation;

// An error reduced to what the user sees, so one CHECK compares offset and message together.
struct Err {
  int offset;
  std::string message;
  bool operator==(const Err& o) const { return offset == o.offset && message == o.message; }
};

std::ostream& operator<<(std::ostream& os, const Err& e) {
  return os << "{" << e.offset << ", \"" << e.message << "\"}";
}

Err ConstraintError(const std::string& text) {
  try {
    ParseConstraint(text);
  } catch (const ExprSyntaxError& e) {
    return {e.offset(), e.what()};
  }
  return {-1, "no error"};
}

Err ExpressionError(const std::string& text) {
  try {
    ParseExpression(text);
  } catch (const ExprSyntaxError& e) {
    return {e.offset(), e.what()};
  }
  return {-1, "no error"};
}

std::string Canon(const std::string& text) { return ToString(*ParseExpression(text)); }

bool SpanIs(const Span& s, int offset, int length) {
  return s.offset == offset && s.length == length;
}

std::string Repeat(const std::string& s, int n) {
  std::string out;
  for (int i = 0; i < n; ++i) out += s;
  return out;
}

}  // namespace

TEST_CASE("expr_parser: numbers in every written form", "[dsl][expr_parser]") {
  auto n = ParseExpression("1e-3");
  REQUIRE(n->kind == Kind::kNumber);
  CHECK(n->number == 1e-3);
  CHECK(n->unit.empty());
  CHECK(SpanIs(n->span, 0, 4));
  CHECK(SpanIs(n->unit_span, 0, 0));

  CHECK(ParseExpression(".5")->number == 0.5);
  CHECK(ParseExpression("2.")->number == 2.0);
  CHECK(ParseExpression("0")->number == 0.0);
  CHECK(ParseExpression("1E3")->number == 1000.0);
  CHECK(ParseExpression("2.e1")->number == 20.0);
  CHECK(ParseExpression("007")->number == 7.0);
  // from_chars is correctly rounded: same double as the literal.
  CHECK(ParseExpression("0.1")->number == 0.1);
  CHECK(ParseExpression("123456789.123456789")->number == 123456789.123456789);
}

TEST_CASE("expr_parser: units on numbers", "[dsl][expr_parser]") {
  auto n = ParseExpression("1.5e+2mm");
  REQUIRE(n->kind == Kind::kNumber);
  CHECK(n->number == 150.0);  // As written: no unit conversion.
  CHECK(n->unit == "mm");
  CHECK(SpanIs(n->span, 0, 8));
  CHECK(SpanIs(n->unit_span, 6, 2));

  n = ParseExpression("  30   deg ");
  CHECK(n->number == 30.0);
  CHECK(n->unit == "deg");
  CHECK(SpanIs(n->span, 2, 8));
  CHECK(SpanIs(n->unit_span, 7, 3));

  n = ParseExpression("12.5mm");
  CHECK(n->number == 12.5);
  CHECK(n->unit == "mm");

  // An 'e' without exponent digits starts the unit instead.
  n = ParseExpression("1em");
  CHECK(n->number == 1.0);
  CHECK(n->unit == "em");
  n = ParseExpression("2.mm");
  CHECK(n->number == 2.0);
  CHECK(n->unit == "mm");

  // The unit binds to its number only, tighter than any operator.
  n = ParseExpression("2 mm * 3");
  REQUIRE(n->kind == Kind::kBinary);
  CHECK(n->args[0]->unit == "mm");
  CHECK(n->args[1]->unit.empty());
}

TEST_CASE("expr_parser: precedence and associativity", "[dsl][expr_parser]") {
  auto n = ParseExpression("a + b * c");
  REQUIRE(n->kind == Kind::kBinary);
  CHECK(n->op == '+');
  CHECK(n->args[0]->name == "a");
  REQUIRE(n->args[1]->kind == Kind::kBinary);
  CHECK(n->args[1]->op == '*');

  // Left-associative: (a - b) - c.
  n = ParseExpression("a - b - c");
  REQUIRE(n->kind == Kind::kBinary);
  CHECK(n->op == '-');
  REQUIRE(n->args[0]->kind == Kind::kBinary);
  CHECK(n->args[0]->op == '-');
  CHECK(n->args[1]->name == "c");
  CHECK(SpanIs(n->span, 0, 9));
  CHECK(SpanIs(n->args[0]->span, 0, 5));

  n = ParseExpression("a / b / c");
  REQUIRE(n->args[0]->kind == Kind::kBinary);
  CHECK(n->args[0]->op == '/');
  CHECK(n->args[1]->name == "c");

  CHECK(Canon("a + b * c") == "a + b * c");
  CHECK(Canon("(a + b) * c") == "(a + b) * c");
  CHECK(Canon("a * (b + c)") == "a * (b + c)");
  CHECK(Canon("a - (b - c)") == "a - (b - c)");
  CHECK(Canon("(a - b) - c") == "a - b - c");
  CHECK(Canon("a / (b * c)") == "a / (b * c)");
  CHECK(Canon("(a / b) * c") == "a / b * c");
  CHECK(Canon("((((a))))") == "a");
  CHECK(Canon("a*b+c/d-e") == "a * b + c / d - e");
}

TEST_CASE("expr_parser: parentheses widen the span", "[dsl][expr_parser]") {
  auto n = ParseExpression("(a + b) * c");
  REQUIRE(n->kind == Kind::kBinary);
  CHECK(SpanIs(n->span, 0, 11));
  CHECK(SpanIs(n->args[0]->span, 0, 7));
  CHECK(SpanIs(n->args[0]->args[0]->span, 1, 1));
}

TEST_CASE("expr_parser: unary minus and plus", "[dsl][expr_parser]") {
  auto n = ParseExpression("-a * b");
  REQUIRE(n->kind == Kind::kBinary);  // Unary binds tighter than '*'.
  CHECK(n->op == '*');
  REQUIRE(n->args[0]->kind == Kind::kUnary);
  CHECK(n->args[0]->op == '-');
  REQUIRE(n->args[0]->args.size() == 1);
  CHECK(n->args[0]->args[0]->name == "a");
  CHECK(SpanIs(n->args[0]->span, 0, 2));

  n = ParseExpression("-(a + b)");
  REQUIRE(n->kind == Kind::kUnary);
  CHECK(SpanIs(n->span, 0, 8));
  CHECK(n->args[0]->op == '+');
  CHECK(ToString(*n) == "-(a + b)");

  n = ParseExpression("- -3 mm");
  REQUIRE(n->kind == Kind::kUnary);
  REQUIRE(n->args[0]->kind == Kind::kUnary);
  CHECK(n->args[0]->args[0]->number == 3.0);
  CHECK(n->args[0]->args[0]->unit == "mm");
  CHECK(ToString(*n) == "--3 mm");

  // Unary plus is accepted and produces no node.
  n = ParseExpression("+a");
  CHECK(n->kind == Kind::kRef);
  CHECK(n->name == "a");
  n = ParseExpression("+-+a");
  REQUIRE(n->kind == Kind::kUnary);
  CHECK(n->args[0]->kind == Kind::kRef);

  CHECK(Canon("a - -b") == "a - -b");
  CHECK(Canon("a * -(b - c)") == "a * -(b - c)");
  CHECK(Canon("-nominal") == "-nominal");
}

TEST_CASE("expr_parser: vector literals", "[dsl][expr_parser]") {
  auto n = ParseExpression("[0, 0, 1] m");
  REQUIRE(n->kind == Kind::kVector);
  REQUIRE(n->args.size() == 3);
  CHECK(n->args[2]->number == 1.0);
  CHECK(n->unit == "m");
  CHECK(SpanIs(n->span, 0, 11));
  CHECK(SpanIs(n->unit_span, 10, 1));

  n = ParseExpression("[1 mm, -a.b, f(x) * 2]");
  REQUIRE(n->kind == Kind::kVector);
  CHECK(n->unit.empty());
  CHECK(n->args[0]->unit == "mm");
  CHECK(n->args[1]->kind == Kind::kUnary);
  CHECK(n->args[2]->kind == Kind::kBinary);
  CHECK(ToString(*n) == "[1 mm, -a.b, f(x) * 2]");

  CHECK(Canon("[[1,2,3],[4,5,6]mm,0]deg") == "[[1, 2, 3], [4, 5, 6] mm, 0] deg");
}

TEST_CASE("expr_parser: vector literal arity errors", "[dsl][expr_parser]") {
  CHECK(ExpressionError("[]") == Err{0, "a vector literal has 3 elements, found 0"});
  CHECK(ExpressionError("[1]") == Err{0, "a vector literal has 3 elements, found 1"});
  CHECK(ExpressionError("a + [1, 2] m") == Err{4, "a vector literal has 3 elements, found 2"});
  CHECK(ExpressionError("[1, 2, 3, 4]") == Err{0, "a vector literal has 3 elements, found 4"});
  CHECK(ExpressionError("[1, 2,]") == Err{6, "expected an expression after ',', found ']'"});
  CHECK(ExpressionError("[1, 2 3]") ==
        Err{6, "expected ',' or ']' to close '[' at column 1, found '3'"});
  CHECK(ExpressionError("[1, 2, 3") ==
        Err{8, "expected ',' or ']' to close '[' at column 1, found end of expression"});
}

TEST_CASE("expr_parser: references", "[dsl][expr_parser]") {
  auto n = ParseExpression("lid");
  REQUIRE(n->kind == Kind::kRef);
  CHECK(n->name == "lid");
  CHECK(n->member.empty());
  CHECK(SpanIs(n->span, 0, 3));

  n = ParseExpression(" lid.c3 ");
  REQUIRE(n->kind == Kind::kRef);
  CHECK(n->name == "lid");
  CHECK(n->member == "c3");
  CHECK(SpanIs(n->span, 1, 6));
  CHECK(ToString(*n) == "lid.c3");

  n = ParseExpression("_a1.B_2");
  CHECK(n->name == "_a1");
  CHECK(n->member == "B_2");

  n = ParseExpression("nominal");
  CHECK(n->kind == Kind::kNominal);
  CHECK(SpanIs(n->span, 0, 7));

  CHECK(ExpressionError("a.b.c") ==
        Err{3, "a reference has at most one member ('a.b'), found another '.'"});
  CHECK(ExpressionError("a.") ==
        Err{2, "expected a member name after 'a.', found end of expression"});
  CHECK(ExpressionError("a.in") == Err{2, "expected a member name after 'a.', found 'in'"});
  CHECK(ExpressionError("in") == Err{0, "expected an expression, found keyword 'in'"});
  CHECK(ExpressionError("nominal.x") ==
        Err{7, "'nominal' is a keyword and takes no member, found '.'"});
  CHECK(ExpressionError("nominal(x)") ==
        Err{7, "'nominal' is a keyword and takes no arguments, found '('"});
}

TEST_CASE("expr_parser: calls with 0..n arguments", "[dsl][expr_parser]") {
  auto n = ParseExpression("now()");
  REQUIRE(n->kind == Kind::kCall);
  CHECK(n->name == "now");
  CHECK(n->args.empty());
  CHECK(SpanIs(n->span, 0, 5));

  n = ParseExpression("abs(x)");
  REQUIRE(n->kind == Kind::kCall);
  REQUIRE(n->args.size() == 1);
  CHECK(n->args[0]->name == "x");

  n = ParseExpression("distance(a.b, c)");
  REQUIRE(n->args.size() == 2);
  CHECK(n->args[0]->member == "b");
  CHECK(SpanIs(n->span, 0, 16));

  n = ParseExpression("f(1, g(2, 3), [4, 5, 6], -x, y.z)");
  REQUIRE(n->args.size() == 5);
  CHECK(n->args[1]->kind == Kind::kCall);
  CHECK(n->args[1]->args.size() == 2);
  CHECK(n->args[2]->kind == Kind::kVector);
  CHECK(n->args[3]->kind == Kind::kUnary);
  CHECK(n->args[4]->kind == Kind::kRef);

  CHECK(Canon("distance(a.b,c)+2mm") == "distance(a.b, c) + 2 mm");
  CHECK(Canon("f ( )") == "f()");

  CHECK(ExpressionError("f(a b)") ==
        Err{4, "expected ',' or ')' to close 'f(' at column 2, found 'b'"});
  CHECK(ExpressionError("f(a,)") == Err{4, "expected an expression after ',', found ')'"});
  CHECK(ExpressionError("f(,a)") == Err{2, "expected an expression after '(', found ','"});
  CHECK(ExpressionError("f(1)(2)") == Err{4, "unexpected '(' after the end of the expression"});
}

TEST_CASE("expr_parser: relations", "[dsl][expr_parser]") {
  AstConstraint c = ParseConstraint("distance(a, b) == 3 mm");
  CHECK(c.relation == Relation::kEqual);
  REQUIRE(c.lhs);
  REQUIRE(c.rhs);
  CHECK(c.lhs->kind == Kind::kCall);  // A call followed by a relation is an ordinary lhs.
  CHECK(c.rhs->number == 3.0);
  CHECK(c.rhs->unit == "mm");
  CHECK_FALSE(c.call);
  CHECK_FALSE(c.lo);
  CHECK_FALSE(c.hi);
  CHECK(SpanIs(c.relation_span, 15, 2));

  c = ParseConstraint("a<=b");
  CHECK(c.relation == Relation::kLessEqual);
  CHECK(SpanIs(c.relation_span, 1, 2));
  CHECK(c.lhs->name == "a");
  CHECK(c.rhs->name == "b");

  c = ParseConstraint("angle(u, v) >= 30 deg");
  CHECK(c.relation == Relation::kGreaterEqual);
  CHECK(SpanIs(c.relation_span, 12, 2));
  CHECK(c.rhs->unit == "deg");

  // Newlines and tabs are whitespace.
  c = ParseConstraint("a\n==\tb");
  CHECK(c.relation == Relation::kEqual);
  CHECK(SpanIs(c.relation_span, 2, 2));
}

TEST_CASE("expr_parser: in [lo, hi]", "[dsl][expr_parser]") {
  AstConstraint c = ParseConstraint("gap(a, b) in [1 mm, 2.5 mm]");
  CHECK(c.relation == Relation::kIn);
  REQUIRE(c.lhs);
  CHECK(c.lhs->name == "gap");
  CHECK_FALSE(c.rhs);
  REQUIRE(c.lo);
  REQUIRE(c.hi);
  CHECK(c.lo->number == 1.0);
  CHECK(c.lo->unit == "mm");
  CHECK(c.hi->number == 2.5);
  CHECK(SpanIs(c.relation_span, 10, 2));

  // A keyword is never a unit, so a bare number can be the lhs.
  c = ParseConstraint("3 in [-1, 5]");
  CHECK(c.relation == Relation::kIn);
  CHECK(c.lhs->number == 3.0);
  CHECK(c.lhs->unit.empty());
  CHECK(c.lo->kind == Kind::kUnary);

  // Bounds may be vectors.
  c = ParseConstraint("p in [[0,0,0] m, [1,1,1] m]");
  CHECK(c.lo->kind == Kind::kVector);
  CHECK(c.hi->unit == "m");

  CHECK(ConstraintError("x in 1") == Err{5, "expected '[' after 'in', found '1'"});
  CHECK(ConstraintError("x in [1]") ==
        Err{7, "expected ',' between the bounds of 'in [lo, hi]', found ']'"});
  CHECK(ConstraintError("x in [1, 2, 3]") ==
        Err{10, "'in' takes exactly two bounds '[lo, hi]', found ','"});
  CHECK(ConstraintError("x in [1, 2") ==
        Err{10, "expected ']' to close '[' at column 6, found end of expression"});
  CHECK(ConstraintError("x in [1, 2] mm") ==
        Err{12,
            "unexpected 'mm' after the end of the expression (a unit goes on each bound, e.g. "
            "'in [1 mm, 2 mm]')"});
  CHECK(ConstraintError("x in") == Err{4, "expected '[' after 'in', found end of expression"});
}

TEST_CASE("expr_parser: relation-call form", "[dsl][expr_parser]") {
  AstConstraint c = ParseConstraint("parallel(a - b, c - d)");
  CHECK(c.relation == Relation::kCall);
  REQUIRE(c.call);
  CHECK(c.call->kind == Kind::kCall);
  CHECK(c.call->name == "parallel");
  CHECK(c.call->args.size() == 2);
  CHECK_FALSE(c.lhs);
  CHECK_FALSE(c.rhs);
  CHECK(SpanIs(c.relation_span, 0, 8));

  c = ParseConstraint("  rigid(p1, p2, p3)  ");
  CHECK(c.relation == Relation::kCall);
  CHECK(c.call->args.size() == 3);
  CHECK(SpanIs(c.relation_span, 2, 5));

  // Redundant parentheses do not change the tree, so they do not change the form either.
  c = ParseConstraint("(coplanar(a, b))");
  CHECK(c.relation == Relation::kCall);
  CHECK(SpanIs(c.relation_span, 1, 8));

  // Anything other than a single call needs a relation.
  CHECK(ConstraintError("parallel(a, b) + 1") ==
        Err{18,
            "expected a relation ('==', '<=', '>=' or 'in') after the expression, found end of "
            "expression"});
  CHECK(ConstraintError("-parallel(a, b)") ==
        Err{15,
            "expected a relation ('==', '<=', '>=' or 'in') after the expression, found end of "
            "expression"});
  CHECK(ConstraintError("parallel(a, b) x") ==
        Err{15, "expected an operator or a relation ('==', '<=', '>=' or 'in'), found 'x'"});
}

TEST_CASE("expr_parser: unexpected characters", "[dsl][expr_parser]") {
  CHECK(ConstraintError("a $ b") == Err{2, "unexpected character '$'"});
  CHECK(ConstraintError("a == b;") == Err{6, "unexpected character ';'"});
  CHECK(ConstraintError("a = b") == Err{2, "unexpected character '=' (use '==' for equality)"});
  CHECK(ConstraintError("a < b") ==
        Err{2, "unexpected character '<' (use '<=': strict '<' is not supported)"});
  CHECK(ConstraintError("a > b") ==
        Err{2, "unexpected character '>' (use '>=': strict '>' is not supported)"});
  CHECK(ConstraintError("a != b") ==
        Err{2, "unexpected character '!' (relations are '==', '<=', '>=' and 'in')"});
  CHECK(ConstraintError("a === b") == Err{4, "unexpected character '=' (use '==' for equality)"});
  CHECK(ConstraintError("a =< b") == Err{2, "unexpected character '=' (use '==' for equality)"});
  CHECK(ConstraintError("a ^ 2 == b") == Err{2, "unexpected character '^'"});
  CHECK(ConstraintError("\xC3\xA9 == 1") ==
        Err{0, "unexpected byte 0xC3 (only ASCII is allowed in expressions)"});
  CHECK(ConstraintError("a ==\x01 b") == Err{4, "unexpected control character 0x01"});
}

TEST_CASE("expr_parser: malformed numbers", "[dsl][expr_parser]") {
  CHECK(ExpressionError("1e999") == Err{0, "number '1e999' is out of the range of a double"});
  CHECK(ExpressionError("2 * 1.2.3") == Err{7, "unexpected '.3' after the end of the expression"});
  CHECK(ExpressionError("1..2") == Err{2, "unexpected '.2' after the end of the expression"});
}

TEST_CASE("expr_parser: unexpected end and unbalanced parentheses", "[dsl][expr_parser]") {
  CHECK(ExpressionError("a +") ==
        Err{3, "expected an expression after '+', found end of expression"});
  CHECK(ExpressionError("2 *   ") ==
        Err{6, "expected an expression after '*', found end of expression"});
  CHECK(ExpressionError("-") ==
        Err{1, "expected an expression after '-', found end of expression"});
  CHECK(ExpressionError("(a + b") ==
        Err{6, "expected ')' to close '(' at column 1, found end of expression"});
  CHECK(ExpressionError("5 * (a") ==
        Err{6, "expected ')' to close '(' at column 5, found end of expression"});
  CHECK(ExpressionError("distance(a, b") ==
        Err{13, "expected ',' or ')' to close 'distance(' at column 9, found end of expression"});
  CHECK(ConstraintError("(a, b) == c") ==
        Err{2, "expected ')' to close '(' at column 1, found ','"});
  CHECK(ConstraintError("(a == b)") == Err{3, "expected ')' to close '(' at column 1, found '=='"});
  CHECK(ExpressionError("a + b)") == Err{5, "unmatched ')'"});
  CHECK(ConstraintError("a + b) == c") == Err{5, "unmatched ')'"});
  CHECK(ConstraintError("a == b)") == Err{6, "unmatched ')'"});
  CHECK(ConstraintError("a == b]") == Err{6, "unmatched ']'"});
  CHECK(ExpressionError(")") == Err{0, "expected an expression, found ')'"});
  CHECK(ExpressionError("()") == Err{1, "expected an expression after '(', found ')'"});
}

TEST_CASE("expr_parser: trailing tokens", "[dsl][expr_parser]") {
  CHECK(ExpressionError("a b") == Err{2, "unexpected 'b' after the end of the expression"});
  CHECK(ExpressionError("2 mm 3") == Err{5, "unexpected '3' after the end of the expression"});
  CHECK(ExpressionError("a == b") == Err{2, "unexpected '==' after the end of the expression"});
  CHECK(ConstraintError("a == b c") == Err{7, "unexpected 'c' after the end of the expression"});
  CHECK(ConstraintError("a == b nominal") ==
        Err{7, "unexpected 'nominal' after the end of the expression"});
  CHECK(ConstraintError("a b == c") ==
        Err{2, "expected an operator or a relation ('==', '<=', '>=' or 'in'), found 'b'"});
}

TEST_CASE("expr_parser: one relation only, and it needs a rhs", "[dsl][expr_parser]") {
  CHECK(ConstraintError("a == b == c") ==
        Err{7, "a constraint has only one relation, found a second '=='"});
  CHECK(ConstraintError("a <= b <= c") ==
        Err{7, "a constraint has only one relation, found a second '<='"});
  CHECK(ConstraintError("a == b in [1, 2]") ==
        Err{7, "a constraint has only one relation, found a second 'in'"});
  CHECK(ConstraintError("x in [1, 2] == 3") ==
        Err{12, "a constraint has only one relation, found a second '=='"});
  CHECK(ConstraintError("distance(a,b) ==") ==
        Err{16, "expected an expression after '==', found end of expression"});
  CHECK(ConstraintError("a >= ") ==
        Err{5, "expected an expression after '>=', found end of expression"});
  CHECK(ConstraintError("a == in") ==
        Err{5, "expected an expression after '==', found keyword 'in'"});
  CHECK(ConstraintError("== b") == Err{0, "expected an expression, found '=='"});
  CHECK(ConstraintError("a + b") ==
        Err{5,
            "expected a relation ('==', '<=', '>=' or 'in') after the expression, found end of "
            "expression"});
}

TEST_CASE("expr_parser: empty input", "[dsl][expr_parser]") {
  CHECK(ConstraintError("") == Err{0, "empty expression"});
  CHECK(ConstraintError(" \t\n ") == Err{0, "empty expression"});
  CHECK(ExpressionError("") == Err{0, "empty expression"});
}

TEST_CASE("expr_parser: length limit", "[dsl][expr_parser]") {
  // Exactly at the limit is fine: "1+1+...+1" padded with spaces.
  std::string at_limit = "a == 1";
  at_limit += std::string(kMaxExpressionLength - at_limit.size(), ' ');
  REQUIRE(at_limit.size() == 4096u);
  CHECK(ParseConstraint(at_limit).relation == Relation::kEqual);

  const std::string too_long = at_limit + " ";
  CHECK(ConstraintError(too_long) == Err{4096, "expression is 4097 bytes long; the limit is 4096"});
  CHECK(ExpressionError(std::string(10000, '1')) ==
        Err{4096, "expression is 10000 bytes long; the limit is 4096"});

  // A long flat chain is not nesting: it parses and prints without trouble.
  const std::string chain = "1" + Repeat(" + 1", 1000);
  auto n = ParseExpression(chain);
  CHECK(n->kind == Kind::kBinary);
  CHECK(ToString(*n) == chain);
}

TEST_CASE("expr_parser: nesting depth limit", "[dsl][expr_parser]") {
  const int max = kMaxExpressionDepth;
  REQUIRE(max == 64);
  const std::string too_deep =
      "expression nested too deeply at '(' (more than 64 levels of "
      "parentheses, calls, vectors or signs)";

  // Parentheses: 64 levels parse, the 65th '(' (offset 64) is rejected.
  CHECK(ParseExpression(Repeat("(", max) + "a" + Repeat(")", max))->name == "a");
  CHECK(ExpressionError(Repeat("(", max + 1) + "a" + Repeat(")", max + 1)) == Err{64, too_deep});
  CHECK(ExpressionError(Repeat("(", 100) + "a" + Repeat(")", 100)) == Err{64, too_deep});
  CHECK(ExpressionError(Repeat("(", 4000)) == Err{64, too_deep});

  // Unary signs each add a level.
  const std::string too_deep_minus =
      "expression nested too deeply at '-' (more than 64 levels of "
      "parentheses, calls, vectors or signs)";
  CHECK(ParseExpression(Repeat("-", max) + "a")->kind == Kind::kUnary);
  CHECK(ExpressionError(Repeat("-", 100) + "a") == Err{64, too_deep_minus});
  CHECK(ExpressionError(Repeat("- ", 2000) + "a") == Err{128, too_deep_minus});
  CHECK(ExpressionError(Repeat("+", 100) + "a") ==
        Err{64,
            "expression nested too deeply at '+' (more than 64 levels of parentheses, calls, "
            "vectors or signs)"});

  // Calls: the level opens at the '(' after the name; "f(" is 2 bytes.
  CHECK(ParseExpression(Repeat("f(", max) + "x" + Repeat(")", max))->kind == Kind::kCall);
  CHECK(ExpressionError(Repeat("f(", 100) + "x" + Repeat(")", 100)) == Err{129, too_deep});

  // Vectors: "[0,0," is 5 bytes per level.
  CHECK(ExpressionError(Repeat("[0,0,", 100) + "1" + Repeat("]", 100)) ==
        Err{320,
            "expression nested too deeply at '[' (more than 64 levels of parentheses, calls, "
            "vectors or signs)"});

  // Mixed constructs share one budget.
  CHECK(ExpressionError(Repeat("-(", 40) + "a" + Repeat(")", 40)) == Err{64, too_deep_minus});

  // Depth is nesting, not a running count: many siblings at shallow depth are fine.
  CHECK(ParseConstraint(Repeat("(a) + ", 200) + "a == 1").relation == Relation::kEqual);
}

TEST_CASE("expr_parser: ToString round-trips", "[dsl][expr_parser]") {
  const char* const inputs[] = {
      "distance(a.b, c) + 2 mm",
      "a - (b - c) * -(d + e) / f",
      "[1, 2, 3] m - p.origin",
      "-(-x)",
      "f() * g(1, [0, 0, 1], nominal)",
      "1e-07 + 1e+20 + 0.001 + 150 mm",
      "a / (b / c)",
  };
  for (const char* text : inputs) {
    INFO(text);
    const std::string once = Canon(text);
    CHECK(Canon(once) == once);
  }
  CHECK(Canon("-(-x)") == "--x");
  CHECK(Canon("1.5e+2mm") == "150 mm");
  CHECK(Canon("1e-3") == "0.001");
  CHECK(Canon(".5") == "0.5");
  CHECK(Canon("2.") == "2");
  CHECK(Canon("1e20") == "1e+20");
}
