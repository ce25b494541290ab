// coplanar(...)'s factory (constraints/src/kinds/coplanar.cpp): points only, spanning a plane at
// the nominal geometry; the plane through the largest triangle, one row per other point.
#include "cfuse/constraints/kinds/coplanar.h"

#include <catch2/catch.hpp>

#include "point_model.h"

namespace cfuse {
namespace {

using testing::PointModel;

TEST_CASE("coplanar: one row per point off the base triangle, its distance to the plane",
          "[constraints]") {
  // (p0, p1, p2) and (p0, p1, p3) tie for the largest triangle: the first is the base.
  const PointModel m({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0.5, 0.5, 0}});
  const ConstraintParts parts = CoplanarResidual::Create(m.points, m.builder.Context());
  CHECK(parts.blocks == m.blocks);
  CHECK(parts.slack_block == -1);
  CHECK(parts.residual->dimension() == 2);
  CHECK(m.Residual(parts).norm() < 1e-12);
  const Eigen::VectorXd r = m.Residual(parts, 3, {1, 1, 0.1});
  CHECK(r[0] == Approx(0.1));
  CHECK(std::abs(r[1]) < 1e-12);
}

TEST_CASE("coplanar: refuses what is not a point, and points without a plane", "[constraints]") {
  const PointModel line({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}});
  std::vector<ExprPtr> args = line.points;
  args[3] = MakeVectorConstant({0, 0, 1}, Quantity{});
  CHECK_THROWS_WITH(CoplanarResidual::Create(args, line.builder.Context()),
                    Catch::StartsWith("argument 4 of coplanar must be a point (a length vector)"));
  args[3] = MakeConstant(1, Quantity::Length());
  CHECK_THROWS_WITH(CoplanarResidual::Create(args, line.builder.Context()),
                    Catch::StartsWith("argument 4 of coplanar must be a point, got a "));
  CHECK_THROWS_AS(CoplanarResidual::Create(line.points, line.builder.Context()), KindError);
  CHECK_THROWS_WITH(CoplanarResidual::Create(line.points, line.builder.Context()),
                    Catch::StartsWith("coplanar: the points are collinear (or coincide) at the "
                                      "nominal geometry"));
  const PointModel one({{1, 2, 3}, {1, 2, 3}, {1, 2, 3}, {1, 2, 3}});
  CHECK_THROWS_WITH(CoplanarResidual::Create(one.points, one.builder.Context()),
                    Catch::StartsWith("coplanar: the points are collinear (or coincide)"));
}

}  // namespace
}  // namespace cfuse
