// The constraint graph's own code: joint type names both ways, the motion of each type with a
// variable, look-ups by name or alias (a point by its index or by a scan), sizes, slot names,
// and the contract the algorithms check at their entry.
#include "cfuse/constraints/graph.h"

#include <catch2/catch.hpp>

#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/constraints/model_builder.h"
#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

// Points a and b at a distance, a rigid body with two points and a frame, a joint to another.
ConstraintGraph Sample() {
  ModelBuilder b("m", "m.yaml");
  const int a = b.AddPointComponent("a", {0, 0, 0}, {});
  const int p = b.AddPointComponent("b", {1, 0, 0}, {});
  const int arm = b.AddRigidComponent("arm", Rigid3d(), {});
  b.AddFeaturePoint(arm, "tip", {0.5, 0, 0}, {});
  b.AddFeaturePoint(arm, "base", {0, 0, 0}, {});
  b.AddFrame(arm, "tool", Rigid3d(Eigen::Quaterniond::Identity(), {0.5, 0, 0}), {});
  const int hand = b.AddRigidComponent("hand", std::nullopt, {});
  JointSpec spec;
  spec.name = "wrist";
  spec.type = JointType::kRevolute;
  spec.parent = arm;
  spec.child = hand;
  spec.axis = {0, 0, 1};
  b.AddJoint(spec);
  b.AddMergedJoint("weld", std::nullopt, {});
  std::string why;
  auto ref = [&](int c) { return MakePointRef(b.graph().components[c].block); };
  b.AddConstraint("d", ConstraintKind::kDistanceEquality, "distance ==",
                  EqualityResidual::Create(MakeCall(Function::kDistance, {ref(a), ref(p)}, &why),
                                           MakeConstant(1, Quantity::Length()), b.Context()),
                  {});
  return std::move(b).Build();
}

TEST_CASE("graph: joint types by name, their variables and motions", "[constraints]") {
  for (JointType t :
       {JointType::kRevolute, JointType::kContinuous, JointType::kPrismatic, JointType::kSpherical,
        JointType::kFixed, JointType::kPlanar, JointType::kFloating}) {
    CHECK(ParseJointType(JointTypeName(t)) == t);
  }
  CHECK(std::string(JointTypeName(JointType::kContinuous)) == "continuous");
  CHECK(std::string(JointTypeName(static_cast<JointType>(42))) == "?");
  CHECK_FALSE(ParseJointType("Revolute"));
  CHECK_FALSE(ParseJointType("ball"));
  CHECK(HasJointVariable(JointType::kRevolute));
  CHECK(HasJointVariable(JointType::kContinuous));
  CHECK(HasJointVariable(JointType::kPrismatic));
  CHECK_FALSE(HasJointVariable(JointType::kSpherical));
  CHECK_FALSE(HasJointVariable(JointType::kPlanar));
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const Rigid3d turn = JointMotion(JointType::kRevolute, z, M_PI / 2);
  CHECK((turn * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(0, 1, 0)).norm() < 1e-15);
  CHECK((JointMotion(JointType::kPrismatic, z, 0.3) * Eigen::Vector3d(1, 0, 0) -
         Eigen::Vector3d(1, 0, 0.3))
            .norm() < 1e-15);
  const Rigid3d still = JointMotion(JointType::kSpherical, z, 0.3);
  CHECK(still.translation.norm() == 0);
  CHECK(still.rotation.angularDistance(Eigen::Quaterniond::Identity()) == 0);
}

TEST_CASE("graph: look-ups by name or alias, sizes and slot names", "[constraints]") {
  ConstraintGraph g = Sample();
  CHECK(g.tangent_dim() == 3 + 3 + 6 + 6);
  CHECK(g.num_equations() == 5 + 1);  // a revolute joint's five rows, the distance's one
  CHECK(g.FindComponent("arm") == 2);
  CHECK(g.FindComponent("tool") == -1);  // a frame, not a component
  CHECK(g.FindJoint("wrist") == 0);
  CHECK(g.FindJoint("weld") == -1);
  REQUIRE(g.FindMergedJoint("weld") != nullptr);
  CHECK_FALSE(g.FindMergedJoint("weld")->locked_at);
  CHECK(g.FindMergedJoint("wrist") == nullptr);
  CHECK(g.FindConstraint("d") == 1);
  CHECK(g.FindConstraint("wrist") == 0);  // a joint's constraint takes its name
  // Frames: a rigid component is its own, a frame is on its component; a point is neither.
  CHECK(g.FindFrame("arm")->first == 2);
  CHECK(g.FindFrame("tool")->first == 2);
  CHECK(g.FindFrame("tool")->second.translation == Eigen::Vector3d(0.5, 0, 0));
  CHECK_FALSE(g.FindFrame("a"));
  CHECK_FALSE(g.FindFrame("tip"));
  // Aliases answer as well as names.
  g.components[2].alias = "arm_1";
  g.joints[0].alias = "wrist_1";
  g.merged_joints[0].alias = "weld_1";
  g.components[2].frames[0].alias = "tool_1";
  CHECK(g.FindComponent("arm_1") == 2);
  CHECK(g.FindJoint("wrist_1") == 0);
  CHECK(g.FindMergedJoint("weld_1") == &g.merged_joints[0]);
  CHECK(g.FindFrame("tool_1")->first == 2);
  CHECK(g.FindComponent("arm") == 2);

  const Constraint& d = g.constraints[1];
  CHECK(g.SlotNames(d) == std::vector<std::string>{"a", "b"});
  CHECK(g.Describe(d) == "distance(a, b) == 1 m");
}

TEST_CASE("graph: a point is found by its index, or by a scan without one", "[constraints]") {
  ConstraintGraph g = Sample();
  Component& arm = g.components[2];
  CHECK(arm.FindPoint("base") == 1);
  CHECK(arm.FindPoint("elbow") == -1);
  arm.point_index.clear();  // as a graph assembled by hand
  CHECK(arm.FindPoint("base") == 1);
  CHECK(arm.FindPoint("elbow") == -1);
  CHECK(g.components[0].FindPoint("a") == -1);  // a single point has no feature points
}

TEST_CASE("graph: the algorithms' entry contract catches a graph assembled wrongly",
          "[constraints]") {
  const ConstraintGraph g = Sample();
  CHECK_NOTHROW(CheckGraph(g));
  ConstraintGraph no_residual = g;
  no_residual.constraints[1].residual = nullptr;
  CHECK_THROWS_WITH(CheckGraph(no_residual), Catch::Contains("constraint 'd' has no residual"));
  ConstraintGraph wrong_blocks = g;
  wrong_blocks.constraints[1].blocks.pop_back();
  CHECK_THROWS_AS(CheckGraph(wrong_blocks), InternalError);
  ConstraintGraph out_of_range = g;
  out_of_range.components[1].block = 7;
  CHECK_THROWS_AS(CheckGraph(out_of_range), InternalError);
  ConstraintGraph wrong_kind = g;
  wrong_kind.components[0].rigid = true;  // a point component's block is no pose
  CHECK_THROWS_AS(CheckGraph(wrong_kind), InternalError);
  ConstraintGraph bad_slot = g;
  bad_slot.constraints[1].blocks[0] = -1;
  CHECK_THROWS_AS(CheckGraph(bad_slot), InternalError);
  ConstraintGraph short_nominal = g;
  short_nominal.nominal.points.pop_back();
  CHECK_THROWS_AS(CheckGraph(short_nominal), InternalError);
}

}  // namespace
}  // namespace cfuse
