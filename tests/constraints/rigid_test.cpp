// rigid(...)'s factory (constraints/src/kinds/rigid.cpp): point names only, none coinciding at
// the nominal geometry; of the candidate rows, those that raise the rank there (3n - 6 for a
// group in general position, 3n - 5 for a collinear one); nothing left is refused.
#include "cfuse/constraints/kinds/rigid.h"

#include <catch2/catch.hpp>

#include "point_model.h"

namespace cfuse {
namespace {

using testing::PointModel;

TEST_CASE("rigid: the rows that raise the rank, zero at the nominal geometry", "[constraints]") {
  const PointModel m({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
  const ConstraintParts parts = RigidResidual::Create(m.points, m.builder.Context());
  CHECK(parts.blocks == m.blocks);
  CHECK(parts.slack_block == -1);
  CHECK(parts.residual->dimension() == 6);
  CHECK(m.Residual(parts).norm() < 1e-12);
  CHECK(m.Residual(parts, 3, {0, 0, 1.1}).norm() > 0.05);

  const PointModel line({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}});
  const ConstraintParts on_line = RigidResidual::Create(line.points, line.builder.Context());
  CHECK(on_line.residual->dimension() == 4);
  CHECK(line.Residual(on_line).norm() < 1e-12);
  CHECK(line.Residual(on_line, 1, {1, 0.1, 0}).norm() > 0.05);

  const PointModel two({{0, 0, 0}, {1, 0, 0}});
  CHECK(RigidResidual::Create(two.points, two.builder.Context()).residual->dimension() == 1);
}

TEST_CASE("rigid: refuses what is not a point name, coinciding points, and nothing to add",
          "[constraints]") {
  const PointModel m({{0, 0, 0}, {1, 0, 0}, {0, 0, 0}});
  CHECK_THROWS_WITH(RigidResidual::Create({m.points[0], m.Vector(0, 1)}, m.builder.Context()),
                    Catch::StartsWith("argument 2 of rigid must be a point"));
  CHECK_THROWS_WITH(
      RigidResidual::Create({m.points[0], MakeVectorConstant({1, 0, 0}, Quantity::Length())},
                            m.builder.Context()),
      Catch::StartsWith("argument 2 of rigid must be a point name"));
  CHECK_THROWS_AS(RigidResidual::Create(m.points, m.builder.Context()), KindError);
  CHECK_THROWS_WITH(RigidResidual::Create(m.points, m.builder.Context()),
                    Catch::StartsWith("rigid: points 1 and 3 coincide at the nominal geometry"));
  CHECK_THROWS_WITH(RigidResidual::Create({m.points[0], m.points[2]}, m.builder.Context()),
                    Catch::StartsWith("rigid: the points coincide at the nominal geometry"));

  ModelBuilder b("m", "test");
  const int arm = b.AddRigidComponent("arm", Rigid3d(), {});
  const int block = b.graph().components[arm].block;
  CHECK_THROWS_WITH(
      RigidResidual::Create(
          {MakeFeatureRef(block, {0, 0, 0}, "a"), MakeFeatureRef(block, {1, 0, 0}, "b")},
          b.Context()),
      Catch::StartsWith("rigid: the points already belong to one rigid component, so the "
                        "constraint adds nothing"));
}

}  // namespace
}  // namespace cfuse
