// The URDF importer on the project's own small robots (tests/data/urdf): the model it builds,
// forward kinematics against a hand computation, the DSL model `cfuse import` writes, a DSL
// model that includes a robot, and every malformed input refused at its element.
#include "cfuse/importers/urdf.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <random>

#include "cfuse/constraints/dof.h"
#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/dsl/model_writer.h"
#include "cfuse/kernel/so3.h"
#include "constraints/jacobian_checker.h"
#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

ConstraintGraph Arm() {
  return ImportUrdf(testing::SourcePath("tests/data/urdf/arm.urdf"));
}
ConstraintGraph Mobile() {
  return ImportUrdf(testing::SourcePath("tests/data/urdf/mobile.urdf"));
}

Eigen::Vector3d PointOf(const ConstraintGraph& g, const std::string& component,
                        const std::string& point) {
  const int c = g.FindComponent(component);
  REQUIRE(c >= 0);
  const int p = g.components[c].FindPoint(point);
  REQUIRE(p >= 0);
  return g.components[c].points[p].position;
}

Rigid3d Rotation(const Eigen::Vector3d& axis, double angle) {
  return Rigid3d(Eigen::Matrix3d(RotationAboutAxis<double>(axis, angle)), Eigen::Vector3d::Zero());
}
Rigid3d Translation(double x, double y, double z) {
  return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, y, z));
}

std::map<std::string, Rigid3d> Poses(const ConstraintGraph& g, const Values& values) {
  std::map<std::string, Rigid3d> out;
  for (const auto& [name, pose] : FramePoses(g, values)) out[name] = pose;
  return out;
}

double PoseError(const Rigid3d& a, const Rigid3d& b) {
  return (a.translation - b.translation).norm() + a.rotation.angularDistance(b.rotation);
}

TEST_CASE("urdf: links become components, fixed and locked links frames on them", "[importers]") {
  const ConstraintGraph g = Arm();
  CHECK(g.name == "test_arm");
  std::vector<std::string> components;
  for (const Component& c : g.components) components.push_back(c.name);
  CHECK(components ==
        std::vector<std::string>{"base", "upper", "fore", "slider", "finger_a", "finger_b"});
  // base_plate is fixed to base, tool locked to slider by equal limits.
  const auto plate = g.FindFrame("base_plate");
  REQUIRE(plate);
  CHECK(plate->first == g.FindComponent("base"));
  CHECK(PoseError(plate->second, Translation(0, 0, 0.1) * Rotation({0, 0, 1}, 0.3)) < 1e-15);
  const auto tool = g.FindFrame("tool");
  REQUIRE(tool);
  CHECK(tool->first == g.FindComponent("slider"));
  CHECK(PoseError(tool->second, Translation(0.05, 0, 0) * Rotation({0, 0, 1}, 0.5)) < 1e-15);
  REQUIRE(g.merged_joints.size() == 2);
  CHECK(g.merged_joints[0].name == "plate_mount");
  CHECK_FALSE(g.merged_joints[0].locked_at);
  CHECK(g.merged_joints[1].name == "tool_lock");
  CHECK(g.merged_joints[1].locked_at == 0.5);

  // Points: the link origin, box corners (the collision box repeats the visual one: skipped),
  // cylinder caps, sphere centres; none from meshes; a merged link's prefixed by its name.
  const Component& base = g.components[g.FindComponent("base")];
  std::vector<std::string> names;
  for (const FeaturePoint& p : base.points) names.push_back(p.name);
  CHECK(names == std::vector<std::string>{"origin", "box0_c0", "box0_c1", "box0_c2", "box0_c3",
                                          "box0_c4", "box0_c5", "box0_c6", "box0_c7",
                                          "base_plate_origin", "base_plate_cyl0_top",
                                          "base_plate_cyl0_bottom"});
  CHECK((PointOf(g, "base", "box0_c0") - Eigen::Vector3d(-0.1, -0.1, 0)).norm() < 1e-15);
  CHECK((PointOf(g, "base", "box0_c7") - Eigen::Vector3d(0.1, 0.1, 0.1)).norm() < 1e-15);
  CHECK((PointOf(g, "base", "base_plate_cyl0_top") - Eigen::Vector3d(0, 0, 0.11)).norm() < 1e-15);
  CHECK(g.components[g.FindComponent("upper")].points.size() == 3);  // origin, 2 caps; no mesh
  CHECK((PointOf(g, "upper", "cyl0_top") - Eigen::Vector3d(0, 0, 0.3)).norm() < 1e-15);
  CHECK((PointOf(g, "slider", "tool_origin") - Eigen::Vector3d(0.05, 0, 0)).norm() < 1e-15);
  CHECK(PointOf(g, "slider", "sphere0").norm() < 1e-15);
  // fore's box is turned 0.2 rad about y: its corner 1 (+x, -y, -z half sizes) moves with it.
  const Eigen::Vector3d c1 =
      Eigen::Vector3d(0.1, 0, 0) +
      RotationAboutAxis<double>(Eigen::Vector3d::UnitY(), 0.2) * Eigen::Vector3d(0.1, -0.02, -0.02);
  CHECK((PointOf(g, "fore", "box0_c1") - c1).norm() < 1e-15);
  // Each box has six faces, their normals (right-hand rule) pointing out of it: the tracker
  // matches their sides.
  for (const char* link : {"base", "fore"}) {
    CAPTURE(link);
    const Component& c = g.components[g.FindComponent(link)];
    REQUIRE(c.faces.size() == 6);
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int i = 0; i < 8; ++i) centre += PointOf(g, link, "box0_c" + std::to_string(i)) / 8;
    for (const Face& f : c.faces) {
      CAPTURE(f.name);
      REQUIRE(f.loop.size() == 4);
      const Eigen::Vector3d& a = c.points[f.loop[0]].position;
      const Eigen::Vector3d normal =
          (c.points[f.loop[1]].position - a).cross(c.points[f.loop[2]].position - a);
      CHECK(normal.dot(a - centre) > 0);
    }
  }

  std::vector<std::pair<std::string, JointType>> joints;
  for (const Joint& j : g.joints) joints.emplace_back(j.name, j.type);
  CHECK(joints ==
        std::vector<std::pair<std::string, JointType>>{{"shoulder", JointType::kRevolute},
                                                       {"elbow", JointType::kContinuous},
                                                       {"slide", JointType::kPrismatic},
                                                       {"grip_a", JointType::kPrismatic},
                                                       {"grip_b", JointType::kPrismatic}});
  const Joint& shoulder = g.joints[g.FindJoint("shoulder")];
  REQUIRE(shoulder.limits);
  CHECK(shoulder.limits->first == -2);
  CHECK(shoulder.limit_constraint >= 0);
  CHECK_FALSE(g.joints[g.FindJoint("elbow")].limits);
  const Joint& grip_b = g.joints[g.FindJoint("grip_b")];
  REQUIRE(grip_b.mimic);
  CHECK(g.joints[grip_b.mimic->leader].name == "grip_a");
  CHECK(g.constraints[grip_b.mimic->constraint].name == "grip_b_mimic");
  // A mimic's own limits are not imposed (docs/urdf.md): its leader's hold.
  CHECK_FALSE(grip_b.limits);
  CHECK(grip_b.limit_constraint < 0);

  // 6 + 6 movable joints - 1 mimic - 1 locked.
  const DofReport dof = AnalyzeDof(g, g.nominal);
  CHECK(dof.dof == 10);
  CHECK(dof.rigid_body == 6);
  // Planar (3) and floating (6) joints.
  const DofReport mobile = AnalyzeDof(Mobile(), Mobile().nominal);
  CHECK(mobile.dof == 15);
}

TEST_CASE("urdf: forward kinematics composes each joint's origin and motion", "[importers]") {
  const ConstraintGraph g = Arm();
  const double shoulder = 0.7, elbow = -2.5, slide = 0.04, grip = 0.012;
  const std::vector<JointValue> given = {
      {"shoulder", shoulder, {}}, {"elbow", elbow, {}}, {"slide", slide, {}}, {"grip_a", grip, {}}};
  const std::map<std::string, double> q = CompleteJointValues(g, given);
  CHECK(q.at("grip_b") == grip);  // the mimic follows
  std::map<std::string, Rigid3d> poses = Poses(g, ForwardKinematics(g, q));
  // By hand, link by link (the URDF's chain).
  const Rigid3d base;
  const Rigid3d plate = base * Translation(0, 0, 0.1) * Rotation({0, 0, 1}, 0.3);
  const Rigid3d upper = plate * Translation(0, 0, 0.01) * Rotation({0, 0, 1}, shoulder);
  const Rigid3d fore =
      upper * Translation(0, 0, 0.3) * Rotation({1, 0, 0}, M_PI / 2) * Rotation({0, 0, 1}, elbow);
  const Rigid3d slider = fore * Translation(0.2, 0, 0) * Translation(slide, 0, 0);
  const Rigid3d finger_a = slider * Translation(0, 0.02, 0) * Translation(0, grip, 0);
  const Rigid3d finger_b = slider * Translation(0, -0.02, 0) * Translation(0, -grip, 0);
  const Rigid3d tool = slider * Translation(0.05, 0, 0) * Rotation({0, 0, 1}, 0.5);
  const std::map<std::string, Rigid3d> expected = {
      {"base", base},     {"base_plate", plate},  {"upper", upper},       {"fore", fore},
      {"slider", slider}, {"finger_a", finger_a}, {"finger_b", finger_b}, {"tool", tool}};
  for (const auto& [name, pose] : expected) {
    INFO(name);
    REQUIRE(poses.count(name));
    CHECK(PoseError(poses[name], pose) < 1e-12);
  }
}

TEST_CASE("urdf: joint values fk refuses, at the value", "[importers]") {
  const ConstraintGraph g = Arm();
  const SourceLocation here("q.json", 3, 5);
  auto refused = [&](const std::vector<JointValue>& given, const std::string& message) {
    INFO(message);
    try {
      CompleteJointValues(g, given);
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().line == 3);
      CHECK_THAT(e.message(), Catch::Matchers::StartsWith(message));
    }
  };
  refused({{"wrist", 1, here}}, "'wrist' is not a joint of model 'test_arm'");
  refused({{"plate_mount", 0, here}}, "joint 'plate_mount' is fixed and has no variable");
  refused({{"tool_lock", 0.4, here}}, "joint 'tool_lock' is locked at 0.5");
  refused({{"grip_a", 0.01, {}}, {"grip_b", 0.02, here}}, "joint 'grip_b' mimics joint 'grip_a'");
  refused({{"elbow", 1, {}}, {"elbow", 2, here}}, "joint 'elbow' is given twice");
  refused({{"elbow", std::nan(""), here}}, "joint 'elbow': the value is not finite");
  // What a full configuration lists is accepted: a locked joint at its value, a mimic joint
  // agreeing with its leader.
  CHECK_NOTHROW(CompleteJointValues(
      g, {{"tool_lock", 0.5, here}, {"grip_a", 0.01, {}}, {"grip_b", 0.01, {}}}));
}

// `cfuse import`: the DSL model read back has the same DOF and the same forward kinematics.
TEST_CASE("urdf: the model import writes reads back with the same DOF and kinematics",
          "[importers]") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (const ConstraintGraph& g : {Arm(), Mobile()}) {
    INFO(g.name);
    const std::string text = WriteModel(g);
    const ConstraintGraph back = LoadModelFromString(text, g.name + ".yaml", ".");
    CHECK(AnalyzeDof(back, back.nominal).dof == AnalyzeDof(g, g.nominal).dof);
    CHECK(back.joints.size() == g.joints.size());
    for (int trial = 0; trial < 5; ++trial) {
      std::vector<JointValue> given;
      for (const Joint& j : g.joints) {
        if (HasJointVariable(j.type) && !j.mimic) given.push_back({j.name, 0.5 * u(rng), {}});
      }
      const auto a = Poses(g, ForwardKinematics(g, CompleteJointValues(g, given)));
      const auto b = Poses(back, ForwardKinematics(back, CompleteJointValues(back, given)));
      CHECK(a.size() == b.size());
      for (const auto& [name, pose] : a) {
        INFO(name);
        REQUIRE(b.count(name));
        CHECK(PoseError(b.at(name), pose) < 1e-12);
      }
    }
  }
}

// A DSL model on top of a URDF: markers on links (merged ones too), a known base pose, a
// constraint of its own; forward kinematics puts the root at the base pose.
TEST_CASE("urdf: a model includes a robot and adds markers, a base pose and constraints",
          "[importers]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_urdf_test";
  fs::create_directories(dir);
  fs::copy_file(testing::SourcePath("tests/data/urdf/arm.urdf"), dir / "arm.urdf",
                fs::copy_options::overwrite_existing);
  const std::string model = R"(name: arm with markers
units: {length: mm, angle: deg}
include: arm.urdf
markers:
  m_base: {link: base, xyz: [100, 0, 0]}
  m_plate: {link: base_plate, xyz: [50, 0, 0]}
  m_tool: {link: tool, xyz: [0, 10, 0]}
fixed:
  - {component: base, at: {xyz: [1000, 0, 500], rpy: [0, 0, 90]}}
constraints:
  - distance(slider.origin, base.origin) >= 100 mm
)";
  std::ofstream(dir / "model.yaml") << model;
  LoadOptions options;
  options.include_handlers[".urdf"] = [](const std::string& path, const SourceLocation& where) {
    return ImportUrdf(path, where);
  };
  const ConstraintGraph g = LoadModel((dir / "model.yaml").string(), options);
  CHECK((PointOf(g, "base", "m_base") - Eigen::Vector3d(0.1, 0, 0)).norm() < 1e-15);
  // On the plate (0.1 up, turned 0.3 rad): expressed in base's frame.
  const Eigen::Vector3d plate_marker =
      Eigen::Vector3d(0, 0, 0.1) +
      RotationAboutAxis<double>(Eigen::Vector3d::UnitZ(), 0.3) * Eigen::Vector3d(0.05, 0, 0);
  CHECK((PointOf(g, "base", "m_plate") - plate_marker).norm() < 1e-15);
  const Eigen::Vector3d tool_marker =
      Eigen::Vector3d(0.05, 0, 0) +
      RotationAboutAxis<double>(Eigen::Vector3d::UnitZ(), 0.5) * Eigen::Vector3d(0, 0.01, 0);
  CHECK((PointOf(g, "slider", "m_tool") - tool_marker).norm() < 1e-15);
  const auto poses = Poses(g, ForwardKinematics(g, CompleteJointValues(g, {})));
  const Rigid3d at = Translation(1, 0, 0.5) * Rotation({0, 0, 1}, M_PI / 2);
  CHECK(PoseError(poses.at("base"), at) < 1e-12);
  CHECK(PoseError(poses.at("upper"), at * Translation(0, 0, 0.11) * Rotation({0, 0, 1}, 0.3)) <
        1e-12);
  CHECK(AnalyzeDof(g, g.nominal).dof == 4);  // the base fixed

  // A marker on a link that does not exist, with a suggestion.
  std::ofstream(dir / "bad.yaml")
      << "include: arm.urdf\nmarkers:\n  m: {link: uper, xyz: [0, 0, 0]}\n";
  try {
    LoadModel((dir / "bad.yaml").string(), options);
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(e.where().line == 3);
    CHECK(e.where().column == 13);
    CHECK(e.message() == "marker 'm': no rigid component or frame 'uper' (did you mean 'upper'?)");
  }
}

// Every malformed input: refused at FILE:LINE:COLUMN, naming the element.
TEST_CASE("urdf: malformed files are refused at the element", "[importers]") {
  struct Case {
    const char* xml;
    int line, column;
    const char* element;
    const char* message;
  };
  const std::string link2 = R"(<link name="a"/><link name="b"/>)";
  const Case cases[] = {
      {"<robot name=\"r\"><link name=\"a\">\n</robot>", 2, 1, "", "not well-formed XML"},
      {"<model name=\"r\"/>", 1, 1, "", "not a URDF file: the root element is <model>"},
      {"<robot><link name=\"a\"/></robot>", 1, 1, "", "<robot> needs a 'name'"},
      {"<robot name=\"r\">\n</robot>", 1, 1, "", "the robot has no <link>"},
      {"<robot name=\"r\"><link name=\"a\"/>\n<link name=\"a\"/></robot>", 2, 1, "link 'a'",
       "duplicate link name 'a'"},
      {"<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>\n<joint name=\"j\" type=\"fixed\">"
       "<parent link=\"a\"/><child link=\"c\"/></joint></robot>",
       2, 48, "joint 'j'", "unknown child link 'c'"},
      {"<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>\n<joint name=\"j\" type=\"hinge\">"
       "<parent link=\"a\"/><child link=\"b\"/></joint></robot>",
       2, 1, "joint 'j'", "unknown joint type 'hinge'"},
      {"<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/><link name=\"c\"/>\n"
       "<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint></robot>",
       1, 49, "link 'c'", "a second root link: 'a'"},
      {"<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/><link name=\"c\"/>\n"
       "<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>\n"
       "<joint name=\"k\" type=\"fixed\"><parent link=\"b\"/><child link=\"c\"/></joint>\n"
       "<joint name=\"l\" type=\"fixed\"><parent link=\"c\"/><child link=\"b\"/></joint></robot>",
       4, 48, "joint 'l'", "link 'b' is already the child of joint 'j'"},
      {"<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>\n"
       "<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>\n"
       "<joint name=\"k\" type=\"fixed\"><parent link=\"b\"/><child link=\"a\"/></joint></robot>",
       3, 1, "joint 'k'", "every link is a joint's child: the joints form a cycle"},
      {"<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>\n<joint name=\"j\" "
       "type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/>\n<axis xyz=\"0 0 0\"/>"
       "<limit lower=\"-1\" upper=\"1\"/></joint></robot>",
       3, 1, "joint 'j'", "the axis has zero length"},
      {"<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>\n<joint name=\"j\" "
       "type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><axis xyz=\"0 0 1\"/>\n"
       "<limit lower=\"1\" upper=\"-1\"/></joint></robot>",
       3, 1, "joint 'j'", "inverted limits: lower 1 is above upper -1"},
      {"<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>\n<joint name=\"j\" "
       "type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/></joint></robot>",
       2, 1, "joint 'j'", "a revolute joint needs a <limit>"},
      {"<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>\n<joint name=\"j\" "
       "type=\"continuous\"><parent link=\"a\"/><child link=\"b\"/>\n<mimic joint=\"k\"/>"
       "</joint></robot>",
       3, 1, "joint 'j'", "mimics joint 'k', which does not exist"},
      {"<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>\n<joint name=\"j\" "
       "type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/>\n<origin xyz=\"0 1\"/>"
       "</joint></robot>",
       3, 1, "joint 'j'", "<origin xyz=\"0 1\">: expected 3 numbers, found 2"},
      {"<robot name=\"r\"><link name=\"a\">\n<visual><geometry><box size=\"1 x 1\"/></geometry>"
       "</visual></link></robot>",
       2, 19, "link 'a'", "<box size=\"1 x 1\">: not 3 finite numbers"},
      {"<robot name=\"r\"><link name=\"a\">\n<visual><geometry><cone radius=\"1\"/></geometry>"
       "</visual></link></robot>",
       2, 19, "link 'a'", "unknown geometry <cone>"},
      // Latin-1, not UTF-8: `import` would write it into a model no reader takes (found by
      // fuzz/urdf_fuzz.cpp).
      {"<robot name=\"r\">\n<link name=\"caf\xE9\"/></robot>", 2, 16, "",
       "is not UTF-8 text (byte 0xE9)"},
  };
  for (const Case& c : cases) {
    INFO(c.xml);
    try {
      ImportUrdfFromString(c.xml, "bad.urdf");
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().file == "bad.urdf");
      CHECK(e.where().line == c.line);
      CHECK(e.where().column == c.column);
      CHECK(e.where().element == c.element);
      CHECK_THAT(e.message(), Catch::Matchers::StartsWith(c.message));
    }
  }
  // A mimic of a fixed joint, and of a locked one: at the <mimic>.
  const std::string mimic_fixed =
      "<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/><link name=\"c\"/>\n"
      "<joint name=\"f\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>\n"
      "<joint name=\"j\" type=\"continuous\"><parent link=\"b\"/><child link=\"c\"/>"
      "<mimic joint=\"f\"/></joint></robot>";
  try {
    ImportUrdfFromString(mimic_fixed, "bad.urdf");
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(e.where().line == 3);
    CHECK(e.where().column == 70);
    CHECK_THAT(e.message(), Catch::Matchers::StartsWith("mimics joint 'f', which has no variable"));
  }
  // Files: missing, a directory, binary.
  CHECK_THROWS_WITH(ImportUrdf("no/such.urdf"),
                    Catch::Matchers::StartsWith("no/such.urdf: error: cannot open"));
  CHECK_THROWS_WITH(ImportUrdf(fs::temp_directory_path().string()),
                    Catch::Matchers::Contains("is a directory"));
}

// The new kinds (planar joint, mimic) and every joint of the test robots: autodiff Jacobians
// against central differences at random configurations off the constraint surface.
TEST_CASE("urdf: every constraint's Jacobian matches finite differences", "[importers]") {
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0, 0.3);
  for (const ConstraintGraph& g : {Arm(), Mobile()}) {
    for (int trial = 0; trial < 5; ++trial) {
      Values at = g.nominal;
      for (Rigid3d& pose : at.poses) {
        pose = Rigid3d(Eigen::Quaterniond(1, n(rng), n(rng), n(rng)).normalized(),
                       Eigen::Vector3d(n(rng), n(rng), n(rng)));
      }
      for (double& s : at.slacks) s = n(rng);
      for (const Constraint& c : g.constraints) {
        INFO(g.name << " " << c.name);
        testing::CheckJacobian(g.blocks, *c.residual, c.blocks, at);
      }
    }
  }
}

}  // namespace
}  // namespace cfuse
