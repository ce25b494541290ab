// Expression trees: static types and units, constant folding, printing, slot binding.
#include "cfuse/constraints/expr.h"

#include <catch2/catch.hpp>

namespace cfuse {
namespace {

TEST_CASE("expr: types and units propagate, mismatches are refused with a reason",
          "[constraints]") {
  std::string why;
  const ExprPtr p = MakePointRef(0), q = MakePointRef(1);
  const ExprPtr d = MakeCall(Function::kDistance, {p, q}, &why);
  REQUIRE(d);
  CHECK(d->type == ExprType{false, Quantity::Length()});
  const ExprPtr dot = MakeCall(Function::kDot, {p, q}, &why);
  CHECK(dot->type.quantity == Quantity{2, 0});
  CHECK(MakeCall(Function::kAngle, {p, q, p}, &why)->type.quantity == Quantity::Angle());
  CHECK(MakeBinary(Expr::Op::kDiv, d, MakeConstant(2, Quantity::Angle()), &why)->type.quantity ==
        Quantity{1, -1});

  CHECK(MakeBinary(Expr::Op::kAdd, d, MakeConstant(1, Quantity::Angle()), &why) == nullptr);
  CHECK(why == "unit mismatch: [m] + [rad]");
  CHECK(MakeBinary(Expr::Op::kMul, p, q, &why) == nullptr);
  CHECK(why.find("dot(u, v) or cross(u, v)") != std::string::npos);
  CHECK(MakeBinary(Expr::Op::kSub, p, d, &why) == nullptr);
  CHECK(why == "cannot subtract a vector and a scalar");
  CHECK(MakeCall(Function::kDistance, {p}, &why) == nullptr);
  CHECK(why.find("distance takes 2 arguments, got 1") != std::string::npos);
  CHECK(MakeCall(Function::kNorm, {d}, &why) == nullptr);
  CHECK(why.find("must be a point or vector") != std::string::npos);
  CHECK(MakeCall(Function::kDistance, {p, MakeVectorConstant({0, 0, 1}, {})}, &why) == nullptr);
  CHECK(why.find("same unit") != std::string::npos);
}

TEST_CASE("expr: constants fold and print in canonical units", "[constraints]") {
  std::string why;
  const ExprPtr e = MakeBinary(Expr::Op::kSub, MakeConstant(M_PI / 2, Quantity::Angle()),
                               MakeNeg(MakeConstant(M_PI / 6, Quantity::Angle())), &why);
  REQUIRE(e->op == Expr::Op::kConstant);
  CHECK(e->constant.x() == Approx(2 * M_PI / 3));
  CHECK(Describe(*e, {}) == "120 deg");
  const ExprPtr v = MakeVector(
      {MakeConstant(0.1, Quantity::Length()), MakeNeg(MakeConstant(0.2, Quantity::Length())),
       MakeConstant(0, Quantity::Length())},
      &why);
  REQUIRE(v->op == Expr::Op::kConstant);
  CHECK(Describe(*v, {}) == "[0.1, -0.2, 0] m");
}

TEST_CASE("expr: printing respects precedence and names slots", "[constraints]") {
  std::string why;
  const ExprPtr a = MakeFeatureRef(7, {0, 0, 0}, "tip"), b = MakePointRef(3);
  const ExprPtr d = MakeCall(Function::kDistance, {a, b}, &why);
  const ExprPtr e = MakeBinary(
      Expr::Op::kSub, d,
      MakeBinary(Expr::Op::kSub, d, MakeConstant(0.002, Quantity::Length()), &why), &why);
  std::vector<ExprPtr> exprs = {e};
  const std::vector<int> blocks = BindSlots(&exprs);
  CHECK(blocks == std::vector<int>{7, 3});
  const std::vector<std::string> names = {"arm", "p3"};
  CHECK(Describe(*exprs[0], names) == "distance(arm.tip, p3) - (distance(arm.tip, p3) - 0.002 m)");
  CHECK(IsConstant(*MakeConstant(1, {})));
  CHECK(!IsConstant(*exprs[0]));
}

TEST_CASE("expr: evaluation of a feature point is R x + t", "[constraints]") {
  const ExprPtr f = MakeFeatureRef(0, {1, 2, 3}, "x");
  BlockState<double> s;
  s.R = ExpSO3<double>(Eigen::Vector3d(0, 0, M_PI / 2));
  s.t = {10, 20, 30};
  const std::vector<BlockState<double>> states = {s};
  const Eigen::Vector3d v = Evaluate<double>(*f, std::span<const BlockState<double>>(states));
  CHECK((v - Eigen::Vector3d(8, 21, 33)).norm() < 1e-12);
}

}  // namespace
}  // namespace cfuse
