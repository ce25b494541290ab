// Forward kinematics: joint values completed (nominal positions, mimic joints from their
// leaders) and every wrong value refused at its place; poses composed down the joint forest
// from roots at their fixed pose or nominal one, checked by hand and by reproducing the nominal
// geometry; frames on components; and a loop that forward kinematics leaves open, closed.
#include "cfuse/constraints/forward_kinematics.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <string>

#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/constraints/model_builder.h"

namespace cfuse {
namespace {

Rigid3d At(double x, double y, double z) {
  return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, y, z));
}

// base (fixed where it stands, a quarter turn about x) -shoulder(z)-> upper -slide(x)-> lower
// -ball-> hand (a pose of its own); base -twin(y)-> follower, twin = 2 shoulder + 0.1; a table
// fixed away from its nominal pose; merged joints 'weld' and 'lock' (locked at 0.25).
ConstraintGraph Arm() {
  ModelBuilder b("arm", "arm.yaml");
  const Rigid3d T0(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX())),
                   Eigen::Vector3d(1, 2, 3));
  const int base = b.AddRigidComponent("base", T0, {});
  const int upper = b.AddRigidComponent("upper", std::nullopt, {});
  const int lower = b.AddRigidComponent("lower", std::nullopt, {});
  b.AddFrame(lower, "tool", At(0, 0, 0.1), {});
  const int hand = b.AddRigidComponent("hand", At(2, 2, 2), {});
  const int follower = b.AddRigidComponent("follower", std::nullopt, {});
  const int table = b.AddRigidComponent("table", Rigid3d(), {});
  b.AddPointComponent("marker", {0.5, 0.5, 0.5}, {});
  auto joint = [&](const char* name, JointType type, int parent, int child, Rigid3d origin,
                   Eigen::Vector3d axis, double position) {
    JointSpec s;
    s.name = name;
    s.type = type;
    s.parent = parent;
    s.child = child;
    s.parent_from_joint = origin;
    s.axis = axis;
    s.position = position;
    return b.AddJoint(s);
  };
  const int shoulder = joint("shoulder", JointType::kRevolute, base, upper, At(0, 0, 0.5),
                             Eigen::Vector3d::UnitZ(), 0);
  joint("slide", JointType::kPrismatic, upper, lower, At(1, 0, 0), Eigen::Vector3d::UnitX(), 0.1);
  joint("ball", JointType::kSpherical, lower, hand, At(0.3, 0, 0), Eigen::Vector3d::UnitX(), 0);
  const int twin = joint("twin", JointType::kContinuous, base, follower, At(0, 0, 1),
                         Eigen::Vector3d::UnitY(), 0.1);
  b.AddMimic(twin, shoulder, 2, 0.1, {});
  b.AddMergedJoint("weld", std::nullopt, {});
  b.AddMergedJoint("lock", 0.25, {});
  b.FixComponent(base, true, true, T0, {});
  b.FixComponent(table, true, true, At(0, 0, -1), {});
  return std::move(b).Build();
}

double Distance(const Rigid3d& a, const Rigid3d& b) {
  return (a.translation - b.translation).norm() + a.rotation.angularDistance(b.rotation);
}

TEST_CASE("forward kinematics: joint values completed, mimic joints from their leaders",
          "[constraints]") {
  const ConstraintGraph g = Arm();
  using Map = std::map<std::string, double>;
  CHECK(CompleteJointValues(g, {}) == Map{{"shoulder", 0}, {"slide", 0.1}, {"twin", 0.1}});
  CHECK(CompleteJointValues(g, {{"shoulder", 0.5, {}}}) ==
        Map{{"shoulder", 0.5}, {"slide", 0.1}, {"twin", 1.1}});
  // A full configuration may list the mimic joint and the merged ones, at the values they take.
  CHECK(
      CompleteJointValues(
          g, {{"twin", 1.1, {}}, {"shoulder", 0.5, {}}, {"lock", 0.25, {}}, {"slide", -0.2, {}}}) ==
      Map{{"shoulder", 0.5}, {"slide", -0.2}, {"twin", 1.1}});
}

TEST_CASE("forward kinematics: every joint value it cannot take, at its place", "[constraints]") {
  ConstraintGraph g = Arm();
  g.joints[0].alias = "shoulder_1";
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const struct {
    std::vector<JointValue> values;
    const char* message;
  } cases[] = {
      {{{"shoulder", nan, {}}}, "joint 'shoulder': the value is not finite"},
      {{{"sholder", 1, {}}}, "'sholder' is not a joint of model 'arm' (did you mean 'shoulder'?)"},
      {{{"elbow", 1, {}}}, "'elbow' is not a joint of model 'arm'"},
      {{{"shoulder", 1, {}}, {"shoulder_1", 1, {}}}, "joint 'shoulder_1' is given twice"},
      {{{"weld", 0, {}}}, "joint 'weld' is fixed and has no variable"},
      {{{"lock", 0.3, {}}},
       "joint 'lock' is locked at 0.25 by its limits (lower = upper), not 0.3"},
      {{{"ball", 0, {}}}, "joint 'ball' is spherical and has no variable"},
      {{{"shoulder", 0, {}}, {"twin", 5, {}}},
       "joint 'twin' mimics joint 'shoulder': its value is 2 times that one plus 0.1, 0.1, not 5"},
  };
  for (const auto& c : cases) {
    std::vector<JointValue> values = c.values;
    values.back().where = SourceLocation("q.yaml", static_cast<int>(values.size()), 7);
    values.front().where = SourceLocation("q.yaml", 1, 7);
    INFO(c.message);
    try {
      CompleteJointValues(g, values);
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.message() == c.message);
      CHECK(e.where().ToString() == "q.yaml:" + std::to_string(values.size()) + ":7");
    }
  }
}

TEST_CASE("forward kinematics: poses down the joints from roots fixed or nominal",
          "[constraints]") {
  const ConstraintGraph g = Arm();
  // At the nominal joint values every component is where the model put it, but the table, whose
  // fixed pose is elsewhere.
  const Values nominal = ForwardKinematics(g, CompleteJointValues(g, {}));
  for (const Component& c : g.components) {
    const int i = g.blocks[c.block].index;
    INFO(c.name);
    if (!c.rigid) {
      CHECK(nominal.points[i] == g.nominal.points[i]);
    } else if (c.name == "table") {
      CHECK(Distance(nominal.poses[i], At(0, 0, -1)) == 0);
    } else {
      CHECK(Distance(nominal.poses[i], g.nominal.poses[i]) < 1e-12);
    }
  }
  CHECK(nominal.slacks == g.nominal.slacks);

  // shoulder a quarter turn, slide 0.2: lower's origin at base * (0, 0, 0.5) + Rz (1.2, 0, 0),
  // that is (0, 1.2, 0.5) in the base, turned by a quarter about x: (0, -0.5, 1.2) + (1, 2, 3).
  const Values moved = ForwardKinematics(
      g, CompleteJointValues(g, {{"shoulder", M_PI / 2, {}}, {"slide", 0.2, {}}}));
  auto pose = [&](const char* name) {
    return moved.poses[g.blocks[g.components[g.FindComponent(name)].block].index];
  };
  CHECK((pose("lower").translation - Eigen::Vector3d(1, 1.5, 4.2)).norm() < 1e-12);
  // The follower turns by 2 (π/2) + 0.1 about y, in the base.
  const Eigen::Matrix3d expected =
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix() *
      Eigen::AngleAxisd(M_PI + 0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
  CHECK((pose("follower").RotationMatrix() - expected).norm() < 1e-12);
  // The hand keeps its offset from the ball joint; the spherical joint at its nominal motion.
  const Rigid3d lower_from_hand = g.nominal.poses[g.blocks[g.components[2].block].index].Inverse() *
                                  g.nominal.poses[g.blocks[g.components[3].block].index];
  CHECK(Distance(pose("hand"), pose("lower") * lower_from_hand) < 1e-12);

  const std::vector<std::pair<std::string, Rigid3d>> frames = FramePoses(g, moved);
  std::vector<std::string> names;
  for (const auto& [name, p] : frames) names.push_back(name);
  CHECK(names ==
        std::vector<std::string>{"base", "upper", "lower", "tool", "hand", "follower", "table"});
  CHECK(Distance(frames[3].second, pose("lower") * At(0, 0, 0.1)) < 1e-15);
}

// A link on a hinge about z whose tip, 1 m out along x, must be at (0, 1, 0).
ConstraintGraph Loop() {
  ModelBuilder b("loop", "loop.yaml");
  const int base = b.AddRigidComponent("base", Rigid3d(), {});
  const int link = b.AddRigidComponent("link", std::nullopt, {});
  JointSpec s;
  s.name = "hinge";
  s.type = JointType::kRevolute;
  s.parent = base;
  s.child = link;
  s.axis = Eigen::Vector3d::UnitZ();
  b.AddJoint(s);
  b.AddFeaturePoint(link, "tip", {1, 0, 0}, {});
  b.FixComponent(base, true, true, Rigid3d(), {});
  const Component& c = b.graph().components[link];
  b.AddConstraint(
      "reach", ConstraintKind::kExpression, "expression ==",
      EqualityResidual::Create(MakeFeatureRef(c.block, {1, 0, 0}, "tip"),
                               MakeVectorConstant({0, 1, 0}, Quantity::Length()), b.Context()),
      {});
  return std::move(b).Build();
}

TEST_CASE("forward kinematics: a loop left open is closed, or left as it was", "[constraints]") {
  const ConstraintGraph g = Loop();
  const Values open = ForwardKinematics(g, CompleteJointValues(g, {}));
  Values closed = open;
  REQUIRE(CloseLoops(g, {}, 1.0, false, &closed));
  const Rigid3d& link = closed.poses[1];
  CHECK((link * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(0, 1, 0)).norm() < 1e-10);
  CHECK(std::abs(ModelOf(JointType::kRevolute).Variable(Eigen::Vector3d::UnitZ(), link) -
                 M_PI / 2) < 1e-9);
  CHECK(Distance(closed.poses[0], Rigid3d()) < 1e-10);
  // Closed already: nothing moves.
  Values again = closed;
  CHECK(CloseLoops(g, {}, 1.0, false, &again));
  CHECK(Distance(again.poses[1], closed.poses[1]) == 0);
  // The hinge held where the tip cannot reach: refused, the values as they were.
  Values held = open;
  CHECK_FALSE(CloseLoops(g, {{"hinge", 0.3}}, 1.0, false, &held));
  CHECK(Distance(held.poses[1], open.poses[1]) == 0);
}

}  // namespace
}  // namespace cfuse
