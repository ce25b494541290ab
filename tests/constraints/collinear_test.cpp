// collinear(...)'s factory (constraints/src/kinds/collinear.cpp): points only, not all
// coinciding at the nominal geometry; the line through the farthest pair, two rows per other
// point.
#include "cfuse/constraints/kinds/collinear.h"

#include <catch2/catch.hpp>

#include "point_model.h"

namespace cfuse {
namespace {

using testing::PointModel;

TEST_CASE("collinear: two rows per point off the base pair, its offset from the line",
          "[constraints]") {
  // The base pair is (p0, p2), the farthest apart.
  const PointModel m({{0, 0, 0}, {1, 0, 0}, {3, 0, 0}, {2, 0, 0}});
  const ConstraintParts parts = CollinearResidual::Create(m.points, m.builder.Context());
  CHECK(parts.blocks == m.blocks);
  CHECK(parts.slack_block == -1);
  CHECK(parts.residual->dimension() == 4);
  CHECK(m.Residual(parts).norm() < 1e-12);
  CHECK(m.Residual(parts, 1, {1, 0.2, 0}).head(2).norm() == Approx(0.2));
  CHECK(m.Residual(parts, 1, {1, 0.2, 0}).tail(2).norm() < 1e-12);
  CHECK(m.Residual(parts, 3, {2, 0, -0.3}).norm() == Approx(0.3));
}

TEST_CASE("collinear: refuses what is not a point, and points that coincide", "[constraints]") {
  const PointModel one({{1, 2, 3}, {1, 2, 3}, {1, 2, 3}});
  std::vector<ExprPtr> args = one.points;
  args[1] = MakeConstant(1, Quantity::Length());
  CHECK_THROWS_WITH(CollinearResidual::Create(args, one.builder.Context()),
                    Catch::StartsWith("argument 2 of collinear must be a point, got a "));
  CHECK_THROWS_AS(CollinearResidual::Create(one.points, one.builder.Context()), KindError);
  CHECK_THROWS_WITH(
      CollinearResidual::Create(one.points, one.builder.Context()),
      Catch::StartsWith("collinear: the points coincide at the nominal geometry, so they do not "
                        "define a line"));
}

}  // namespace
}  // namespace cfuse
