// Degrees of freedom from the rank of the constraint Jacobian, on models whose answer is known.
#include "cfuse/constraints/dof.h"

#include <catch2/catch.hpp>

#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/constraints/kinds/registry.h"
#include "cfuse/constraints/model_builder.h"
#include "constraints/jacobian_checker.h"

namespace cfuse {
namespace {

struct Model {
  ModelBuilder b{"m", "test"};
  int Point(const char* name, Eigen::Vector3d p) { return b.AddPointComponent(name, p, {}); }
  ExprPtr P(int component) const { return MakePointRef(b.graph().components[component].block); }
  void Distance(int i, int j) {
    std::string why;
    const ExprPtr d = MakeCall(Function::kDistance, {P(i), P(j)}, &why);
    const ExprPtr nominal = MakeConstant(
        (b.graph().nominal.points[b.graph().blocks[b.graph().components[i].block].index] -
         b.graph().nominal.points[b.graph().blocks[b.graph().components[j].block].index])
            .norm(),
        Quantity::Length());
    b.AddConstraint(b.UniqueConstraintName("d"), ConstraintKind::kDistanceEquality,
                    "distance ==", EqualityResidual::Create(d, nominal, b.Context()), {});
  }
  void Relation(const char* name, std::vector<int> points) {
    std::vector<ExprPtr> args;
    for (int p : points) args.push_back(P(p));
    b.AddConstraint(b.UniqueConstraintName(name), FindRelation(name)->kind, name,
                    FindRelation(name)->create(args, b.Context()), {});
  }
  DofReport Dof() const { return AnalyzeDof(b.graph(), b.graph().nominal); }
};

TEST_CASE("dof: free points", "[constraints]") {
  Model m;
  m.Point("a", {0, 0, 0});
  CHECK(m.Dof().dof == 3);
  CHECK(m.Dof().rigid_body == 3);  // a point does not rotate
  m.Point("b", {1, 0, 0});
  m.Distance(0, 1);
  // A rod: 5 rigid-body DOF (no spin about its own axis), nothing internal.
  CHECK(m.Dof().dof == 5);
  CHECK(m.Dof().rigid_body == 5);
  CHECK(m.Dof().internal == 0);
}

TEST_CASE("dof: a chain of three points has one internal DOF", "[constraints]") {
  Model m;
  m.Point("a", {0, 0, 0});
  m.Point("b", {1, 0, 0});
  m.Point("c", {1, 1, 0});
  m.Distance(0, 1);
  m.Distance(1, 2);
  const DofReport r = m.Dof();
  CHECK(r.dof == 7);
  CHECK(r.rigid_body == 6);
  CHECK(r.internal == 1);
  CHECK(r.redundant.empty());
}

TEST_CASE("dof: rigid() makes a planar group rigid, where its distances alone would not",
          "[constraints]") {
  // Four coplanar points with all six distances flex out of their plane to first order.
  Model distances;
  for (const auto& [name, p] : std::vector<std::pair<const char*, Eigen::Vector3d>>{
           {"a", {0, 0, 0}}, {"b", {1, 0, 0}}, {"c", {1, 1, 0}}, {"d", {0, 1, 0}}}) {
    distances.Point(name, p);
  }
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) distances.Distance(i, j);
  CHECK(distances.Dof().internal == 1);
  CHECK(distances.Dof().redundant.size() == 1);

  Model rigid;
  for (const auto& [name, p] :
       std::vector<std::pair<const char*, Eigen::Vector3d>>{{"a", {0, 0, 0}},
                                                            {"b", {1, 0, 0}},
                                                            {"c", {1, 1, 0}},
                                                            {"d", {0, 1, 0}},
                                                            {"e", {0.5, 0.5, 0}}}) {
    rigid.Point(name, p);
  }
  rigid.Relation("rigid", {0, 1, 2, 3, 4});
  const DofReport r = rigid.Dof();
  CHECK(r.equations == 3 * 5 - 6);  // full rank by construction
  CHECK(r.dof == 6);
  CHECK(r.internal == 0);
  CHECK(r.redundant.empty());
}

TEST_CASE("dof: rigid() on collinear points is rigid too", "[constraints]") {
  Model m;
  for (const auto& [name, p] : std::vector<std::pair<const char*, Eigen::Vector3d>>{
           {"a", {0, 0, 0}}, {"b", {1, 0, 0}}, {"c", {3, 0, 0}}, {"d", {4, 0, 0}}}) {
    m.Point(name, p);
  }
  m.Relation("rigid", {0, 1, 2, 3});
  const DofReport r = m.Dof();
  CHECK(r.equations == 3 * 4 - 5);  // a rigid rod: no spin about its axis
  CHECK(r.dof == 5);
  CHECK(r.rigid_body == 5);
  CHECK(r.internal == 0);
  // Its line-offset rows differentiate correctly away from the line too.
  Values moved = m.b.graph().nominal;
  moved.points[2] += Eigen::Vector3d(0.1, -0.2, 0.3);
  const Constraint& c = m.b.graph().constraints[0];
  testing::CheckJacobian(m.b.graph(), *c.residual, c.blocks, moved);
}

TEST_CASE("dof: parallel and collinear are full rank by construction", "[constraints]") {
  Model m;
  for (const auto& [name, p] : std::vector<std::pair<const char*, Eigen::Vector3d>>{
           {"a", {0, 0, 0}}, {"b", {1, 0, 0}}, {"c", {2, 0, 0}}, {"d", {3, 0, 0}}}) {
    m.Point(name, p);
  }
  m.Relation("collinear", {0, 1, 2, 3});
  const DofReport r = m.Dof();
  CHECK(r.equations == 4);
  CHECK(r.rank == 4);
  CHECK(r.dof == 8);
  CHECK(r.rigid_body == 5);  // collinear points: no spin about the line
}

TEST_CASE("dof: joints between two rigid bodies", "[constraints]") {
  const std::vector<std::pair<JointType, int>> expected = {{JointType::kRevolute, 7},
                                                           {JointType::kContinuous, 7},
                                                           {JointType::kPrismatic, 7},
                                                           {JointType::kSpherical, 9},
                                                           {JointType::kFixed, 6}};
  for (const auto& [type, dof] : expected) {
    DYNAMIC_SECTION(JointTypeName(type)) {
      ModelBuilder b("m", "test");
      const int a =
          b.AddRigidComponent("a", Rigid3d::FromXyzRpy({0.1, 0.2, 0.3}, {0.4, -1.0, 2.0}), {});
      const int c = b.AddRigidComponent("c", std::nullopt, {});
      JointSpec spec;
      spec.name = "j";
      spec.type = type;
      spec.parent = a;
      spec.child = c;
      spec.parent_from_joint = Rigid3d::FromXyzRpy({0, 0.5, 0}, {0.1, 0.2, 0.3});
      spec.axis = {1, 2, 3};
      if (HasJointVariable(type) && type != JointType::kContinuous)
        spec.limits = std::make_pair(-1.0, 1.0);
      b.AddJoint(spec);
      const DofReport r = AnalyzeDof(b.graph(), b.graph().nominal);
      CHECK(r.dof == dof);
      CHECK(r.rigid_body == 6);
      CHECK(r.internal == dof - 6);
      CHECK(r.redundant.empty());
      // Fixing the parent in the world leaves only the joint's own freedom.
      b.FixComponent(a, true, true, b.graph().nominal.poses[0], {});
      const DofReport fixed = AnalyzeDof(b.graph(), b.graph().nominal);
      CHECK(fixed.rigid_body == 0);
      CHECK(fixed.dof == dof - 6);
    }
  }
}

TEST_CASE("dof: redundant constraints are named", "[constraints]") {
  Model m;
  m.Point("a", {0, 0, 0});
  m.Point("b", {1, 0, 0});
  m.Distance(0, 1);
  m.Distance(0, 1);
  const DofReport r = m.Dof();
  REQUIRE(r.redundant.size() == 1);
  CHECK(r.redundant[0].first == "d_2");
  CHECK(r.redundant[0].second == 1);
  CHECK(r.dof == 5);
}

}  // namespace
}  // namespace cfuse
