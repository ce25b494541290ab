// What the constraint kinds share (constraints/src/kinds/kind_support.cpp): arguments bound to
// slots (a slack last), their nominal values, the refusals a kind throws as KindError, the
// description of a call, the largest triangle, farthest pair and extent against brute force, and
// the range's slack form (cfuse/constraints/kinds/range_slack.h). The helpers are internal:
// tested through constraints/src/kinds/kind_support.h.
#include "kinds/kind_support.h"

#include <catch2/catch.hpp>
#include <random>

#include "cfuse/constraints/kinds/range_slack.h"
#include "cfuse/constraints/model_builder.h"
#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

using namespace internal;

struct Model {
  ModelBuilder b{"m", "test"};
  int a, p, arm, slack;
  Model() {
    a = b.AddPointComponent("a", {1, 2, 3}, {});
    p = b.AddPointComponent("p", {0, 0, 1}, {});
    arm = b.AddRigidComponent("arm", Rigid3d(Eigen::Quaterniond::Identity(), {0, 0, 1}), {});
    b.AddFeaturePoint(arm, "tip", {0.5, 0, 0}, {});
    slack = b.AddSlack("k");
  }
  ExprPtr Point(int c) const { return MakePointRef(b.graph().components[c].block); }
  ExprPtr Tip() const {
    return MakeFeatureRef(b.graph().components[arm].block, {0.5, 0, 0}, "tip");
  }
};

TEST_CASE("kind support: arguments bound to slots, and their nominal values", "[constraints]") {
  const Model m;
  std::string why;
  const ExprPtr d = MakeBinary(Expr::Op::kSub, m.Tip(), m.Point(m.a), &why);
  const BoundArgs args = BindArgs({d, m.Point(m.a)}, m.b.Context(m.slack), true);
  // Slots in order of first appearance, then the slack.
  const std::vector<Component>& c = m.b.graph().components;
  CHECK(args.blocks == std::vector<int>{c[m.arm].block, c[m.a].block, m.slack});
  CHECK(args.kinds ==
        std::vector<BlockKind>{BlockKind::kPose, BlockKind::kPoint, BlockKind::kSlack});
  CHECK(args.exprs[1]->slot == 1);
  const std::vector<Eigen::Vector3d> v = NominalValues(args, m.b.Context(m.slack));
  REQUIRE(v.size() == 2);
  CHECK(v[0] == Eigen::Vector3d(0.5, 0, 1) - Eigen::Vector3d(1, 2, 3));
  CHECK(v[1] == Eigen::Vector3d(1, 2, 3));
  const std::string names[] = {"arm", "a"};
  CHECK(DescribeCall("parallel", args.exprs, names) == "parallel(arm.tip - a, a)");
  // A slack asked for needs its block.
  CHECK_THROWS_AS(BindArgs({m.Point(m.a)}, m.b.Context(), true), InternalError);
}

TEST_CASE("kind support: what a kind refuses, and why", "[constraints]") {
  const Model m;
  const ExprPtr scalar = MakeConstant(2, Quantity::Length());
  const ExprPtr direction = MakeVectorConstant({0, 0, 1}, Quantity{});
  CHECK_NOTHROW(RequireVectors({m.Point(m.a), direction}, "parallel", false));
  CHECK_THROWS_WITH(RequireVectors({m.Point(m.a), scalar}, "parallel", false),
                    "argument 2 of parallel must be a vector, got a scalar [m]");
  CHECK_THROWS_WITH(RequireVectors({scalar}, "coplanar", true),
                    "argument 1 of coplanar must be a point, got a scalar [m]");
  CHECK_THROWS_WITH(RequireVectors({m.Point(m.a), direction}, "coplanar", true),
                    "argument 2 of coplanar must be a point (a length vector), got vector [1]");
  CHECK_THROWS_AS(RequireVectors({scalar}, "x", false), KindError);

  CHECK_NOTHROW(RequireNonZero({{1e-11, 0, 0}}, "parallel"));
  CHECK_THROWS_WITH(RequireNonZero({{1, 0, 0}, {1e-13, 0, 0}}, "parallel"),
                    "parallel: argument 2 has zero length at the nominal geometry, its direction "
                    "is undefined");

  std::string why;
  const ExprPtr distance = MakeCall(Function::kDistance, {m.Point(m.a), m.Point(m.p)}, &why);
  const ExprPtr norm = MakeCall(Function::kNorm, {m.Point(m.a)}, &why);
  const ExprPtr zero = MakeConstant(0, Quantity::Length());
  CHECK_THROWS_WITH(RefuseZeroLength(*distance, *zero),
                    Catch::StartsWith("a distance or a norm required to be 0 holds only where"));
  CHECK_THROWS_AS(RefuseZeroLength(*norm, *zero), KindError);
  CHECK_NOTHROW(RefuseZeroLength(*distance, *MakeConstant(1e-3, Quantity::Length())));
  CHECK_NOTHROW(RefuseZeroLength(*m.Point(m.a), *MakeVectorConstant({0, 0, 0}, {1, 0})));
  CHECK_NOTHROW(RefuseZeroLength(*distance, *m.Point(m.p)));
}

TEST_CASE("kind support: largest triangle, farthest pair and extent against brute force",
          "[constraints]") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Eigen::Vector3d> p(9);
  for (Eigen::Vector3d& q : p) q = {u(rng), u(rng), u(rng)};
  double best_area = 0, best_distance = 0, extent = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    extent = std::max(extent, (p[i] - p[0]).norm());
    for (size_t j = i + 1; j < p.size(); ++j) {
      best_distance = std::max(best_distance, (p[i] - p[j]).norm());
      for (size_t k = j + 1; k < p.size(); ++k)
        best_area = std::max(best_area, (p[j] - p[i]).cross(p[k] - p[i]).norm());
    }
  }
  const auto [t, area] = LargestTriangle(p);
  CHECK(area == best_area);
  CHECK((p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).norm() == Approx(best_area));
  const auto [pair, distance] = FarthestPair(p);
  CHECK(distance == best_distance);
  CHECK((p[pair[0]] - p[pair[1]]).norm() == best_distance);
  CHECK(Extent(p) == extent);
  // Ties go to the first in argument order: a square's two diagonals, its four triangles.
  const std::vector<Eigen::Vector3d> square = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  CHECK(LargestTriangle(square).first == std::array<int, 3>{0, 1, 2});
  CHECK(FarthestPair(square).first == std::array<int, 2>{0, 2});
  CHECK(LargestTriangle({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}).second == 0);
  CHECK(Extent({{3, 0, 0}}) == 0);
}

TEST_CASE("kind support: a range's product form and its nominal slack", "[constraints]") {
  // x in [1, 3]: mid 2, half 1; (x - 1)(3 - x) = λ².
  for (double x : {1.0, 1.5, 2.0, 2.9, 3.0, 4.0}) {
    const double lambda = 0.3;
    CHECK(RangeSlackResidual(x, 2.0, 1.0, lambda) == Approx((x - 1) * (3 - x) - lambda * lambda));
  }
  CHECK(NominalSlack(0.25) == 0.5);
  CHECK(NominalSlack(0) == 0);
  CHECK(NominalSlack(-0.5) == 0);
}

}  // namespace
}  // namespace cfuse
