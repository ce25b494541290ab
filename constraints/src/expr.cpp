#include "cfuse/constraints/expr.h"

#include <fmt/format.h>

#include <cmath>
#include <functional>

#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

std::shared_ptr<Expr> NewExpr(Expr::Op op, ExprType type) {
  auto e = std::make_shared<Expr>();
  e->op = op;
  e->type = type;
  return e;
}

int Precedence(const Expr& e) {
  switch (e.op) {
    case Expr::Op::kAdd:
    case Expr::Op::kSub:
      return 1;
    case Expr::Op::kMul:
    case Expr::Op::kDiv:
      return 2;
    case Expr::Op::kNeg:
      return 3;
    default:
      return 4;
  }
}

// Constant subtrees are folded so that e.g. "-90 deg" is one constant node.
ExprPtr Fold(std::shared_ptr<Expr> e) {
  if (e->op == Expr::Op::kConstant || !IsConstant(*e)) return e;
  const Eigen::Vector3d v = Evaluate<double>(*e, {});
  return e->type.vector ? MakeVectorConstant(v, e->type.quantity)
                        : MakeConstant(v.x(), e->type.quantity);
}

ExprPtr Remap(const ExprPtr& e, std::vector<int>* blocks) {
  if (e->op == Expr::Op::kPoint || e->op == Expr::Op::kFeature) {
    auto copy = std::make_shared<Expr>(*e);
    int local = -1;
    for (size_t i = 0; i < blocks->size(); ++i) {
      if ((*blocks)[i] == e->slot) local = static_cast<int>(i);
    }
    if (local < 0) {
      local = static_cast<int>(blocks->size());
      blocks->push_back(e->slot);
    }
    copy->slot = local;
    return copy;
  }
  if (e->args.empty()) return e;
  auto copy = std::make_shared<Expr>(*e);
  for (ExprPtr& a : copy->args) a = Remap(a, blocks);
  return copy;
}

}  // namespace

ExprPtr MakeConstant(double value, Quantity q) {
  auto e = NewExpr(Expr::Op::kConstant, ExprType{false, q});
  e->constant.x() = value;
  return e;
}

ExprPtr MakeVectorConstant(const Eigen::Vector3d& value, Quantity q) {
  auto e = NewExpr(Expr::Op::kConstant, ExprType{true, q});
  e->constant = value;
  return e;
}

ExprPtr MakePointRef(int slot) {
  auto e = NewExpr(Expr::Op::kPoint, ExprType{true, Quantity::Length()});
  e->slot = slot;
  return e;
}

ExprPtr MakeFeatureRef(int slot, const Eigen::Vector3d& position_in_component, std::string name) {
  auto e = NewExpr(Expr::Op::kFeature, ExprType{true, Quantity::Length()});
  e->slot = slot;
  e->constant = position_in_component;
  e->name = std::move(name);
  return e;
}

ExprPtr MakeVector(std::vector<ExprPtr> scalars, std::string* why) {
  CFUSE_CHECK(scalars.size() == 3);
  for (int i = 0; i < 3; ++i) {
    if (scalars[i]->type.vector) {
      *why = fmt::format("element {} of a vector literal must be a scalar, got a vector", i + 1);
      return nullptr;
    }
    if (!(scalars[i]->type.quantity == scalars[0]->type.quantity)) {
      *why =
          fmt::format("the elements of a vector literal must have the same unit, got [{}] and [{}]",
                      scalars[0]->type.quantity.ToString(), scalars[i]->type.quantity.ToString());
      return nullptr;
    }
  }
  auto e = NewExpr(Expr::Op::kVector, ExprType{true, scalars[0]->type.quantity});
  e->args = std::move(scalars);
  return Fold(e);
}

ExprPtr MakeNeg(ExprPtr a) {
  auto e = NewExpr(Expr::Op::kNeg, a->type);
  e->args = {std::move(a)};
  return Fold(e);
}

ExprPtr MakeBinary(Expr::Op op, ExprPtr a, ExprPtr b, std::string* why) {
  const ExprType ta = a->type, tb = b->type;
  ExprType result;
  switch (op) {
    case Expr::Op::kAdd:
    case Expr::Op::kSub:
      if (ta.vector != tb.vector) {
        *why = fmt::format("cannot {} a {} and a {}", op == Expr::Op::kAdd ? "add" : "subtract",
                           ta.vector ? "vector" : "scalar", tb.vector ? "vector" : "scalar");
        return nullptr;
      }
      if (!(ta.quantity == tb.quantity)) {
        *why = fmt::format("unit mismatch: [{}] {} [{}]", ta.quantity.ToString(),
                           op == Expr::Op::kAdd ? "+" : "-", tb.quantity.ToString());
        return nullptr;
      }
      result = ta;
      break;
    case Expr::Op::kMul:
      if (ta.vector && tb.vector) {
        *why = "cannot multiply two vectors: use dot(u, v) or cross(u, v)";
        return nullptr;
      }
      result = ExprType{ta.vector || tb.vector, ta.quantity * tb.quantity};
      break;
    case Expr::Op::kDiv:
      if (tb.vector) {
        *why = "cannot divide by a vector";
        return nullptr;
      }
      result = ExprType{ta.vector, ta.quantity / tb.quantity};
      break;
    default:
      CFUSE_CHECK_MSG(false, "MakeBinary takes + - * /");
  }
  auto e = NewExpr(op, result);
  e->args = {std::move(a), std::move(b)};
  return Fold(e);
}

ExprPtr MakeCall(Function f, std::vector<ExprPtr> args, std::string* why) {
  std::vector<ExprType> types;
  for (const ExprPtr& a : args) types.push_back(a->type);
  const std::optional<ExprType> result = FunctionResultType(f, types, why);
  if (!result) return nullptr;
  auto e = NewExpr(Expr::Op::kCall, *result);
  e->function = f;
  e->args = std::move(args);
  return Fold(e);
}

std::vector<int> BindSlots(std::vector<ExprPtr>* exprs) {
  std::vector<int> blocks;
  for (ExprPtr& e : *exprs) e = Remap(e, &blocks);
  return blocks;
}

bool IsConstant(const Expr& e) {
  if (e.op == Expr::Op::kPoint || e.op == Expr::Op::kFeature) return false;
  for (const ExprPtr& a : e.args) {
    if (!IsConstant(*a)) return false;
  }
  return true;
}

std::string FormatQuantity(double value, Quantity q) {
  if (q == Quantity::Angle()) return fmt::format("{:.6g} deg", value * 180.0 / M_PI);
  if (q == Quantity{}) return fmt::format("{:.6g}", value);
  return fmt::format("{:.6g} {}", value, q.ToString());
}

std::string Describe(const Expr& e, std::span<const std::string> names) {
  auto child = [&](const ExprPtr& a, bool right_operand) {
    std::string s = Describe(*a, names);
    const int pa = Precedence(*a), pe = Precedence(e);
    if (pa < pe ||
        (right_operand && pa == pe && (e.op == Expr::Op::kSub || e.op == Expr::Op::kDiv)))
      return "(" + s + ")";
    return s;
  };
  switch (e.op) {
    case Expr::Op::kConstant:
      if (e.type.vector) {
        if (e.type.quantity == Quantity::Angle()) {
          const Eigen::Vector3d d = e.constant * 180.0 / M_PI;
          return fmt::format("[{:.6g}, {:.6g}, {:.6g}] deg", d.x(), d.y(), d.z());
        }
        const std::string unit =
            e.type.quantity == Quantity{} ? "" : " " + e.type.quantity.ToString();
        return fmt::format("[{:.6g}, {:.6g}, {:.6g}]{}", e.constant.x(), e.constant.y(),
                           e.constant.z(), unit);
      }
      return FormatQuantity(e.constant.x(), e.type.quantity);
    case Expr::Op::kPoint:
      return e.slot < static_cast<int>(names.size()) ? names[e.slot] : fmt::format("#{}", e.slot);
    case Expr::Op::kFeature:
      return (e.slot < static_cast<int>(names.size()) ? names[e.slot]
                                                      : fmt::format("#{}", e.slot)) +
             "." + e.name;
    case Expr::Op::kVector:
      return fmt::format("[{}, {}, {}]", Describe(*e.args[0], names), Describe(*e.args[1], names),
                         Describe(*e.args[2], names));
    case Expr::Op::kNeg:
      return "-" + child(e.args[0], false);
    case Expr::Op::kAdd:
      return child(e.args[0], false) + " + " + child(e.args[1], true);
    case Expr::Op::kSub:
      return child(e.args[0], false) + " - " + child(e.args[1], true);
    case Expr::Op::kMul:
      return child(e.args[0], false) + " * " + child(e.args[1], true);
    case Expr::Op::kDiv:
      return child(e.args[0], false) + " / " + child(e.args[1], true);
    case Expr::Op::kCall: {
      std::string s = std::string(GetFunctionInfo(e.function).name) + "(";
      for (size_t i = 0; i < e.args.size(); ++i) {
        s += (i ? ", " : "") + Describe(*e.args[i], names);
      }
      return s + ")";
    }
  }
  return "?";
}

}  // namespace cfuse
