#include "expr_parser.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <string>
#include <system_error>
#include <utility>

namespace cfuse {

ExprSyntaxError::ExprSyntaxError(int offset, const std::string& message)
    : std::runtime_error(message), offset_(offset) {}

int ExprSyntaxError::offset() const { return offset_; }

namespace {

// ---------------------------------------------------------------------------------------------
// Lexer

enum class Tok {
  kEnd,
  kNumber,
  kIdent,
  kIn,       // keyword 'in'
  kNominal,  // keyword 'nominal'
  kLParen,
  kRParen,
  kLBracket,
  kRBracket,
  kComma,
  kDot,
  kPlus,
  kMinus,
  kStar,
  kSlash,
  kEqEq,
  kLessEq,
  kGreaterEq,
};

struct Token {
  Tok kind = Tok::kEnd;
  int offset = 0;
  int length = 0;
  std::string_view text;
  double number = 0;  // kNumber only.
};

bool IsDigit(char c) { return c >= '0' && c <= '9'; }
bool IsIdentStart(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool IsIdentChar(char c) { return IsIdentStart(c) || IsDigit(c); }
bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

std::string DescribeBadChar(char c) {
  const auto u = static_cast<unsigned char>(c);
  char hex[8];
  std::snprintf(hex, sizeof(hex), "0x%02X", static_cast<unsigned>(u));
  if (u >= 0x80) {
    return std::string("unexpected byte ") + hex + " (only ASCII is allowed in expressions)";
  }
  if (u < 0x20 || u == 0x7F) return std::string("unexpected control character ") + hex;
  std::string msg = std::string("unexpected character '") + c + "'";
  // Single-character forms of the relations are the likeliest typos; point at the real ones.
  if (c == '=') msg += " (use '==' for equality)";
  if (c == '<') msg += " (use '<=': strict '<' is not supported)";
  if (c == '>') msg += " (use '>=': strict '>' is not supported)";
  if (c == '!') msg += " (relations are '==', '<=', '>=' and 'in')";
  return msg;
}

// Single-character tokens, and the relations: first character followed by '='.
constexpr std::string_view kPunctuators = "()[],.+-*/";
constexpr Tok kPunctuatorKinds[] = {Tok::kLParen, Tok::kRParen, Tok::kLBracket, Tok::kRBracket,
                                    Tok::kComma,  Tok::kDot,    Tok::kPlus,     Tok::kMinus,
                                    Tok::kStar,   Tok::kSlash};
constexpr std::string_view kRelationStarts = "=<>";
constexpr Tok kRelationKinds[] = {Tok::kEqEq, Tok::kLessEq, Tok::kGreaterEq};

std::vector<Token> Lex(std::string_view text) {
  std::vector<Token> tokens;
  const int n = static_cast<int>(text.size());
  int i = 0;
  auto push = [&](Tok kind, int start, int end) {
    Token t;
    t.kind = kind;
    t.offset = start;
    t.length = end - start;
    t.text = text.substr(start, end - start);
    tokens.push_back(t);
  };
  while (i < n) {
    const char c = text[i];
    if (IsSpace(c)) {
      ++i;
      continue;
    }
    const int start = i;
    if (IsDigit(c) || (c == '.' && i + 1 < n && IsDigit(text[i + 1]))) {
      while (i < n && IsDigit(text[i])) ++i;
      if (i < n && text[i] == '.') {
        ++i;
        while (i < n && IsDigit(text[i])) ++i;
      }
      // The exponent only counts if digits follow, so "1em" is the number 1 with unit "em".
      if (i < n && (text[i] == 'e' || text[i] == 'E')) {
        int j = i + 1;
        if (j < n && (text[j] == '+' || text[j] == '-')) ++j;
        if (j < n && IsDigit(text[j])) {
          while (j < n && IsDigit(text[j])) ++j;
          i = j;
        }
      }
      push(Tok::kNumber, start, i);
      Token& t = tokens.back();
      const char* first = text.data() + start;
      const char* last = text.data() + i;
      const auto [ptr, ec] = std::from_chars(first, last, t.number, std::chars_format::general);
      if (ec == std::errc::result_out_of_range) {
        throw ExprSyntaxError(
            start, "number '" + std::string(t.text) + "' is out of the range of a double");
      }
      if (ec != std::errc() || ptr != last) {
        throw ExprSyntaxError(start, "malformed number '" + std::string(t.text) + "'");
      }
      continue;
    }
    if (IsIdentStart(c)) {
      while (i < n && IsIdentChar(text[i])) ++i;
      const std::string_view word = text.substr(start, i - start);
      Tok kind = Tok::kIdent;
      if (word == "in") kind = Tok::kIn;
      if (word == "nominal") kind = Tok::kNominal;
      push(kind, start, i);
      continue;
    }
    Tok kind = Tok::kEnd;
    int len = 1;
    if (const size_t k = kPunctuators.find(c); k != std::string_view::npos) {
      kind = kPunctuatorKinds[k];
    } else if (i + 1 < n && text[i + 1] == '=') {
      const size_t r = kRelationStarts.find(c);
      if (r != std::string_view::npos) {
        kind = kRelationKinds[r];
        len = 2;
      }
    }
    if (kind == Tok::kEnd) throw ExprSyntaxError(start, DescribeBadChar(c));
    i += len;
    push(kind, start, i);
  }
  push(Tok::kEnd, n, n);
  return tokens;
}

std::string Describe(const Token& t) {
  if (t.kind == Tok::kEnd) return "end of expression";
  return "'" + std::string(t.text) + "'";
}

std::string Column(int offset) { return "column " + std::to_string(offset + 1); }

bool IsRelation(Tok k) {
  return k == Tok::kEqEq || k == Tok::kLessEq || k == Tok::kGreaterEq || k == Tok::kIn;
}

// ---------------------------------------------------------------------------------------------
// Parser

std::unique_ptr<AstNode> MakeNode(AstNode::Kind kind, int offset) {
  auto node = std::make_unique<AstNode>();
  node->kind = kind;
  node->span.offset = offset;
  return node;
}

class Parser {
 public:
  explicit Parser(std::string_view text) {
    if (text.size() > static_cast<size_t>(kMaxExpressionLength)) {
      throw ExprSyntaxError(kMaxExpressionLength, "expression is " + std::to_string(text.size()) +
                                                      " bytes long; the limit is " +
                                                      std::to_string(kMaxExpressionLength));
    }
    tokens_ = Lex(text);
    if (tokens_.size() == 1) throw ExprSyntaxError(0, "empty expression");
  }

  AstConstraint ParseConstraint() {
    AstConstraint c;
    std::unique_ptr<AstNode> lhs = ParseExpr();
    const Token& t = Peek();
    if (t.kind == Tok::kEnd) {
      if (lhs->kind != AstNode::Kind::kCall) {
        throw ExprSyntaxError(t.offset,
                              "expected a relation ('==', '<=', '>=' or 'in') after the "
                              "expression, found end of expression");
      }
      c.relation = AstConstraint::Relation::kCall;
      // The name is the first identifier: only '(' can precede it in "((f(x)))".
      for (const Token& tok : tokens_) {
        if (tok.kind == Tok::kIdent) {
          c.relation_span = {tok.offset, tok.length};
          break;
        }
      }
      c.call = std::move(lhs);
      return c;
    }
    if (!IsRelation(t.kind)) {
      RejectUnmatchedClose(t);
      throw ExprSyntaxError(t.offset,
                            "expected an operator or a relation ('==', '<=', '>=' or 'in'), "
                            "found " +
                                Describe(t));
    }
    const Token rel = Next();
    c.relation_span = {rel.offset, rel.length};
    c.lhs = std::move(lhs);
    switch (rel.kind) {
      case Tok::kEqEq:
        c.relation = AstConstraint::Relation::kEqual;
        break;
      case Tok::kLessEq:
        c.relation = AstConstraint::Relation::kLessEqual;
        break;
      case Tok::kGreaterEq:
        c.relation = AstConstraint::Relation::kGreaterEqual;
        break;
      default:
        c.relation = AstConstraint::Relation::kIn;
        break;
    }
    if (rel.kind == Tok::kIn) {
      const Token open = Expect(Tok::kLBracket, "expected '[' after 'in'");
      c.lo = ParseExpr();
      if (Peek().kind != Tok::kComma) {
        throw ExprSyntaxError(Peek().offset,
                              "expected ',' between the bounds of 'in [lo, hi]', "
                              "found " +
                                  Describe(Peek()));
      }
      Next();
      c.hi = ParseExpr();
      if (Peek().kind == Tok::kComma) {
        throw ExprSyntaxError(Peek().offset, "'in' takes exactly two bounds '[lo, hi]', found ','");
      }
      Expect(Tok::kRBracket, "expected ']' to close '[' at " + Column(open.offset));
      if (Peek().kind == Tok::kIdent) {
        throw ExprSyntaxError(Peek().offset, "unexpected " + Describe(Peek()) +
                                                 " after the end of the expression (a unit goes "
                                                 "on each bound, e.g. 'in [1 mm, 2 mm]')");
      }
    } else {
      c.rhs = ParseExpr();
    }
    const Token& after = Peek();
    // "1.2 in" meant as inches reads as a second relation 'in' with no range after it.
    if (after.kind == Tok::kIn && pos_ + 1 < tokens_.size() &&
        tokens_[pos_ + 1].kind != Tok::kLBracket) {
      throw ExprSyntaxError(after.offset,
                            "'in' is not a unit: the units are m, cm, mm, rad and deg (no inches); "
                            "'in' is the range relation, as in 'x in [lo, hi]'");
    }
    if (IsRelation(after.kind)) {
      throw ExprSyntaxError(
          after.offset, "a constraint has only one relation, found a second " + Describe(after));
    }
    RejectTrailing();
    return c;
  }

  std::unique_ptr<AstNode> ParseWholeExpression() {
    std::unique_ptr<AstNode> node = ParseExpr();
    RejectTrailing();
    return node;
  }

 private:
  // Counts one nesting level for as long as it lives; the limit keeps recursion bounded.
  class DepthGuard {
   public:
    DepthGuard(Parser& p, const Token& at) : p_(p) {
      if (++p_.depth_ > kMaxExpressionDepth) {
        throw ExprSyntaxError(at.offset, "expression nested too deeply at " + Describe(at) +
                                             " (more than " + std::to_string(kMaxExpressionDepth) +
                                             " levels of parentheses, calls, vectors or signs)");
      }
    }
    ~DepthGuard() { --p_.depth_; }
    DepthGuard(const DepthGuard&) = delete;
    DepthGuard& operator=(const DepthGuard&) = delete;

   private:
    Parser& p_;
  };

  const Token& Peek() const { return tokens_[pos_]; }

  // Never advances past kEnd, so Peek() stays valid.
  const Token& Next() {
    const Token& t = tokens_[pos_];
    if (t.kind != Tok::kEnd) ++pos_;
    return t;
  }

  // End offset of the last consumed token: sub-expression spans end there.
  int PrevEnd() const {
    if (pos_ == 0) return 0;
    const Token& t = tokens_[pos_ - 1];
    return t.offset + t.length;
  }

  void Finish(AstNode& node) const { node.span.length = PrevEnd() - node.span.offset; }

  const Token& Expect(Tok kind, const std::string& what) {
    if (Peek().kind != kind)
      throw ExprSyntaxError(Peek().offset, what + ", found " + Describe(Peek()));
    return Next();
  }

  void RejectUnmatchedClose(const Token& t) const {
    if (t.kind == Tok::kRParen || t.kind == Tok::kRBracket) {
      throw ExprSyntaxError(t.offset, "unmatched " + Describe(t));
    }
  }

  void RejectTrailing() const {
    const Token& t = Peek();
    if (t.kind == Tok::kEnd) return;
    RejectUnmatchedClose(t);
    throw ExprSyntaxError(t.offset,
                          "unexpected " + Describe(t) + " after the end of the expression");
  }

  std::unique_ptr<AstNode> MakeBinary(std::unique_ptr<AstNode> lhs, const Token& op,
                                      std::unique_ptr<AstNode> rhs) const {
    auto node = MakeNode(AstNode::Kind::kBinary, lhs->span.offset);
    node->op = op.text[0];
    node->op_span = {op.offset, op.length};
    node->args.push_back(std::move(lhs));
    node->args.push_back(std::move(rhs));
    Finish(*node);
    return node;
  }

  // Binary chains loop instead of recursing, so only real nesting consumes stack.
  std::unique_ptr<AstNode> ParseExpr() {
    std::unique_ptr<AstNode> lhs = ParseTerm();
    while (Peek().kind == Tok::kPlus || Peek().kind == Tok::kMinus) {
      const Token& op = Next();
      lhs = MakeBinary(std::move(lhs), op, ParseTerm());
    }
    return lhs;
  }

  std::unique_ptr<AstNode> ParseTerm() {
    std::unique_ptr<AstNode> lhs = ParseUnary();
    while (Peek().kind == Tok::kStar || Peek().kind == Tok::kSlash) {
      const Token& op = Next();
      lhs = MakeBinary(std::move(lhs), op, ParseUnary());
    }
    return lhs;
  }

  std::unique_ptr<AstNode> ParseUnary() {
    if (Peek().kind != Tok::kMinus && Peek().kind != Tok::kPlus) return ParsePrimary();
    DepthGuard guard(*this, Peek());
    const Token& sign = Next();
    std::unique_ptr<AstNode> operand = ParseUnary();
    if (sign.kind == Tok::kPlus) return operand;
    auto node = MakeNode(AstNode::Kind::kUnary, sign.offset);
    node->op = '-';
    node->args.push_back(std::move(operand));
    Finish(*node);
    return node;
  }

  // An identifier right after a number or vector literal is its unit; keywords never are, so
  // "3 in [1, 5]" still reads as a relation.
  void ParseUnit(AstNode& node) {
    if (Peek().kind != Tok::kIdent) return;
    const Token& u = Next();
    node.unit = std::string(u.text);
    node.unit_span = {u.offset, u.length};
  }

  std::unique_ptr<AstNode> ParsePrimary() {
    const Token& t = Peek();
    switch (t.kind) {
      case Tok::kNumber: {
        Next();
        auto node = MakeNode(AstNode::Kind::kNumber, t.offset);
        node->number = t.number;
        ParseUnit(*node);
        Finish(*node);
        return node;
      }
      case Tok::kLBracket:
        return ParseVector();
      case Tok::kLParen: {
        DepthGuard guard(*this, t);
        const Token& open = Next();
        std::unique_ptr<AstNode> inner = ParseExpr();
        Expect(Tok::kRParen, "expected ')' to close '(' at " + Column(open.offset));
        // Widen to include the parentheses so enclosing spans start at the '('.
        inner->span.offset = open.offset;
        Finish(*inner);
        return inner;
      }
      case Tok::kNominal: {
        Next();
        if (Peek().kind == Tok::kLParen || Peek().kind == Tok::kDot) {
          throw ExprSyntaxError(
              Peek().offset, "'nominal' is a keyword and takes no " +
                                 std::string(Peek().kind == Tok::kLParen ? "arguments" : "member") +
                                 ", found " + Describe(Peek()));
        }
        auto node = MakeNode(AstNode::Kind::kNominal, t.offset);
        Finish(*node);
        return node;
      }
      case Tok::kIdent:
        return ParseRefOrCall();
      default:
        break;
    }
    std::string msg = "expected an expression";
    if (pos_ > 0) msg += " after " + Describe(tokens_[pos_ - 1]);
    msg += ", found ";
    msg += t.kind == Tok::kIn ? "keyword 'in'" : Describe(t);
    throw ExprSyntaxError(t.offset, msg);
  }

  std::unique_ptr<AstNode> ParseVector() {
    DepthGuard guard(*this, Peek());
    const Token& open = Next();
    auto node = MakeNode(AstNode::Kind::kVector, open.offset);
    if (Peek().kind != Tok::kRBracket) {
      node->args.push_back(ParseExpr());
      while (Peek().kind == Tok::kComma) {
        Next();
        node->args.push_back(ParseExpr());
      }
    }
    Expect(Tok::kRBracket, "expected ',' or ']' to close '[' at " + Column(open.offset));
    if (node->args.size() != 3) {
      throw ExprSyntaxError(open.offset, "a vector literal has 3 elements, found " +
                                             std::to_string(node->args.size()));
    }
    ParseUnit(*node);
    Finish(*node);
    return node;
  }

  std::unique_ptr<AstNode> ParseRefOrCall() {
    const Token& id = Next();
    if (Peek().kind == Tok::kLParen) {
      DepthGuard guard(*this, Peek());
      const Token& open = Next();
      auto node = MakeNode(AstNode::Kind::kCall, id.offset);
      node->name = std::string(id.text);
      if (Peek().kind != Tok::kRParen) {
        node->args.push_back(ParseExpr());
        while (Peek().kind == Tok::kComma) {
          Next();
          node->args.push_back(ParseExpr());
        }
      }
      Expect(Tok::kRParen,
             "expected ',' or ')' to close '" + node->name + "(' at " + Column(open.offset));
      Finish(*node);
      return node;
    }
    auto node = MakeNode(AstNode::Kind::kRef, id.offset);
    node->name = std::string(id.text);
    if (Peek().kind == Tok::kDot) {
      Next();
      const Token& m = Expect(Tok::kIdent, "expected a member name after '" + node->name + ".'");
      node->member = std::string(m.text);
      if (Peek().kind == Tok::kDot) {
        throw ExprSyntaxError(Peek().offset, "a reference has at most one member ('" + node->name +
                                                 "." + node->member + "'), found another '.'");
      }
    }
    Finish(*node);
    return node;
  }

  std::vector<Token> tokens_;
  size_t pos_ = 0;
  int depth_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Printing

constexpr int kPrecAdd = 1;
constexpr int kPrecMul = 2;
constexpr int kPrecUnary = 3;
constexpr int kPrecAtom = 4;

int Precedence(const AstNode& node) {
  switch (node.kind) {
    case AstNode::Kind::kBinary:
      return (node.op == '+' || node.op == '-') ? kPrecAdd : kPrecMul;
    case AstNode::Kind::kUnary:
      return kPrecUnary;
    // A negative literal can only come from a hand-built tree; it prints like a unary minus.
    case AstNode::Kind::kNumber:
      return std::signbit(node.number) ? kPrecUnary : kPrecAtom;
    default:
      return kPrecAtom;
  }
}

void Print(const AstNode& node, std::string& out);

void PrintWrapped(const AstNode& node, bool parens, std::string& out) {
  if (parens) out += '(';
  Print(node, out);
  if (parens) out += ')';
}

void PrintList(const std::vector<std::unique_ptr<AstNode>>& args, std::string& out) {
  for (size_t i = 0; i < args.size(); ++i) {
    if (i > 0) out += ", ";
    if (args[i]) Print(*args[i], out);
  }
}

void PrintUnit(const AstNode& node, std::string& out) {
  if (node.unit.empty()) return;
  out += ' ';
  out += node.unit;
}

void Print(const AstNode& node, std::string& out) {
  switch (node.kind) {
    case AstNode::Kind::kNumber: {
      char buf[64];
      // Shortest representation that round-trips.
      const auto res = std::to_chars(buf, buf + sizeof(buf), node.number);
      out.append(buf, res.ptr);
      PrintUnit(node, out);
      return;
    }
    case AstNode::Kind::kVector:
      out += '[';
      PrintList(node.args, out);
      out += ']';
      PrintUnit(node, out);
      return;
    case AstNode::Kind::kNominal:
      out += "nominal";
      return;
    case AstNode::Kind::kRef:
      out += node.name;
      if (!node.member.empty()) out += '.' + node.member;
      return;
    case AstNode::Kind::kCall:
      out += node.name;
      out += '(';
      PrintList(node.args, out);
      out += ')';
      return;
    case AstNode::Kind::kUnary:
      out += node.op;
      if (!node.args.empty() && node.args[0]) {
        PrintWrapped(*node.args[0], Precedence(*node.args[0]) < kPrecUnary, out);
      }
      return;
    case AstNode::Kind::kBinary: {
      if (node.args.size() != 2 || !node.args[0] || !node.args[1]) return;
      const int prec = Precedence(node);
      // Left-associative: the rhs needs parentheses at equal precedence ("a - (b - c)").
      PrintWrapped(*node.args[0], Precedence(*node.args[0]) < prec, out);
      out += ' ';
      out += node.op;
      out += ' ';
      PrintWrapped(*node.args[1], Precedence(*node.args[1]) <= prec, out);
      return;
    }
  }
}

}  // namespace

std::string SyntaxMessageInFile(const ExprSyntaxError& e, int line, int column, bool exact) {
  std::string message = e.what();
  constexpr std::string_view kAt = "at column ";
  const size_t at = message.find(kAt);
  if (at == std::string::npos) return message;
  size_t end = at + kAt.size();
  int n = 0;
  while (end < message.size() && IsDigit(message[end])) n = n * 10 + (message[end++] - '0');
  if (end == at + kAt.size()) return message;
  const std::string where =
      exact ? "at line " + std::to_string(line) + ", column " + std::to_string(column + n - 1)
            : "at column " + std::to_string(n) + " of the expression";
  return message.replace(at, end - at, where);
}

AstConstraint ParseConstraint(std::string_view text) { return Parser(text).ParseConstraint(); }

std::unique_ptr<AstNode> ParseExpression(std::string_view text) {
  return Parser(text).ParseWholeExpression();
}

std::string ToString(const AstNode& node) {
  std::string out;
  Print(node, out);
  return out;
}

}  // namespace cfuse
