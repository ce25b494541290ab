// lhs >= rhs's (and lhs <= rhs's) factory (constraints/src/kinds/inequality.cpp): g - λ² on the
// arguments' blocks and the slack's, with the nominal slack sqrt(max(g, 0)); a distance or a
// norm required to be <= 0 is refused.
#include "cfuse/constraints/kinds/inequality.h"

#include <catch2/catch.hpp>

#include "point_model.h"

namespace cfuse {
namespace {

using testing::PointModel;

TEST_CASE("inequality: g - slack², with the slack that meets it at the nominal geometry",
          "[constraints]") {
  PointModel m({{0, 0, 0}, {1, 0, 0}});
  const int slack = m.builder.AddSlack("k");
  double s0 = -1;
  const ConstraintParts ge = InequalityResidual::Create(
      m.Distance(0, 1), MakeConstant(0.5, Quantity::Length()), true, m.builder.Context(slack), &s0);
  CHECK(s0 == Approx(std::sqrt(0.5)));
  CHECK(ge.blocks == std::vector<int>{m.blocks[0], m.blocks[1], slack});
  CHECK(ge.slack_block == slack);
  CHECK(ge.residual->dimension() == 1);
  m.builder.SetSlackNominal(slack, s0);
  CHECK(std::abs(m.Residual(ge)[0]) < 1e-12);
  CHECK(m.Residual(ge, 1, {2, 0, 0})[0] == Approx(1));  // 2 - 0.5 - 0.5

  const ConstraintParts le = InequalityResidual::Create(
      m.Distance(0, 1), MakeConstant(2, Quantity::Length()), false, m.builder.Context(slack), &s0);
  CHECK(s0 == Approx(1));
  m.builder.SetSlackNominal(slack, s0);
  CHECK(std::abs(m.Residual(le)[0]) < 1e-12);
  CHECK(m.Residual(le, 1, {0.5, 0, 0})[0] == Approx(0.5));  // 2 - 0.5 - 1

  // Violated at the nominal geometry: the slack is 0.
  InequalityResidual::Create(m.Distance(0, 1), MakeConstant(3, Quantity::Length()), true,
                             m.builder.Context(slack), &s0);
  CHECK(s0 == 0);
}

TEST_CASE("inequality: refuses a distance or a norm required to be <= 0", "[constraints]") {
  PointModel m({{0, 0, 0}, {1, 0, 0}});
  const int slack = m.builder.AddSlack("k");
  const ExprPtr zero = MakeConstant(0, Quantity::Length());
  double s0 = 0;
  CHECK_THROWS_AS(
      InequalityResidual::Create(m.Distance(0, 1), zero, false, m.builder.Context(slack), &s0),
      KindError);
  CHECK_THROWS_WITH(
      InequalityResidual::Create(m.Distance(0, 1), zero, false, m.builder.Context(slack), &s0),
      Catch::StartsWith("a distance or a norm required to be 0 holds only where"));
  CHECK_NOTHROW(
      InequalityResidual::Create(m.Distance(0, 1), zero, true, m.builder.Context(slack), &s0));
}

}  // namespace
}  // namespace cfuse
