// x in [lo, hi]'s factory (constraints/src/kinds/range.cpp): the product form on the argument's
// blocks and the slack's, with the slack that meets it at the nominal geometry; an empty range
// is refused.
#include "cfuse/constraints/kinds/range.h"

#include <catch2/catch.hpp>

#include "point_model.h"

namespace cfuse {
namespace {

using testing::PointModel;

TEST_CASE("range: the product form, with the slack that meets it at the nominal geometry",
          "[constraints]") {
  PointModel m({{0, 0, 0}, {1.25, 0, 0}});
  const int slack = m.builder.AddSlack("k");
  double s0 = -1;
  const ConstraintParts parts =
      RangeResidual::Create(m.Distance(0, 1), 0.5, 1.5, m.builder.Context(slack), &s0);
  CHECK(s0 == Approx(std::sqrt(0.75)));  // u = 0.5: 1 - u²
  CHECK(parts.blocks == std::vector<int>{m.blocks[0], m.blocks[1], slack});
  CHECK(parts.slack_block == slack);
  CHECK(parts.residual->dimension() == 1);
  m.builder.SetSlackNominal(slack, s0);
  CHECK(std::abs(m.Residual(parts)[0]) < 1e-12);
  CHECK(m.Residual(parts, 1, {1, 0, 0})[0] == Approx(0.25));  // 1 - 0 - 0.75

  // Outside the range at the nominal geometry: the slack is 0.
  RangeResidual::Create(m.Distance(0, 1), 2, 3, m.builder.Context(slack), &s0);
  CHECK(s0 == 0);
}

TEST_CASE("range: refuses an empty range", "[constraints]") {
  PointModel m({{0, 0, 0}, {1, 0, 0}});
  const int slack = m.builder.AddSlack("k");
  double s0 = 0;
  CHECK_THROWS_AS(RangeResidual::Create(m.Distance(0, 1), 1, 1, m.builder.Context(slack), &s0),
                  KindError);
  CHECK_THROWS_WITH(
      RangeResidual::Create(m.Distance(0, 1), 1.5, 0.5, m.builder.Context(slack), &s0),
      Catch::StartsWith("empty range: the lower bound 1.5 m is not below the upper bound 0.5 m"));
}

}  // namespace
}  // namespace cfuse
