#include "cfuse/constraints/functions.h"

#include <fmt/format.h>

#include <array>

#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

constexpr std::array<FunctionInfo, 6> kFunctions = {{
    {Function::kDistance, "distance", 2, "distance(a, b): two points"},
    {Function::kAngle, "angle", 3, "angle(a, b, c): three points, the angle at b"},
    {Function::kAngleBetween, "angle_between", 2, "angle_between(u, v): two vectors"},
    {Function::kDot, "dot", 2, "dot(u, v): two vectors"},
    {Function::kCross, "cross", 2, "cross(u, v): two vectors"},
    {Function::kNorm, "norm", 1, "norm(u): one vector"},
}};

}  // namespace

std::string Quantity::ToString() const {
  auto power = [](const char* unit, int p) {
    return p == 1 ? std::string(unit) : fmt::format("{}^{}", unit, p);
  };
  std::string num, den;
  auto add = [&](const char* unit, int p) {
    if (p > 0) num += (num.empty() ? "" : "·") + power(unit, p);
    if (p < 0) den += (den.empty() ? "" : "·") + power(unit, -p);
  };
  add("m", length);
  add("rad", angle);
  if (num.empty() && den.empty()) return "1";
  if (den.empty()) return num;
  return (num.empty() ? "1" : num) + "/" + den;
}

std::string ExprType::ToString() const {
  return fmt::format("{} [{}]", vector ? "vector" : "scalar", quantity.ToString());
}

const FunctionInfo* FindFunction(std::string_view name) {
  for (const FunctionInfo& f : kFunctions) {
    if (name == f.name) return &f;
  }
  return nullptr;
}

const FunctionInfo& GetFunctionInfo(Function f) {
  for (const FunctionInfo& info : kFunctions) {
    if (info.id == f) return info;
  }
  CFUSE_CHECK_MSG(false, "unknown function id");
  return kFunctions[0];
}

std::optional<ExprType> FunctionResultType(Function f, std::span<const ExprType> args,
                                           std::string* why) {
  const FunctionInfo& info = GetFunctionInfo(f);
  if (static_cast<int>(args.size()) != info.arity) {
    *why = fmt::format("{} takes {} argument{}, got {} (usage: {})", info.name, info.arity,
                       info.arity == 1 ? "" : "s", args.size(), info.signature);
    return std::nullopt;
  }
  for (size_t i = 0; i < args.size(); ++i) {
    if (!args[i].vector) {
      *why = fmt::format("argument {} of {} must be a point or vector, got a {} (usage: {})", i + 1,
                         info.name, args[i].ToString(), info.signature);
      return std::nullopt;
    }
  }
  auto same_quantity = [&]() {
    for (size_t i = 1; i < args.size(); ++i) {
      if (!(args[i].quantity == args[0].quantity)) {
        *why = fmt::format("arguments of {} must have the same unit, got [{}] and [{}]", info.name,
                           args[0].quantity.ToString(), args[i].quantity.ToString());
        return false;
      }
    }
    return true;
  };
  switch (f) {
    case Function::kDistance:
      if (!same_quantity()) return std::nullopt;
      return ExprType{false, args[0].quantity};
    case Function::kAngle:
      if (!same_quantity()) return std::nullopt;
      return ExprType{false, Quantity::Angle()};
    case Function::kAngleBetween:
      return ExprType{false, Quantity::Angle()};
    case Function::kDot:
      return ExprType{false, args[0].quantity * args[1].quantity};
    case Function::kCross:
      return ExprType{true, args[0].quantity * args[1].quantity};
    case Function::kNorm:
      return ExprType{false, args[0].quantity};
  }
  return std::nullopt;
}

}  // namespace cfuse
