// The model builder's checks and what it builds: names (identifiers, reserved words, each kind
// unique), components, points, frames, edges and faces; joints placing or adapting to their
// child, with limits and mimics, and every joint it refuses; constraints that must be
// differentiable at the nominal geometry; fixed components; merging a graph under a prefix;
// and Build keeping only the independent rows of a constraint the earlier ones partly imply.
#include "cfuse/constraints/model_builder.h"

#include <fmt/format.h>

#include <catch2/catch.hpp>
#include <cmath>

#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/evaluate.h"

namespace cfuse {
namespace {

SourceLocation At(int line) { return SourceLocation("m.yaml", line, 3); }

// The message of the InputError `f` throws, with its place checked.
template <typename F>
std::string Refusal(F f, int line) {
  try {
    f();
  } catch (const InputError& e) {
    CHECK(e.where().line == line);
    return e.message();
  }
  FAIL("accepted");
  return "";
}

Rigid3d Shifted(double x) { return Rigid3d(Eigen::Quaterniond::Identity(), {x, 0, 0}); }

// A point p, a rigid base (with a point, a frame, an edge and a face) and arm, free of poses.
struct Model {
  ModelBuilder b{"m", "m.yaml"};
  int p, base, arm, other;
  Model() {
    p = b.AddPointComponent("p", {0, 0, 1}, At(1));
    base = b.AddRigidComponent("base", Rigid3d(), At(2));
    b.AddFeaturePoint(base, "tip", {1, 0, 0}, At(3));
    b.AddFeaturePoint(base, "foot", {0, 1, 0}, At(4));
    b.AddFeaturePoint(base, "heel", {0, 0, 1}, At(5));
    b.AddFrame(base, "tool", Shifted(0.5), At(6));
    arm = b.AddRigidComponent("arm", std::nullopt, At(7));
    other = b.AddRigidComponent("other", Shifted(2), At(8));
  }
  JointSpec Joint(const char* name, JointType type, int parent, int child) const {
    JointSpec s;
    s.name = name;
    s.type = type;
    s.parent = parent;
    s.child = child;
    s.parent_from_joint = Shifted(1);
    s.axis = {0, 0, 2};
    s.where = At(20);
    return s;
  }
};

TEST_CASE("model builder: names are identifiers, not reserved words, each used once",
          "[constraints]") {
  for (const char* ok : {"a", "_x1", "Arm_2"}) CHECK(ModelBuilder::IsIdentifier(ok));
  for (const char* bad : {"", "1a", "a-b", "a.b", "a b", "caf\xC3\xA9"}) {
    CHECK_FALSE(ModelBuilder::IsIdentifier(bad));
  }
  Model m;
  CHECK(Refusal([&] { m.b.AddPointComponent("2p", {}, At(9)); }, 9) ==
        "invalid point name '2p': names are letters, digits and '_', not starting with a digit");
  CHECK(Refusal([&] { m.b.AddRigidComponent("nominal", std::nullopt, At(9)); }, 9) ==
        "invalid component name 'nominal': it is a reserved word");
  CHECK(Refusal([&] { m.b.AddPointComponent("arm", {}, At(9)); }, 9) ==
        "duplicate component name 'arm', first defined (at m.yaml:7:3)");
  CHECK(Refusal([&] { m.b.AddRigidComponent("tool", std::nullopt, At(9)); }, 9) ==
        "'tool' is already a frame on component 'base' (at m.yaml:6:3)");
  CHECK(Refusal([&] { m.b.AddFrame(m.arm, "p", Rigid3d(), At(9)); }, 9) ==
        "duplicate component name 'p', first defined (at m.yaml:1:3)");
  CHECK(Refusal([&] { m.b.AddFeaturePoint(m.base, "tip", {}, At(9)); }, 9) ==
        "duplicate point name 'tip' in component 'base', first defined (at m.yaml:3:3)");
  CHECK_THROWS_AS(m.b.AddFeaturePoint(m.p, "q", {}, At(9)), InternalError);  // not rigid
  m.b.AddFeaturePoint(m.arm, "tip", {}, At(10));  // another component's point name is fine
  CHECK(m.b.FindBarePoint("tip") == std::vector<std::pair<int, int>>{{m.base, 0}, {m.arm, 0}});
  CHECK(m.b.FindBarePoint("p") == std::vector<std::pair<int, int>>{{m.p, -1}});
  CHECK(m.b.FindBarePoint("nothing").empty());
  CHECK(m.b.FindFrame("tool")->first == m.base);
  CHECK(m.b.FindFrame("tool")->second.translation.x() == 0.5);
  CHECK(m.b.FindFrame("arm")->first == m.arm);
  CHECK_FALSE(m.b.FindFrame("p"));
}

TEST_CASE("model builder: edges and faces", "[constraints]") {
  Model m;
  m.b.AddEdge(m.base, "e", 0, 1, At(11));
  m.b.AddEdge(m.arm, "e", 0, 1, At(11));  // names are per component
  CHECK(Refusal([&] { m.b.AddEdge(m.base, "e", 1, 2, At(12)); }, 12) ==
        "duplicate edge name 'e' in component 'base', first defined (at m.yaml:11:3)");
  CHECK(Refusal([&] { m.b.AddEdge(m.base, "loop", 2, 2, At(12)); }, 12) ==
        "edge 'loop' joins a point to itself");
  m.b.AddFace(m.base, "f", {0, 1, 2}, At(13));
  CHECK(Refusal(
            [&] {
              m.b.AddFace(m.base, "f", {2, 1, 0}, At(14));
            },
            14) == "duplicate face name 'f' in component 'base', first defined (at m.yaml:13:3)");
  CHECK(Refusal(
            [&] {
              m.b.AddFace(m.base, "g", {0, 1}, At(14));
            },
            14) == "face 'g' has 2 points; a face needs at least 3");
  CHECK(Refusal(
            [&] {
              m.b.AddFace(m.base, "g", {0, 1, 2, 1}, At(14));
            },
            14) == "face 'g' visits point 'foot' twice");
  const Component& base = m.b.graph().components[m.base];
  CHECK(base.edges.size() == 1);
  REQUIRE(base.faces.size() == 1);
  CHECK(base.faces[0].loop == std::vector<int>{0, 1, 2});
}

TEST_CASE("model builder: a joint places a child without a pose, adapts to one with",
          "[constraints]") {
  Model m;
  JointSpec s = m.Joint("j", JointType::kRevolute, m.base, m.arm);
  s.position = 0.5;
  s.limits = {{-1, 1}};
  const int j = m.b.AddJoint(s);
  const ConstraintGraph& g = m.b.graph();
  const Joint& joint = g.joints[j];
  CHECK(joint.axis == Eigen::Vector3d::UnitZ());  // normalised
  CHECK(joint.nominal_position == 0.5);
  const Rigid3d placed = g.nominal.poses[g.blocks[g.components[m.arm].block].index];
  const Rigid3d expected = Shifted(1) * JointMotion(JointType::kRevolute, joint.axis, 0.5);
  CHECK((placed.translation - expected.translation).norm() < 1e-15);
  CHECK(placed.rotation.angularDistance(expected.rotation) < 1e-15);
  CHECK(g.components[m.arm].pose_given);
  // Its constraint, then its limit with the slack of its nominal position: u = 0.5.
  REQUIRE(joint.limit_constraint == joint.constraint + 1);
  const Constraint& limit = g.constraints[joint.limit_constraint];
  CHECK(limit.name == "j_limit");
  CHECK(limit.kind == ConstraintKind::kJointLimit);
  CHECK(g.nominal.slacks[g.blocks[limit.slack_block].index] == Approx(std::sqrt(0.75)));

  // A child with a pose keeps it; the joint holds at its position there.
  JointSpec t = m.Joint("k", JointType::kPrismatic, m.arm, m.other);
  t.position = 0.25;
  const Joint& k = g.joints[m.b.AddJoint(t)];
  CHECK(g.nominal.poses[g.blocks[g.components[m.other].block].index].translation.x() == 2);
  Eigen::VectorXd r;
  for (const Constraint& c : g.constraints) {
    EvaluateResidual(*c.residual, g.blocks, c.blocks, g.nominal, &r, nullptr);
    INFO(c.name);
    CHECK(r.norm() < 1e-12);
  }
  CHECK(k.child_from_joint.translation.norm() > 0);
  // A revolute range of a whole turn restricts nothing: no limit constraint.
  JointSpec u = m.Joint("whole", JointType::kRevolute, m.arm, m.b.AddRigidComponent("c", {}, {}));
  u.limits = {{-M_PI, M_PI}};
  CHECK(g.joints[m.b.AddJoint(u)].limit_constraint == -1);
}

TEST_CASE("model builder: every joint it refuses, at the joint", "[constraints]") {
  Model m;
  m.b.AddJoint(m.Joint("j", JointType::kRevolute, m.base, m.arm));
  m.b.AddMergedJoint("weld", std::nullopt, At(21));
  auto refusal = [&](JointSpec s) { return Refusal([&] { m.b.AddJoint(s); }, 20); };
  CHECK(refusal(m.Joint("j", JointType::kFixed, m.arm, m.other)) ==
        "duplicate joint name 'j', first defined (at m.yaml:20:3)");
  CHECK(refusal(m.Joint("weld", JointType::kFixed, m.arm, m.other)) ==
        "duplicate joint name 'weld'");
  CHECK(refusal(m.Joint("in", JointType::kFixed, m.arm, m.other)) ==
        "invalid joint name 'in': it is a reserved word");
  CHECK(refusal(m.Joint("x", JointType::kFixed, m.arm, m.p)) ==
        "joint 'x': 'p' is a single-point component; joints connect rigid components");
  CHECK(refusal(m.Joint("x", JointType::kFixed, m.other, m.other)) ==
        "joint 'x' connects 'other' to itself");
  CHECK(refusal(m.Joint("x", JointType::kFixed, m.other, m.arm)) ==
        "joint 'x': component 'arm' is already the child of joint 'j' (at m.yaml:20:3); close a "
        "kinematic loop with a constraint instead");
  CHECK(refusal(m.Joint("x", JointType::kFixed, m.arm, m.base)) ==
        "joint 'x' closes a cycle: 'base' is already an ancestor of 'arm'");
  JointSpec s = m.Joint("x", JointType::kRevolute, m.arm, m.other);
  s.axis = {0, 0, 1e-10};
  CHECK(refusal(s) == "joint 'x': the axis has zero length");
  s.axis = {std::nan(""), 0, 1};
  CHECK(refusal(s) == "joint 'x': the axis has zero length");
  s = m.Joint("x", JointType::kFixed, m.arm, m.other);
  s.limits = {{0, 1}};
  CHECK(refusal(s) == "joint 'x': a fixed joint has no limits");
  s.type = JointType::kContinuous;
  CHECK(refusal(s) == "joint 'x': a continuous joint has no limits (use revolute)");
  s.type = JointType::kRevolute;
  s.limits = {{1, 1}};
  CHECK(refusal(s) == "joint 'x': the lower limit is not below the upper limit");
  s = m.Joint("x", JointType::kSpherical, m.arm, m.other);
  s.position = 0.1;
  CHECK(refusal(s) == "joint 'x': a spherical joint has no position");
  // A child whose nominal pose a constraint already uses cannot be moved by its joint.
  const int loose = m.b.AddRigidComponent("loose", std::nullopt, {});
  m.b.FixComponent(loose, true, false, Rigid3d(), At(30));
  CHECK(refusal(m.Joint("x", JointType::kFixed, m.arm, loose)) ==
        "joint 'x' would place component 'loose', but constraint 'fixed_loose' (at m.yaml:30:3) "
        "already uses its nominal pose: give 'loose' a pose");
  CHECK(Refusal([&] { m.b.AddMergedJoint("j", 0.5, At(22)); }, 22) == "duplicate joint name 'j'");
  CHECK(Refusal([&] { m.b.AddMergedJoint("weld", 0.5, At(22)); }, 22) ==
        "duplicate joint name 'weld'");
}

TEST_CASE("model builder: mimic joints, and the mimics it refuses", "[constraints]") {
  Model m;
  const int a = m.b.AddJoint(m.Joint("a", JointType::kRevolute, m.base, m.arm));
  const int b = m.b.AddJoint(m.Joint("b", JointType::kContinuous, m.arm, m.other));
  const int c = m.b.AddRigidComponent("c", std::nullopt, {});
  const int fixed = m.b.AddJoint(m.Joint("f", JointType::kFixed, m.other, c));
  auto refusal = [&](int follower, int leader, double multiplier) {
    return Refusal([&] { m.b.AddMimic(follower, leader, multiplier, 0, At(40)); }, 40);
  };
  CHECK(refusal(a, a, 1) == "joint 'a' mimics itself");
  CHECK(refusal(fixed, a, 1) == "joint 'f' mimics joint 'a', but a fixed joint has no variable");
  CHECK(refusal(b, a, std::nan("")) == "joint 'b': the mimic multiplier and offset must be finite");
  m.b.AddMimic(b, a, -2, 0.1, At(41));
  const Joint& follower = m.b.graph().joints[b];
  REQUIRE(follower.mimic);
  CHECK(follower.mimic->leader == a);
  CHECK(follower.mimic->multiplier == -2);
  const Constraint& k = m.b.graph().constraints[follower.mimic->constraint];
  CHECK(k.name == "b_mimic");
  CHECK(k.kind == ConstraintKind::kMimicJoint);
  // The slots: the distinct poses of both joints, base, arm, other.
  CHECK(k.blocks.size() == 3);
  CHECK(refusal(b, a, 1) == "joint 'b' already mimics joint 'a'");
  CHECK(refusal(a, b, 1) == "joint 'a' mimics joint 'b', which mimics it back");
}

TEST_CASE("model builder: constraints, their names, fixed components", "[constraints]") {
  Model m;
  CHECK(m.b.UniqueConstraintName("fixed_base") == "fixed_base");
  m.b.FixComponent(m.base, true, true, Shifted(0), At(50));
  m.b.FixComponent(m.base, true, false, Shifted(0), At(51));
  m.b.FixComponent(m.base, false, true, Shifted(0), At(52));
  CHECK(m.b.UniqueConstraintName("fixed_base") == "fixed_base_4");
  const std::vector<Constraint>& c = m.b.graph().constraints;
  CHECK(c[0].name == "fixed_base");
  CHECK(c[0].kind_name == "fixed pose");
  CHECK(c[0].fixed_pose.has_value());
  CHECK(c[1].name == "fixed_base_2");
  CHECK(c[1].kind_name == "fixed position");
  CHECK_FALSE(c[1].fixed_pose);
  CHECK(c[2].kind_name == "fixed orientation");
  CHECK_THROWS_AS(m.b.FixComponent(m.p, true, true, Rigid3d(), {}), InternalError);
  CHECK_THROWS_AS(m.b.FixComponent(m.base, false, false, Rigid3d(), {}), InternalError);
  // A nominal pose under a constraint cannot change any more.
  CHECK_THROWS_AS(m.b.SetNominalPose(m.base, Shifted(3)), InternalError);

  const int block = m.b.graph().components[m.p].block;
  std::string why;
  auto p_is = [&](Eigen::Vector3d at) {
    return EqualityResidual::Create(MakePointRef(block), MakeVectorConstant(at, {1, 0}),
                                    m.b.Context());
  };
  CHECK(Refusal(
            [&] {
              m.b.AddConstraint("fixed_base", ConstraintKind::kExpression, "e", p_is({0, 0, 0}),
                                At(53));
            },
            53) == "duplicate constraint name 'fixed_base', first defined (at m.yaml:50:3)");
  // |p| is not differentiable where p is at the origin.
  const ConstraintParts norm =
      EqualityResidual::Create(MakeCall(Function::kNorm,
                                        {MakeBinary(Expr::Op::kSub, MakePointRef(block),
                                                    MakeVectorConstant({0, 0, 1}, {1, 0}), &why)},
                                        &why),
                               MakeConstant(1, {1, 0}), m.b.Context());
  CHECK(
      Refusal([&] { m.b.AddConstraint("n", ConstraintKind::kExpression, "norm ==", norm, At(54)); },
              54) ==
      "constraint 'n' (norm(p - [0, 0, 1] m) == 1 m) is not differentiable at the nominal "
      "geometry: a length or an angle in it is degenerate there (coincident points, a "
      "zero-length vector, or an angle of exactly 0 or 180 degrees)");
  CHECK(m.b.FindConstraint("n") == -1);
}

TEST_CASE("model builder: a graph merged under a prefix", "[constraints]") {
  Model inner;
  inner.b.AddJoint(inner.Joint("j", JointType::kRevolute, inner.base, inner.arm));
  inner.b.AddMergedJoint("weld", 0.2, {});
  inner.b.FixComponent(inner.base, true, true, Rigid3d(), {});
  const ConstraintGraph part = std::move(inner.b).Build();

  ModelBuilder b("top", "top.yaml");
  b.AddRigidComponent("table", Rigid3d(), {});
  b.Merge(part, "r_", At(60));
  const ConstraintGraph& g = b.graph();
  CHECK(g.components.size() == 5);
  CHECK(g.FindComponent("r_arm") == 3);
  CHECK(g.components[3].block == 3);
  CHECK(b.FindFrame("r_tool")->first == 2);
  CHECK(b.FindBarePoint("r_p").size() == 1);
  CHECK(b.FindBarePoint("tip").size() == 1);  // feature points keep their names
  const Joint& j = g.joints[b.FindJoint("r_j")];
  CHECK(j.parent == 2);
  CHECK(j.child == 3);
  CHECK(g.constraints[j.constraint].name == "r_j");
  CHECK(g.constraints[b.FindConstraint("r_fixed_base")].blocks == std::vector<int>{2});
  CHECK(g.FindMergedJoint("r_weld")->locked_at == 0.2);
  CHECK(g.nominal.points.back() == Eigen::Vector3d(0, 0, 1));
  // Merged again under the same prefix: each kind of clash, the first one named.
  ConstraintGraph clash = part;
  auto refusal = [&] { return Refusal([&] { b.Merge(clash, "r_", At(61)); }, 61); };
  CHECK(refusal() ==
        "including 'm.yaml' defines component 'r_p' (at m.yaml:1:3) again, first defined (at "
        "m.yaml:1:3)");
  clash.components = {part.components[1]};
  CHECK(refusal() ==
        "including 'm.yaml' defines frame 'r_tool' (at m.yaml:6:3) again, as a component or frame "
        "already defined");
  clash.components.clear();
  CHECK(refusal() == "including 'm.yaml' defines joint 'r_j' (at m.yaml:20:3) again");
  clash.joints.clear();
  CHECK(refusal() == "including 'm.yaml' defines constraint 'r_j' (at m.yaml:20:3) again");
  clash.constraints.clear();
  clash.blocks.clear();
  CHECK(refusal() == "including 'm.yaml' defines joint 'r_weld' again");
  // Too large a graph is refused before anything is merged.
  ConstraintGraph huge;
  huge.source = "huge.yaml";
  huge.components.resize(ModelBuilder::kMaxComponents);
  CHECK(Refusal([&] { b.Merge(huge, "h_", At(62)); }, 62) ==
        "including 'huge.yaml' makes the model larger than 100000 components or 200000 "
        "constraints");
}

TEST_CASE("model builder: Build keeps the independent rows of a constraint partly implied",
          "[constraints]") {
  for (const bool on_surface : {true, false}) {
    ModelBuilder b("m", "m.yaml");
    const int a = b.AddPointComponent("a", {1, 0, 0}, {});
    const int c = b.AddPointComponent("b", {0, 0, 0}, {});
    const ExprPtr A = MakePointRef(b.graph().components[a].block);
    const ExprPtr B = MakePointRef(b.graph().components[c].block);
    std::string why;
    const ExprPtr ab = MakeBinary(Expr::Op::kSub, A, B, &why);
    const double d = on_surface ? 1 : 2;  // the nominal a - b is (1, 0, 0)
    b.AddConstraint("x", ConstraintKind::kExpression, "dot ==",
                    EqualityResidual::Create(
                        MakeCall(Function::kDot, {ab, MakeVectorConstant({1, 0, 0}, {})}, &why),
                        MakeConstant(d, {1, 0}), b.Context()),
                    {});
    b.AddConstraint(
        "all", ConstraintKind::kExpression, "expression ==",
        EqualityResidual::Create(ab, MakeVectorConstant({d, 0, 0}, {1, 0}), b.Context()), {});
    const ConstraintGraph g = std::move(b).Build();
    INFO("on the surface " << on_surface);
    CHECK(g.constraints[0].residual->dimension() == 1);
    CHECK(g.constraints[1].residual->dimension() == (on_surface ? 2 : 3));
    CHECK(g.constraints[1].redundant_rows == (on_surface ? 1 : 0));
  }
}

}  // namespace
}  // namespace cfuse
