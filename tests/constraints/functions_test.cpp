// The built-in functions of the constraint language: units printed as the messages show them,
// the table of functions, the result type of each (and why a call is refused), and their values
// worked by hand, the angle accurate near 0 and π where an arccosine is not.
#include "cfuse/constraints/functions.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

TEST_CASE("functions: quantities print as units", "[constraints]") {
  CHECK(Quantity{}.ToString() == "1");
  CHECK(Quantity::Length().ToString() == "m");
  CHECK(Quantity::Angle().ToString() == "rad");
  CHECK((Quantity::Length() * Quantity::Length()).ToString() == "m^2");
  CHECK((Quantity::Length() / Quantity::Angle()).ToString() == "m/rad");
  CHECK((Quantity{} / Quantity::Length()).ToString() == "1/m");
  CHECK((Quantity::Length() * Quantity::Angle()).ToString() == "m·rad");
  CHECK(Quantity{2, -3}.ToString() == "m^2/rad^3");
  CHECK(Quantity{-1, -1}.ToString() == "1/m·rad");
  CHECK((ExprType{true, Quantity::Length()}.ToString()) == "vector [m]");
  CHECK((ExprType{false, Quantity{}}.ToString()) == "scalar [1]");
}

TEST_CASE("functions: the table finds each function by name and id", "[constraints]") {
  const std::vector<std::pair<const char*, int>> table = {
      {"distance", 2}, {"angle", 3}, {"angle_between", 2}, {"dot", 2}, {"cross", 2}, {"norm", 1}};
  for (const auto& [name, arity] : table) {
    const FunctionInfo* f = FindFunction(name);
    REQUIRE(f != nullptr);
    CHECK(std::string(f->name) == name);
    CHECK(f->arity == arity);
    CHECK(&GetFunctionInfo(f->id) == f);
    CHECK(std::string(f->signature).rfind(std::string(name) + "(", 0) == 0);
  }
  CHECK(FindFunction("Distance") == nullptr);
  CHECK(FindFunction("") == nullptr);
  CHECK_THROWS_AS(GetFunctionInfo(static_cast<Function>(99)), InternalError);
}

TEST_CASE("functions: result types, and why a call is refused", "[constraints]") {
  const ExprType point{true, Quantity::Length()}, direction{true, Quantity{}},
      angle{false, Quantity::Angle()}, length{false, Quantity::Length()};
  auto type = [](Function f, std::vector<ExprType> args, std::string* why) {
    return FunctionResultType(f, args, why);
  };
  std::string why;
  CHECK(type(Function::kDistance, {point, point}, &why) == length);
  CHECK(type(Function::kAngle, {point, point, point}, &why) == angle);
  CHECK(type(Function::kAngleBetween, {point, direction}, &why) == angle);
  CHECK(type(Function::kDot, {point, point}, &why) == (ExprType{false, Quantity{2, 0}}));
  CHECK(type(Function::kCross, {point, direction}, &why) == point);
  CHECK(type(Function::kNorm, {direction}, &why) == (ExprType{false, Quantity{}}));

  CHECK_FALSE(type(Function::kNorm, {point, point}, &why));
  CHECK(why == "norm takes 1 argument, got 2 (usage: norm(u): one vector)");
  CHECK_FALSE(type(Function::kAngle, {point}, &why));
  CHECK(why ==
        "angle takes 3 arguments, got 1 (usage: angle(a, b, c): three points, the angle at b)");
  CHECK_FALSE(type(Function::kDot, {point, length}, &why));
  CHECK(why ==
        "argument 2 of dot must be a point or vector, got a scalar [m] (usage: dot(u, v): two "
        "vectors)");
  CHECK_FALSE(type(Function::kDistance, {point, direction}, &why));
  CHECK(why == "arguments of distance must have the same unit, got [m] and [1]");
  CHECK_FALSE(type(Function::kAngle, {point, point, direction}, &why));
  CHECK(why == "arguments of angle must have the same unit, got [m] and [1]");
}

TEST_CASE("functions: values by hand; the angle keeps its digits near 0 and π", "[constraints]") {
  const Eigen::Vector3d a(1, 0, 0), b(0, 0, 0), c(0, 2, 0);
  auto apply = [](Function f, std::vector<Eigen::Vector3d> args) {
    return ApplyFunction<double>(f, std::span<const Eigen::Vector3d>(args));
  };
  CHECK(apply(Function::kDistance, {Eigen::Vector3d(1, 2, 2), b}).x() == Approx(3));
  CHECK(apply(Function::kAngle, {a, b, c}).x() == Approx(M_PI / 2));
  CHECK(apply(Function::kAngle, {c, a, b}).x() == Approx(std::atan(2.0)));  // at a
  CHECK(apply(Function::kAngleBetween, {a, Eigen::Vector3d(1, 1, 0)}).x() == Approx(M_PI / 4));
  CHECK(apply(Function::kDot, {Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(4, -5, 6)}).x() == 12);
  CHECK(apply(Function::kCross, {a, c}) == Eigen::Vector3d(0, 0, 2));
  CHECK(apply(Function::kNorm, {Eigen::Vector3d(0, 3, 4)}).x() == 5);
  // The scalar results leave y and z at zero.
  CHECK(apply(Function::kDistance, {a, c}).tail<2>().isZero());

  for (const double t : {1e-9, 1e-6}) {
    INFO(t);
    const Eigen::Vector3d tilted(std::cos(t), std::sin(t), 0);
    CHECK(AngleBetween<double>(a, tilted) == Approx(t).epsilon(1e-12));
    CHECK(M_PI - AngleBetween<double>(-a, tilted) == Approx(t).epsilon(1e-6));
  }
}

}  // namespace
}  // namespace cfuse
