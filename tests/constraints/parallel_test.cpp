// parallel(u, v)'s factory (constraints/src/kinds/parallel.cpp): two vectors of nonzero length
// at the nominal geometry; two rows, zero for parallel and anti-parallel vectors.
#include "cfuse/constraints/kinds/parallel.h"

#include <catch2/catch.hpp>

#include "point_model.h"

namespace cfuse {
namespace {

using testing::PointModel;

TEST_CASE("parallel: two rows on the vectors' points, zero only when they are parallel",
          "[constraints]") {
  const PointModel m({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 1, 0}});
  const ConstraintParts parts =
      ParallelResidual::Create({m.Vector(0, 1), m.Vector(2, 3)}, m.builder.Context());
  CHECK(parts.blocks == std::vector<int>{m.blocks[1], m.blocks[0], m.blocks[3], m.blocks[2]});
  CHECK(parts.slack_block == -1);
  CHECK(parts.residual->dimension() == 2);
  CHECK(m.Residual(parts).norm() < 1e-12);
  CHECK(m.Residual(parts, 3, {-2, 1, 0}).norm() < 1e-12);                   // anti-parallel
  CHECK(m.Residual(parts, 3, {2, 3, 0}).norm() == Approx(std::sqrt(0.5)));  // 45 degrees
}

TEST_CASE("parallel: refuses a scalar and a vector of zero length", "[constraints]") {
  const PointModel m({{0, 0, 0}, {1, 0, 0}, {0, 0, 0}});
  CHECK_THROWS_WITH(ParallelResidual::Create({m.Vector(0, 1), MakeConstant(1, Quantity::Length())},
                                             m.builder.Context()),
                    Catch::StartsWith("argument 2 of parallel must be a vector, got a "));
  CHECK_THROWS_AS(ParallelResidual::Create({m.Vector(0, 2), m.Vector(0, 1)}, m.builder.Context()),
                  KindError);
  CHECK_THROWS_WITH(
      ParallelResidual::Create({m.Vector(0, 1), m.Vector(0, 2)}, m.builder.Context()),
      Catch::StartsWith("parallel: argument 2 has zero length at the nominal geometry"));
}

}  // namespace
}  // namespace cfuse
