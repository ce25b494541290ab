#include "lower.h"

#include <fmt/format.h>

#include <algorithm>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/constraints/kinds/inequality.h"
#include "cfuse/constraints/kinds/range.h"
#include "cfuse/constraints/kinds/registry.h"
#include "cfuse/kernel/did_you_mean.h"
#include "units.h"

namespace cfuse {
namespace {

bool IsZeroConstant(const Expr& e) {
  return e.op == Expr::Op::kConstant && e.type.quantity == Quantity{} && e.constant.isZero(0);
}

// The value of a bound expression at the nominal geometry, as a constant.
ExprPtr NominalOf(const ExprPtr& e, const ConstraintGraph& graph) {
  std::vector<ExprPtr> bound = {e};
  const std::vector<int> blocks = BindSlots(&bound);
  const std::vector<BlockState<double>> states = GatherStates(graph.blocks, blocks, graph.nominal);
  const Eigen::Vector3d v =
      Evaluate<double>(*bound[0], std::span<const BlockState<double>>(states));
  return e->type.vector ? MakeVectorConstant(v, e->type.quantity)
                        : MakeConstant(v.x(), e->type.quantity);
}

}  // namespace

SourceLocation TextOrigin::At(int offset) const {
  SourceLocation loc(file, line, column);
  if (exact) loc.column += offset;
  return loc;
}

void Lowerer::Fail(const Span& span, const std::string& message) const {
  throw InputError(origin_.At(span.offset), message);
}

void Lowerer::UnifyZero(ExprPtr* a, const ExprPtr& b) {
  if (IsZeroConstant(**a) && (*a)->type.vector == b->type.vector) {
    *a = b->type.vector ? MakeVectorConstant(Eigen::Vector3d::Zero(), b->type.quantity)
                        : MakeConstant(0.0, b->type.quantity);
  }
}

ExprPtr Lowerer::LowerRef(const AstNode& node) const {
  const ConstraintGraph& g = builder_.graph();
  // Candidate lists for "did you mean" are built only on the error paths.
  auto component_names = [&] {
    std::vector<std::string> names;
    for (const Component& c : g.components) names.push_back(c.name);
    return names;
  };
  if (!node.member.empty()) {
    const int ci = builder_.FindComponent(node.name);
    if (ci < 0) {
      Fail(node.span, fmt::format("unknown component '{}'{}", node.name,
                                  DidYouMean(node.name, component_names())));
    }
    const Component& c = g.components[ci];
    if (!c.rigid) {
      Fail(node.span, fmt::format("'{}' is a single-point component: write '{}' alone, it has no "
                                  "point '{}'",
                                  c.name, c.name, node.member));
    }
    const int pi = c.FindPoint(node.member);
    if (pi < 0) {
      std::vector<std::string> names;
      for (const FeaturePoint& p : c.points) names.push_back(p.name);
      Fail(node.span, fmt::format("component '{}' has no point '{}'{}", c.name, node.member,
                                  DidYouMean(node.member, names)));
    }
    return MakeFeatureRef(c.block, c.points[pi].position, c.points[pi].name);
  }
  // A bare name: a single-point component, or a feature point whose name is unique.
  const std::vector<std::pair<int, int>>& matches = builder_.FindBarePoint(node.name);
  if (matches.empty()) {
    const int ci = builder_.FindComponent(node.name);
    if (ci >= 0) {
      const Component& c = g.components[ci];
      Fail(node.span, fmt::format("'{}' is a rigid component, not a point: name one of its points, "
                                  "e.g. {}.{}",
                                  c.name, c.name, c.points.empty() ? "p" : c.points[0].name));
    }
    std::vector<std::string> all_points;
    for (const Component& c : g.components) {
      if (!c.rigid) all_points.push_back(c.name);
      for (const FeaturePoint& p : c.points) all_points.push_back(p.name);
    }
    Fail(node.span,
         fmt::format("unknown point '{}'{}", node.name, DidYouMean(node.name, all_points)));
  }
  if (matches.size() > 1) {
    std::string list;
    for (const auto& [ci, pi] : matches) {
      list += (list.empty() ? "" : ", ") +
              (pi < 0 ? g.components[ci].name : g.components[ci].name + "." + node.name);
    }
    Fail(node.span, fmt::format("point name '{}' is ambiguous: it could be {}; write "
                                "component.point",
                                node.name, list));
  }
  const auto [ci, pi] = matches[0];
  const Component& c = g.components[ci];
  if (pi < 0) return MakePointRef(c.block);
  return MakeFeatureRef(c.block, c.points[pi].position, c.points[pi].name);
}

ExprPtr Lowerer::LowerCall(const AstNode& node, const ExprPtr& nominal) const {
  const FunctionInfo* f = FindFunction(node.name);
  if (f == nullptr) {
    if (const RelationKind* r = FindRelation(node.name)) {
      Fail(node.span, fmt::format("{} is a relation, not a value: write it alone as a whole "
                                  "constraint (usage: {})",
                                  node.name, r->usage));
    }
    std::vector<std::string> names = {"distance", "angle", "angle_between", "dot", "cross", "norm"};
    Fail(node.span, fmt::format("unknown function '{}'{}; the functions are {}", node.name,
                                DidYouMean(node.name, names),
                                "distance, angle, angle_between, dot, cross, norm"));
  }
  if (static_cast<int>(node.args.size()) != f->arity) {
    Fail(node.span, fmt::format("{} takes {} argument{}, got {} (usage: {})", f->name, f->arity,
                                f->arity == 1 ? "" : "s", node.args.size(), f->signature));
  }
  std::vector<ExprPtr> args;
  for (const auto& a : node.args) args.push_back(Lower(*a, nominal));
  std::string why;
  // Point which argument is wrong when one is.
  for (size_t i = 0; i < args.size(); ++i) {
    if (!args[i]->type.vector) {
      Fail(node.args[i]->span, fmt::format("argument {} of {} must be a point or vector, got a {} "
                                           "(usage: {})",
                                           i + 1, f->name, args[i]->type.ToString(), f->signature));
    }
  }
  ExprPtr e = MakeCall(f->id, std::move(args), &why);
  if (!e) Fail(node.span, why);
  return e;
}

ExprPtr Lowerer::Lower(const AstNode& node, const ExprPtr& nominal) const {
  std::string why;
  switch (node.kind) {
    case AstNode::Kind::kNumber: {
      if (node.unit.empty()) return MakeConstant(node.number, Quantity{});
      const Unit* u = FindUnit(node.unit);
      if (!u) {
        Fail(node.unit_span, fmt::format("unknown unit '{}' (units: {})", node.unit, KnownUnits()));
      }
      return MakeConstant(node.number * u->factor, u->quantity);
    }
    case AstNode::Kind::kVector: {
      std::vector<ExprPtr> elements;
      for (const auto& a : node.args) elements.push_back(Lower(*a, nominal));
      if (!node.unit.empty()) {
        const Unit* u = FindUnit(node.unit);
        if (!u) {
          Fail(node.unit_span,
               fmt::format("unknown unit '{}' (units: {})", node.unit, KnownUnits()));
        }
        for (size_t i = 0; i < elements.size(); ++i) {
          if (!(elements[i]->type.quantity == Quantity{})) {
            Fail(node.args[i]->span, fmt::format("element {} already has a unit; a unit after the "
                                                 "vector applies to plain numbers",
                                                 i + 1));
          }
          elements[i] =
              MakeBinary(Expr::Op::kMul, elements[i], MakeConstant(u->factor, u->quantity), &why);
        }
      }
      for (size_t i = 1; i < elements.size(); ++i) {
        UnifyZero(&elements[i], elements[0]);
        UnifyZero(&elements[0], elements[i]);
      }
      for (size_t i = 1; i < elements.size(); ++i) UnifyZero(&elements[i], elements[0]);
      ExprPtr e = MakeVector(std::move(elements), &why);
      if (!e) Fail(node.span, why);
      return e;
    }
    case AstNode::Kind::kNominal:
      if (!nominal) {
        Fail(node.span,
             "'nominal' stands for the value of the left-hand side at the nominal "
             "geometry, so it can only appear on the right-hand side of a relation "
             "or in the bounds of a range");
      }
      return nominal;
    case AstNode::Kind::kRef:
      return LowerRef(node);
    case AstNode::Kind::kCall:
      return LowerCall(node, nominal);
    case AstNode::Kind::kUnary:
      return MakeNeg(Lower(*node.args[0], nominal));
    case AstNode::Kind::kBinary: {
      ExprPtr a = Lower(*node.args[0], nominal), b = Lower(*node.args[1], nominal);
      Expr::Op op = Expr::Op::kAdd;
      switch (node.op) {
        case '+':
          op = Expr::Op::kAdd;
          break;
        case '-':
          op = Expr::Op::kSub;
          break;
        case '*':
          op = Expr::Op::kMul;
          break;
        default:
          op = Expr::Op::kDiv;
          break;
      }
      if (op == Expr::Op::kAdd || op == Expr::Op::kSub) {
        UnifyZero(&a, b);
        UnifyZero(&b, a);
      }
      ExprPtr e = MakeBinary(op, a, b, &why);
      if (!e) Fail(node.op_span, why);
      return e;
    }
  }
  Fail(node.span, "unsupported expression");
}

void Lowerer::AddConstraint(ModelBuilder* builder, std::string_view text,
                            const std::string& name) const {
  AstConstraint ast;
  try {
    ast = ParseConstraint(text);
  } catch (const ExprSyntaxError& e) {
    throw InputError(
        origin_.At(e.offset()),
        fmt::format("syntax error in constraint: {}",
                    SyntaxMessageInFile(e, origin_.line, origin_.column, origin_.exact)));
  }
  const SourceLocation where = origin_.At(0);
  const ConstraintGraph& g = builder_.graph();
  auto kind_error = [&](const KindError& e) {
    throw InputError(where, fmt::format("constraint '{}': {}", name, e.what()));
  };

  if (ast.relation == AstConstraint::Relation::kCall) {
    const AstNode& call = *ast.call;
    const RelationKind* kind = FindRelation(call.name);
    if (kind == nullptr) {
      if (FindFunction(call.name)) {
        Fail(call.span, fmt::format("{}(...) is a value, not a constraint: compare it, e.g. '{} == "
                                    "nominal'",
                                    call.name, ToString(call)));
      }
      std::vector<std::string> names;
      for (const RelationKind& r : AllRelations()) names.push_back(r.name);
      Fail(call.span,
           fmt::format("unknown relation '{}'{}; the relations are {}, or use ==, <=, >=, in",
                       call.name, DidYouMean(call.name, names), RelationNames()));
    }
    const int n = static_cast<int>(call.args.size());
    if (n < kind->min_args || (kind->max_args >= 0 && n > kind->max_args)) {
      Fail(call.span,
           fmt::format("{} takes {}{} arguments, got {} (usage: {})", kind->name,
                       kind->max_args < 0 ? "at least " : "", kind->min_args, n, kind->usage));
    }
    std::vector<ExprPtr> args;
    for (size_t i = 0; i < call.args.size(); ++i) {
      args.push_back(Lower(*call.args[i], nullptr));
      if (!args.back()->type.vector) {
        Fail(call.args[i]->span,
             fmt::format("argument {} of {} must be a point or vector, got a {}", i + 1, kind->name,
                         args.back()->type.ToString()));
      }
    }
    try {
      builder->AddConstraint(name, kind->kind, kind->name,
                             kind->create(std::move(args), builder->Context()), where);
    } catch (const KindError& e) {
      kind_error(e);
    }
    return;
  }

  ExprPtr lhs = Lower(*ast.lhs, nullptr);
  if (IsConstant(*lhs)) {
    Fail(ast.lhs->span, "the left-hand side of a constraint must depend on the model's points");
  }
  const ExprPtr nominal = NominalOf(lhs, g);
  std::string kind_prefix = "expression";
  if (ast.lhs->kind == AstNode::Kind::kCall) kind_prefix = ast.lhs->name;
  const FunctionInfo* lhs_function =
      ast.lhs->kind == AstNode::Kind::kCall ? FindFunction(ast.lhs->name) : nullptr;
  const ConstraintKind equality_kind = lhs_function && lhs_function->id == Function::kDistance
                                           ? ConstraintKind::kDistanceEquality
                                           : ConstraintKind::kExpression;

  auto require_same_type = [&](const ExprPtr& r, const AstNode& node, const char* what) {
    const Span& span = node.span;
    if (r->type.vector != lhs->type.vector) {
      Fail(span, fmt::format("{} is a {} but the left-hand side is a {}", what,
                             r->type.vector ? "vector" : "scalar",
                             lhs->type.vector ? "vector" : "scalar"));
    }
    if (!(r->type.quantity == lhs->type.quantity)) {
      // A plain number where a length or an angle is due: say how to write one.
      std::string hint;
      const bool plain =
          (node.kind == AstNode::Kind::kNumber || node.kind == AstNode::Kind::kVector) &&
          node.unit.empty() && r->type.quantity == Quantity{};
      if (plain &&
          (lhs->type.quantity == Quantity::Length() || lhs->type.quantity == Quantity::Angle())) {
        hint = fmt::format("; a number without a unit is dimensionless, write e.g. '{} {}'",
                           ToString(node), lhs->type.quantity == Quantity::Length() ? "m" : "deg");
      }
      Fail(span,
           fmt::format("unit mismatch: the left-hand side is in [{}] but {} is in [{}]{}",
                       lhs->type.quantity.ToString(), what, r->type.quantity.ToString(), hint));
    }
  };

  try {
    switch (ast.relation) {
      case AstConstraint::Relation::kEqual: {
        ExprPtr rhs = Lower(*ast.rhs, nominal);
        UnifyZero(&rhs, lhs);
        require_same_type(rhs, *ast.rhs, "the right-hand side");
        builder->AddConstraint(name, equality_kind, kind_prefix + " ==",
                               EqualityResidual::Create(lhs, rhs, builder->Context()), where);
        return;
      }
      case AstConstraint::Relation::kLessEqual:
      case AstConstraint::Relation::kGreaterEqual: {
        const bool greater = ast.relation == AstConstraint::Relation::kGreaterEqual;
        if (lhs->type.vector)
          Fail(ast.relation_span, "an inequality compares scalars, not vectors");
        ExprPtr rhs = Lower(*ast.rhs, nominal);
        UnifyZero(&rhs, lhs);
        require_same_type(rhs, *ast.rhs, "the right-hand side");
        const int slack = builder->AddSlack(name);
        double slack0 = 0;
        ConstraintParts parts =
            InequalityResidual::Create(lhs, rhs, greater, builder->Context(slack), &slack0);
        builder->SetSlackNominal(slack, slack0);
        builder->AddConstraint(name, ConstraintKind::kExpression,
                               kind_prefix + (greater ? " >=" : " <="), std::move(parts), where);
        return;
      }
      case AstConstraint::Relation::kIn: {
        if (lhs->type.vector) Fail(ast.relation_span, "a range bounds a scalar, not a vector");
        ExprPtr lo = Lower(*ast.lo, nominal), hi = Lower(*ast.hi, nominal);
        UnifyZero(&lo, lhs);
        UnifyZero(&hi, lhs);
        require_same_type(lo, *ast.lo, "the lower bound");
        require_same_type(hi, *ast.hi, "the upper bound");
        if (!IsConstant(*lo)) Fail(ast.lo->span, "the bounds of a range must be constants");
        if (!IsConstant(*hi)) Fail(ast.hi->span, "the bounds of a range must be constants");
        if (!(lo->constant.x() < hi->constant.x())) {
          Fail(ast.lo->span, fmt::format("empty range: the lower bound {} is not below the upper "
                                         "bound {}",
                                         FormatQuantity(lo->constant.x(), lhs->type.quantity),
                                         FormatQuantity(hi->constant.x(), lhs->type.quantity)));
        }
        const int slack = builder->AddSlack(name);
        double slack0 = 0;
        ConstraintParts parts = RangeResidual::Create(lhs, lo->constant.x(), hi->constant.x(),
                                                      builder->Context(slack), &slack0);
        builder->SetSlackNominal(slack, slack0);
        builder->AddConstraint(name, ConstraintKind::kExpression, kind_prefix + " in",
                               std::move(parts), where);
        return;
      }
      case AstConstraint::Relation::kCall:
        break;
    }
  } catch (const KindError& e) {
    kind_error(e);
  }
}

double Lowerer::LowerConstantScalar(std::string_view text, Quantity expected,
                                    const char* what) const {
  std::unique_ptr<AstNode> ast;
  try {
    ast = ParseExpression(text);
  } catch (const ExprSyntaxError& e) {
    throw InputError(
        origin_.At(e.offset()),
        fmt::format("invalid {}: {}", what,
                    SyntaxMessageInFile(e, origin_.line, origin_.column, origin_.exact)));
  }
  const std::string expectation =
      expected == Quantity::Angle()    ? "a number with a unit, e.g. '90 deg'"
      : expected == Quantity::Length() ? "a number with a unit, e.g. '12 mm'"
                                       : "a number";
  // A name here is not a constant: say so rather than "unknown point".
  std::vector<const AstNode*> todo = {ast.get()};
  while (!todo.empty()) {
    const AstNode* n = todo.back();
    todo.pop_back();
    if (n->kind == AstNode::Kind::kRef || n->kind == AstNode::Kind::kCall ||
        n->kind == AstNode::Kind::kNominal) {
      Fail(n->span,
           fmt::format("invalid {}: expected {}, found '{}'", what, expectation, ToString(*n)));
    }
    for (const auto& a : n->args) todo.push_back(a.get());
  }
  const ExprPtr e = Lower(*ast, nullptr);
  if (!IsConstant(*e) || e->type.vector) {
    Fail(ast->span, fmt::format("invalid {}: expected {}", what, expectation));
  }
  if (!(e->type.quantity == expected)) {
    Fail(ast->span, fmt::format("invalid {}: expected [{}], got [{}]", what, expected.ToString(),
                                e->type.quantity.ToString()));
  }
  return e->constant.x();
}

}  // namespace cfuse
