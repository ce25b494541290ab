#include "cfuse/dsl/pose_reader.h"

#include <Eigen/Geometry>

#include "yaml_document.h"
#include "yaml_numbers.h"

namespace cfuse {
namespace {

const FileKind kPoseFile{"pose", "a pose file needs 'components' (or 'points')", 64u << 20};

PoseSet Read(const std::string& display, const std::string& text) {
  CheckText(display, text, kPoseFile);
  const Document doc(display, text, kPoseFile);
  const YAML::Node root = doc.Parse();
  if (!root.IsMap()) doc.Fail(root, "a pose file is a mapping with 'components' (and 'points')");
  PoseSet set;
  set.source = display;
  const YAML::Node components = root["components"], points = root["points"];
  if (!Present(components) && !Present(points)) {
    doc.Fail(root, "a pose file needs 'components' (or 'points')");
  }
  if (Present(components)) {
    for (const auto& [key, value] : doc.Entries(components, "components", {})) {
      const std::string name = key.Scalar();
      const std::string what = fmt::format("components.{}", name);
      doc.Entries(value, what, {});  // a mapping without duplicate keys
      const YAML::Node position = value["position"], quaternion = value["quaternion"];
      if (!Present(position)) doc.Fail(value, fmt::format("{} needs 'position'", what));
      if (!Present(quaternion)) doc.Fail(value, fmt::format("{} needs 'quaternion'", what));
      NamedPose p;
      p.name = name;
      p.where = doc.Loc(value);
      p.where.element = what;
      p.pose.translation = Numbers(doc, position, 3, what + " position");
      const Eigen::Vector4d q = Numbers(doc, quaternion, 4, what + " quaternion");
      if (std::abs(q.norm() - 1) > 1e-3) {
        doc.Fail(quaternion, fmt::format("{} quaternion [w, x, y, z] must have norm 1, got {:.6g}",
                                         what, q.norm()));
      }
      p.pose.rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
      set.components.push_back(std::move(p));
    }
  }
  if (Present(points)) {
    for (const auto& [key, value] : doc.Entries(points, "points", {})) {
      NamedPoint p;
      p.name = key.Scalar();
      const std::string what = fmt::format("points.{}", p.name);
      p.where = doc.Loc(value);
      p.where.element = what;
      if (value.IsMap()) {
        doc.Entries(value, what, {});
        const YAML::Node xyz = value["xyz"];
        if (!Present(xyz)) doc.Fail(value, fmt::format("{} needs 'xyz'", what));
        p.xyz = Numbers(doc, xyz, 3, what + " xyz");
      } else {
        p.xyz = Numbers(doc, value, 3, what);
      }
      set.points.push_back(std::move(p));
    }
  }
  return set;
}

const FileKind kJointFile{"joint values", "a joint-values file maps joint names to numbers",
                          16u << 20};

std::vector<JointValue> ReadValues(const std::string& display, const std::string& text) {
  CheckText(display, text, kJointFile);
  const Document doc(display, text, kJointFile);
  const YAML::Node root = doc.Parse();
  if (!root.IsMap()) {
    doc.Fail(root, "a joint-values file is a mapping {\"joint\": value, ...}");
  }
  std::vector<JointValue> out;
  for (const auto& [key, value] : doc.Entries(root, "the joint values", {})) {
    JointValue v;
    v.name = key.Scalar();
    v.where = doc.Loc(key);
    v.where.element = fmt::format("joint '{}'", v.name);
    if (value.IsMap()) {
      const auto entries = doc.Entries(value, v.where.element, {"value", "sigma"});
      const YAML::Node n = Document::Find(entries, "value");
      if (!Present(n)) doc.Fail(value, fmt::format("{} needs 'value'", v.where.element));
      v.value = Number(doc, n, v.where.element);
    } else {
      v.value = Number(doc, value, v.where.element);
    }
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace

std::vector<JointValue> ReadJointValues(const std::string& path) {
  return ReadValues(path, ReadTextFile(path, SourceLocation(), kJointFile));
}

std::vector<JointValue> ReadJointValuesFromString(std::string_view text,
                                                  const std::string& display_name) {
  return ReadValues(display_name, std::string(text));
}

PoseSet ReadPoses(const std::string& path) {
  return Read(path, ReadTextFile(path, SourceLocation(), kPoseFile));
}

PoseSet ReadPosesFromString(std::string_view text, const std::string& display_name) {
  return Read(display_name, std::string(text));
}

}  // namespace cfuse
