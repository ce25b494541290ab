// All the constraints of a graph at once: rows stacked in constraint order and columns at each
// block's tangent offset, against each constraint alone and against central differences of the
// whole state; and the slacks matched to their inequalities (λ = ±√max(g, 0), its sign kept).
#include "cfuse/constraints/evaluate.h"

#include <catch2/catch.hpp>
#include <cmath>

#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/constraints/kinds/inequality.h"
#include "cfuse/constraints/kinds/range.h"
#include "cfuse/constraints/model_builder.h"

namespace cfuse {
namespace {

// Points a and b, a rigid arm; a distance, a vector equality, an inequality and a range.
ConstraintGraph Sample() {
  ModelBuilder b("m", "test");
  const int a = b.AddPointComponent("a", {0.3, 0, 0}, {});
  const int p = b.AddPointComponent("b", {1.2, 0.1, 0}, {});
  const int arm = b.AddRigidComponent(
      "arm", Rigid3d(Eigen::Quaterniond(0.9, 0.1, 0.3, -0.2).normalized(), {1, 0.5, 0.2}), {});
  b.AddFeaturePoint(arm, "tip", {0.2, -0.1, 0.4}, {});
  const Component& c = b.graph().components[arm];
  const ExprPtr A = MakePointRef(b.graph().components[a].block);
  const ExprPtr B = MakePointRef(b.graph().components[p].block);
  const ExprPtr tip = MakeFeatureRef(c.block, c.points[0].position, "tip");
  std::string why;
  const ExprPtr ab = MakeCall(Function::kDistance, {A, B}, &why);
  b.AddConstraint("d", ConstraintKind::kDistanceEquality, "distance ==",
                  EqualityResidual::Create(ab, MakeConstant(1, Quantity::Length()), b.Context()),
                  {});
  b.AddConstraint("on", ConstraintKind::kExpression,
                  "expression ==", EqualityResidual::Create(tip, B, b.Context()), {});
  double slack0 = 0;
  const int s1 = b.AddSlack("low");
  b.AddConstraint("low", ConstraintKind::kExpression, "distance <=",
                  InequalityResidual::Create(ab, MakeConstant(1.5, Quantity::Length()), false,
                                             b.Context(s1), &slack0),
                  {});
  const int s2 = b.AddSlack("range");
  b.AddConstraint("range", ConstraintKind::kExpression, "distance in",
                  RangeResidual::Create(MakeCall(Function::kDistance, {A, tip}, &why), 0.5, 2.5,
                                        b.Context(s2), &slack0),
                  {});
  return std::move(b).Build();
}

TEST_CASE("constraints evaluate: rows stacked, columns at the blocks' offsets", "[constraints]") {
  const ConstraintGraph g = Sample();
  REQUIRE(g.num_equations() == 1 + 3 + 1 + 1);
  REQUIRE(g.tangent_dim() == 3 + 3 + 6 + 1 + 1);
  Values at = g.nominal;
  at.slacks = {0.4, -0.7};
  Eigen::VectorXd r, alone;
  Eigen::MatrixXd J;
  EvaluateConstraints(g, at, &r, &J);
  REQUIRE(J.rows() == 6);
  REQUIRE(J.cols() == 14);
  EvaluateConstraints(g, at, &alone, nullptr);
  CHECK(alone == r);
  int row = 0;
  for (const Constraint& c : g.constraints) {
    Eigen::VectorXd rc;
    EvaluateResidual(*c.residual, g.blocks, c.blocks, at, &rc, nullptr);
    CHECK(r.segment(row, rc.size()) == rc);
    row += static_cast<int>(rc.size());
  }
  const double h = 1e-6;
  for (int i = 0; i < 14; ++i) {
    Eigen::VectorXd e = Eigen::VectorXd::Zero(14);
    e[i] = h;
    Values plus = at, minus = at;
    Retract(g.blocks, e, &plus);
    Retract(g.blocks, -e, &minus);
    Eigen::VectorXd rp, rm;
    EvaluateConstraints(g, plus, &rp, nullptr);
    EvaluateConstraints(g, minus, &rm, nullptr);
    INFO("column " << i);
    CHECK((J.col(i) - (rp - rm) / (2 * h)).norm() < 1e-8);
  }
}

TEST_CASE("constraints evaluate: slacks matched to their inequalities", "[constraints]") {
  const ConstraintGraph g = Sample();
  Values at = g.nominal;
  at.slacks = {-3, 5};
  MatchSlacks(g, &at);
  // distance(a, b) <= 1.5: g = 1.5 - |a - b|; the slack's negative sign is kept.
  const double ab = (at.points[0] - at.points[1]).norm();
  CHECK(at.slacks[0] == Approx(-std::sqrt(1.5 - ab)));
  // |a - tip| in [0.5, 2.5]: 1 - u² with u = (x - 1.5) / 1.
  const Eigen::Vector3d tip = at.poses[0] * Eigen::Vector3d(0.2, -0.1, 0.4);
  const double u = (at.points[0] - tip).norm() - 1.5;
  CHECK(at.slacks[1] == Approx(std::sqrt(1 - u * u)));
  Eigen::VectorXd r;
  EvaluateConstraints(g, at, &r, nullptr);
  CHECK(std::abs(r[4]) < 1e-14);
  CHECK(std::abs(r[5]) < 1e-14);

  // A violated inequality gets a zero slack; so does one that cannot be evaluated.
  Values violated = at;
  violated.points[1] = Eigen::Vector3d(5, 0, 0);
  MatchSlacks(g, &violated);
  CHECK(violated.slacks[0] == 0);
  Values broken = at;
  broken.points[0].x() = std::nan("");
  MatchSlacks(g, &broken);
  CHECK(broken.slacks[0] == 0);
  CHECK(broken.slacks[1] == 0);
}

}  // namespace
}  // namespace cfuse
