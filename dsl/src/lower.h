// Lowering parsed constraint text (expr_parser.h) to the constraint graph: name resolution,
// units and types, `nominal`, and the choice of constraint kind. Internal to dsl/.
#pragma once

#include <string>

#include "cfuse/constraints/model_builder.h"
#include "cfuse/kernel/error.h"
#include "expr_parser.h"

namespace cfuse {

// Where byte 0 of an expression string sits in its file. When the string's bytes appear
// verbatim in the file (a one-line plain or quoted YAML scalar), offsets map exactly;
// otherwise every offset maps to the scalar's start.
struct TextOrigin {
  std::string file;
  int line = 0;    // 1-based
  int column = 0;  // 1-based
  bool exact = false;

  SourceLocation At(int offset) const;
};

class Lowerer {
 public:
  Lowerer(const ModelBuilder& builder, TextOrigin origin)
      : builder_(builder), origin_(std::move(origin)) {}

  // An expression; `nominal` is the value the keyword `nominal` stands for (nullptr: not allowed).
  ExprPtr Lower(const AstNode& node, const ExprPtr& nominal) const;

  // Parses and adds the constraint `text` to the builder under `name`.
  void AddConstraint(ModelBuilder* builder, std::string_view text, const std::string& name) const;

  // A constant quantity such as "12 mm" or "-90 deg" (no references): its SI value.
  double LowerConstantScalar(std::string_view text, Quantity expected, const char* what) const;

 private:
  [[noreturn]] void Fail(const Span& span, const std::string& message) const;
  ExprPtr LowerRef(const AstNode& node) const;
  ExprPtr LowerCall(const AstNode& node, const ExprPtr& nominal) const;
  // Makes a dimensionless constant zero take the other operand's unit ("dot(u, v) == 0").
  static void UnifyZero(ExprPtr* a, const ExprPtr& b);

  const ModelBuilder& builder_;
  TextOrigin origin_;
};

}  // namespace cfuse
