// lhs == rhs's factory (constraints/src/kinds/equality.cpp): r = lhs - rhs, 3 rows for vectors
// and 1 for scalars; a distance or a norm required to be 0 is refused (unless it is 0 at the
// nominal geometry, which the model builder refuses as not differentiable).
#include "cfuse/constraints/kinds/equality.h"

#include <catch2/catch.hpp>

#include "point_model.h"

namespace cfuse {
namespace {

using testing::PointModel;

TEST_CASE("equality: r = lhs - rhs, for a point and for a distance", "[constraints]") {
  const PointModel m({{1, 2, 3}, {1, 2, 4}});
  const ConstraintParts at = EqualityResidual::Create(
      m.points[0], MakeVectorConstant({1, 2, 3}, Quantity::Length()), m.builder.Context());
  CHECK(at.blocks == std::vector<int>{m.blocks[0]});
  CHECK(at.slack_block == -1);
  CHECK(at.residual->dimension() == 3);
  CHECK(m.Residual(at).norm() == 0);
  CHECK(m.Residual(at, 0, {1.5, 2, 2}).isApprox(Eigen::Vector3d(0.5, 0, -1)));

  const ConstraintParts d = EqualityResidual::Create(
      m.Distance(0, 1), MakeConstant(1, Quantity::Length()), m.builder.Context());
  CHECK(d.blocks == std::vector<int>{m.blocks[0], m.blocks[1]});
  CHECK(d.residual->dimension() == 1);
  CHECK(std::abs(m.Residual(d)[0]) < 1e-12);
  CHECK(m.Residual(d, 1, {1, 2, 6})[0] == Approx(2));
}

TEST_CASE("equality: refuses a distance or a norm required to be 0", "[constraints]") {
  const PointModel m({{0, 0, 0}, {1, 0, 0}, {0, 0, 0}});
  const ExprPtr zero = MakeConstant(0, Quantity::Length());
  CHECK_THROWS_WITH(EqualityResidual::Create(m.Distance(0, 1), zero, m.builder.Context()),
                    Catch::StartsWith("a distance or a norm required to be 0 holds only where it "
                                      "has no derivative"));
  std::string why;
  CHECK_THROWS_AS(EqualityResidual::Create(MakeCall(Function::kNorm, {m.Vector(0, 1)}, &why), zero,
                                           m.builder.Context()),
                  KindError);
  // Already 0 at the nominal geometry: left to the model builder's check.
  CHECK_NOTHROW(EqualityResidual::Create(m.Distance(0, 2), zero, m.builder.Context()));
}

}  // namespace
}  // namespace cfuse
