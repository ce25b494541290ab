// The constraint graph in dot: the whole text of a small model (nodes by kind, a joint as a
// labelled edge with its limits in degrees, its constraints not repeated as notes, every other
// constraint a note joined once to each component it touches), and names quoted for dot.
#include "cfuse/constraints/graphviz.h"

#include <catch2/catch.hpp>
#include <sstream>

#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/constraints/model_builder.h"

namespace cfuse {
namespace {

std::string Dot(const ConstraintGraph& g) {
  std::ostringstream out;
  WriteDot(g, out);
  return out.str();
}

TEST_CASE("graphviz: components, a joint and the other constraints", "[constraints]") {
  ModelBuilder b("lamp \"x\"\\", "m.yaml");
  const int a = b.AddPointComponent("a", {0, 0, 0}, {});
  const int arm = b.AddRigidComponent("arm", Rigid3d(), {});
  b.AddFeaturePoint(arm, "tip", {1, 0, 0}, {});
  b.AddFeaturePoint(arm, "base", {0, 0, 0}, {});
  const int hand = b.AddRigidComponent("hand", std::nullopt, {});
  JointSpec wrist;
  wrist.name = "wrist";
  wrist.type = JointType::kRevolute;
  wrist.parent = arm;
  wrist.child = hand;
  wrist.axis = Eigen::Vector3d::UnitZ();
  wrist.limits = {{-M_PI / 2, M_PI / 4}};
  b.AddJoint(wrist);
  const int arm_block = b.graph().components[arm].block;
  const ExprPtr tip = MakeFeatureRef(arm_block, {1, 0, 0}, "tip");
  const ExprPtr base = MakeFeatureRef(arm_block, {0, 0, 0}, "base");
  const ExprPtr one = MakeConstant(1, Quantity::Length());
  std::string why;
  auto distance = [&](const char* name, ExprPtr p, ExprPtr q) {
    b.AddConstraint(
        name, ConstraintKind::kDistanceEquality, "distance ==",
        EqualityResidual::Create(MakeCall(Function::kDistance, {p, q}, &why), one, b.Context()),
        {});
  };
  distance("d", MakePointRef(b.graph().components[a].block), tip);
  distance("span", tip, base);  // one component, joined once
  const ConstraintGraph g = std::move(b).Build();
  REQUIRE(g.constraints.size() == 4);  // wrist, wrist_limit, d, span
  // NOTE stands for a note's attributes.
  std::string expected = R"(graph "lamp \"x\"\\" {
  graph [overlap=false, fontname="Helvetica", label="lamp \"x\"\\: 3 components, 4 constraints"];
  node [fontname="Helvetica", fontsize=11];
  edge [fontname="Helvetica", fontsize=9];
  c0 [label="a", shape=ellipse];
  c1 [label="arm\n2 points", shape=box];
  c2 [label="hand\n0 points", shape=box];
  c1 -- c2 [label="wrist\nrevolute\nlimits [-90 deg, 45 deg]", dir=forward, penwidth=2];
  k2 [label="d\ndistance(a, arm.tip) == 1 m", NOTE];
  k2 -- c0;
  k2 -- c1;
  k3 [label="span\ndistance(arm.tip, arm.base) == 1 m", NOTE];
  k3 -- c1;
}
)";
  for (size_t at; (at = expected.find("NOTE")) != std::string::npos;) {
    expected.replace(at, 4, R"(shape=note, fontsize=9, style=filled, fillcolor="#f3f3f3")");
  }
  CHECK(Dot(g) == expected);
}

TEST_CASE("graphviz: a prismatic joint's limits in metres; a model without a name",
          "[constraints]") {
  ModelBuilder b("", "m.yaml");
  const int rail = b.AddRigidComponent("rail", Rigid3d(), {});
  const int cart = b.AddRigidComponent("cart", std::nullopt, {});
  JointSpec slide;
  slide.name = "slide";
  slide.type = JointType::kPrismatic;
  slide.parent = rail;
  slide.child = cart;
  slide.limits = {{0, 0.25}};
  slide.position = 0.1;
  b.AddJoint(slide);
  const std::string dot = Dot(std::move(b).Build());
  CHECK(dot.rfind("graph \"model\" {\n", 0) == 0);
  CHECK_THAT(dot, Catch::Contains("label=\": 2 components, 2 constraints\""));
  CHECK_THAT(dot, Catch::Contains("c0 -- c1 [label=\"slide\\nprismatic\\nlimits [0 m, 0.25 m]\""));
  CHECK_THAT(dot, !Catch::Contains("k0") && !Catch::Contains("k1"));
}

}  // namespace
}  // namespace cfuse
