// Writing a graph as a model file (dsl/src/model_writer.cpp): the text of each part, names the
// files can refer to (an imported name's identifier), quoting, signed zeros, and what it cannot
// write; read back by the DSL, the same components, points, frames, edges, faces and joints,
// the numbers exact and forward kinematics the same.
#include "cfuse/dsl/model_writer.h"

#include <catch2/catch.hpp>

#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/constraints/model_builder.h"
#include "cfuse/dsl/model_loader.h"

namespace cfuse {
namespace {

Rigid3d Pose(double x, double y, double z, const Eigen::Quaterniond& q = {1, 0, 0, 0}) {
  return Rigid3d(q, Eigen::Vector3d(x, y, z));
}

// A base with points, an edge, a face and a frame; joints of every written kind, one mimicking
// another; a single point; the arm renamed as an importer would ('arm-1', built as 'arm').
ConstraintGraph Robot() {
  ModelBuilder b("robot", "robot.urdf");
  const int base = b.AddRigidComponent("base", Pose(0.5, 0, 0.25, {0.5, 0.5, 0.5, 0.5}), {});
  b.AddFeaturePoint(base, "p0", {-0.0, 0, 0}, {});
  b.AddFeaturePoint(base, "p1", {0.1, 0, 0}, {});
  b.AddFeaturePoint(base, "p2", {0, 0.1, 0}, {});
  b.AddFrame(base, "tool", Pose(0, 0, 0.125), {});
  b.AddEdge(base, "e", 0, 1, {});
  b.AddFace(base, "f", {0, 1, 2}, {});
  b.AddPointComponent("marker", {1, 2, -0.5}, {});
  auto joint = [&](const char* name, JointType type, int parent, const char* child,
                   Eigen::Vector3d axis, double position) {
    JointSpec s;
    s.name = name;
    s.type = type;
    s.parent = parent;
    s.child = b.AddRigidComponent(child, std::nullopt, {});
    s.parent_from_joint = Pose(0.25, 0, 0.5, Eigen::Quaterniond(0.8, 0, 0.6, 0));
    s.axis = axis;
    s.position = position;
    if (type == JointType::kRevolute) s.limits = {{-1.5, 1.5}};
    return b.AddJoint(s);
  };
  const int shoulder = joint("shoulder", JointType::kRevolute, base, "arm", {0, 0, 1}, 0.25);
  const int arm = b.FindComponent("arm");
  joint("slide", JointType::kPrismatic, arm, "finger", {1, 0, 0}, 0);
  const int twin = joint("twin", JointType::kContinuous, base, "wing", {0, 1, 0}, 0.25);
  b.AddMimic(twin, shoulder, -1, 0.5, {});
  joint("weld", JointType::kFixed, arm, "cap", {1, 0, 0}, 0);
  joint("glide", JointType::kPlanar, base, "puck", {0, 0, 1}, 0);
  ConstraintGraph g = std::move(b).Build();
  g.components[arm].alias = "arm";
  g.components[arm].name = "arm-1";
  return g;
}

TEST_CASE("model writer: each part written as the DSL spells it", "[dsl]") {
  const std::string text = WriteModel(Robot());
  CHECK(text.rfind("# robot as a cfuse model, written by `cfuse import` from robot.urdf.\n"
                   "# Lengths in metres, angles in radians; docs/urdf.md and docs/cao.md explain "
                   "the names.\n"
                   "name: \"robot\"\n"
                   "units: {length: m, angle: rad}\n"
                   "components:\n"
                   "  base:\n"
                   "    pose: {xyz: [0.5, 0, 0.25], quaternion: [0.5, 0.5, 0.5, 0.5]}\n"
                   "    frames:\n"
                   "      tool: {xyz: [0, 0, 0.125], quaternion: [1, 0, 0, 0]}\n"
                   "    points:\n"
                   "      p0: [0, 0, 0]\n"  // not -0
                   "      p1: [0.10000000000000001, 0, 0]\n"
                   "      p2: [0, 0.10000000000000001, 0]\n"
                   "    edges:\n"
                   "      e: [p0, p1]\n"
                   "    faces:\n"
                   "      f: [p0, p1, p2]\n"
                   "  arm:\n",
                   0) == 0);
  for (const char* part : {
           "  finger:\n    pose: {",
           "  cap:\n    pose: {xyz: [",
           "\n    points: {}\n",
           "points:\n  marker: [1, 2, -0.5]\njoints:\n",
           "  shoulder:\n    type: revolute\n    parent: base\n    child: arm\n"
           "    origin: {xyz: [0.25, 0, 0.5], quaternion: [0.80000000000000004, 0, "
           "0.59999999999999998, 0]}\n    axis: [0, 0, 1]\n    limits: [-1.5, 1.5]\n"
           "    position: 0.25\n",
           "  slide:\n    type: prismatic\n    parent: arm\n    child: finger\n",
           "    axis: [1, 0, 0]\n  twin:\n",
           "    position: 0.25\n    mimic: {joint: shoulder, multiplier: -1, offset: 0.5}\n",
           "  weld:\n    type: fixed\n    parent: arm\n    child: cap\n    origin: {",
           "  glide:\n    type: planar\n",
       }) {
    INFO(part);
    CHECK(text.find(part) != std::string::npos);
  }
  // No axis for a fixed joint, no position at 0.
  const size_t weld = text.find("  weld:"), glide = text.find("  glide:");
  CHECK(text.substr(weld, glide - weld).find("axis") == std::string::npos);
  const size_t slide = text.find("  slide:"), twin = text.find("  twin:");
  CHECK(text.substr(slide, twin - slide).find("position") == std::string::npos);
}

TEST_CASE("model writer: read back, the same model", "[dsl]") {
  const ConstraintGraph g = Robot();
  const ConstraintGraph back = LoadModelFromString(WriteModel(g), "robot.yaml", ".");
  REQUIRE(back.components.size() == g.components.size());
  for (const Component& c : g.components) {
    const std::string name = c.alias.empty() ? c.name : c.alias;
    INFO(name);
    const int i = back.FindComponent(name);
    REQUIRE(i >= 0);
    const Component& d = back.components[i];
    CHECK(d.rigid == c.rigid);
    if (!c.rigid) {
      CHECK(back.nominal.points[back.blocks[d.block].index] ==
            g.nominal.points[g.blocks[c.block].index]);
      continue;
    }
    const Rigid3d& p = g.nominal.poses[g.blocks[c.block].index];
    const Rigid3d& q = back.nominal.poses[back.blocks[d.block].index];
    CHECK((p.translation - q.translation).norm() == 0);
    CHECK(p.rotation.angularDistance(q.rotation) < 1e-15);
    REQUIRE(d.points.size() == c.points.size());
    for (size_t k = 0; k < c.points.size(); ++k) {
      CHECK(d.points[k].name == c.points[k].name);
      CHECK(d.points[k].position == c.points[k].position);
    }
    REQUIRE(d.frames.size() == c.frames.size());
    for (size_t k = 0; k < c.frames.size(); ++k) {
      CHECK(d.frames[k].name == c.frames[k].name);
      CHECK(d.frames[k].component_from_frame.translation ==
            c.frames[k].component_from_frame.translation);
    }
    REQUIRE(d.edges.size() == c.edges.size());
    for (size_t k = 0; k < c.edges.size(); ++k) CHECK(d.edges[k].b == c.edges[k].b);
    REQUIRE(d.faces.size() == c.faces.size());
    for (size_t k = 0; k < c.faces.size(); ++k) CHECK(d.faces[k].loop == c.faces[k].loop);
  }
  REQUIRE(back.joints.size() == g.joints.size());
  std::vector<JointValue> given;
  for (size_t k = 0; k < g.joints.size(); ++k) {
    const Joint &j = g.joints[k], &d = back.joints[k];
    INFO(j.name);
    CHECK(d.name == j.name);
    CHECK(d.type == j.type);
    CHECK(back.components[d.child].name == (g.components[j.child].alias.empty()
                                                ? g.components[j.child].name
                                                : g.components[j.child].alias));
    CHECK(d.limits == j.limits);
    CHECK(d.nominal_position == j.nominal_position);
    CHECK(d.mimic.has_value() == j.mimic.has_value());
    if (j.mimic) {
      CHECK(d.mimic->leader == j.mimic->leader);
      CHECK(d.mimic->multiplier == j.mimic->multiplier);
      CHECK(d.mimic->offset == j.mimic->offset);
    }
    if (HasJointVariable(j.type) && !j.mimic) given.push_back({j.name, 0.3 + 0.1 * k, {}});
  }
  // Forward kinematics the same, joints moved.
  const std::vector<std::pair<std::string, Rigid3d>> a =
      FramePoses(g, ForwardKinematics(g, CompleteJointValues(g, given)));
  const std::vector<std::pair<std::string, Rigid3d>> b =
      FramePoses(back, ForwardKinematics(back, CompleteJointValues(back, given)));
  REQUIRE(a.size() == b.size());
  for (size_t k = 0; k < a.size(); ++k) {
    INFO(a[k].first);
    CHECK((a[k].second.translation - b[k].second.translation).norm() < 1e-12);
    CHECK(a[k].second.rotation.angularDistance(b[k].second.rotation) < 1e-12);
  }
}

TEST_CASE("model writer: names quoted, and what it cannot write", "[dsl]") {
  ModelBuilder b("say \"hi\"\\\nnow", "odd.urdf");
  const int box = b.AddRigidComponent("box", std::nullopt, {});
  ConstraintGraph g = b.graph();
  const std::string text = WriteModel(g);
  CHECK(text.rfind("# say \"hi\"\\ now as a cfuse model", 0) == 0);  // one comment line
  CHECK(text.find("name: \"say \\\"hi\\\"\\\\\\nnow\"\n") != std::string::npos);
  CHECK(text.find("  box:\n    points: {}\n") != std::string::npos);  // no pose given
  CHECK(text.find("pose") == std::string::npos);
  CHECK(text.find("joints:") == std::string::npos);
  CHECK(text.find("\npoints:") == std::string::npos);
  CHECK(LoadModelFromString(text, "odd.yaml", ".").name == g.name);

  // Only joints' constraints have a place in a model file.
  b.FixComponent(box, true, true, Rigid3d(), {});
  try {
    WriteModel(b.graph());
    FAIL("written");
  } catch (const InputError& e) {
    CHECK(e.where().ToString() == "odd.urdf");  // the constraint has no place of its own
    CHECK(e.message() ==
          "cannot write constraint 'fixed_box' (fixed pose) as a model file: only joints are "
          "written");
  }
}

}  // namespace
}  // namespace cfuse
