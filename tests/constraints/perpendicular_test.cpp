// perpendicular(u, v)'s factory (constraints/src/kinds/perpendicular.cpp): two vectors of
// nonzero length at the nominal geometry; one row, the cosine of their angle.
#include "cfuse/constraints/kinds/perpendicular.h"

#include <catch2/catch.hpp>

#include "point_model.h"

namespace cfuse {
namespace {

using testing::PointModel;

TEST_CASE("perpendicular: one row, the cosine of the angle", "[constraints]") {
  const PointModel m({{0, 0, 0}, {1, 0, 0}, {0, 2, 0}});
  const ConstraintParts parts =
      PerpendicularResidual::Create({m.Vector(0, 1), m.Vector(0, 2)}, m.builder.Context());
  CHECK(parts.blocks == std::vector<int>{m.blocks[1], m.blocks[0], m.blocks[2]});
  CHECK(parts.slack_block == -1);
  CHECK(parts.residual->dimension() == 1);
  CHECK(std::abs(m.Residual(parts)[0]) < 1e-12);
  CHECK(m.Residual(parts, 2, {2, 2, 0})[0] == Approx(std::sqrt(0.5)));
}

TEST_CASE("perpendicular: refuses a scalar and a vector of zero length", "[constraints]") {
  const PointModel m({{0, 0, 0}, {1, 0, 0}, {0, 0, 0}});
  CHECK_THROWS_WITH(PerpendicularResidual::Create({MakeConstant(1, Quantity{}), m.Vector(0, 1)},
                                                  m.builder.Context()),
                    Catch::StartsWith("argument 1 of perpendicular must be a vector, got a "));
  CHECK_THROWS_AS(
      PerpendicularResidual::Create({m.Vector(0, 2), m.Vector(0, 1)}, m.builder.Context()),
      KindError);
  CHECK_THROWS_WITH(
      PerpendicularResidual::Create({m.Vector(0, 2), m.Vector(0, 1)}, m.builder.Context()),
      Catch::StartsWith("perpendicular: argument 1 has zero length at the nominal geometry"));
}

}  // namespace
}  // namespace cfuse
