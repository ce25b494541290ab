#include "cfuse/constraints/graph.h"

#include <fmt/format.h>

#include <array>

#include "cfuse/constraints/joint_model.h"
#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {
constexpr std::array<std::pair<JointType, const char*>, 7> kJointTypes = {{
    {JointType::kRevolute, "revolute"},
    {JointType::kContinuous, "continuous"},
    {JointType::kPrismatic, "prismatic"},
    {JointType::kSpherical, "spherical"},
    {JointType::kFixed, "fixed"},
    {JointType::kPlanar, "planar"},
    {JointType::kFloating, "floating"},
}};
}  // namespace

int Component::FindPoint(std::string_view point_name) const {
  if (point_index.size() == points.size() && !points.empty()) {
    const auto it = point_index.find(std::string(point_name));
    return it == point_index.end() ? -1 : it->second;
  }
  for (size_t i = 0; i < points.size(); ++i) {
    if (points[i].name == point_name) return static_cast<int>(i);
  }
  return -1;
}

const char* JointTypeName(JointType type) {
  for (const auto& [t, name] : kJointTypes) {
    if (t == type) return name;
  }
  return "?";
}

std::optional<JointType> ParseJointType(std::string_view name) {
  for (const auto& [t, n] : kJointTypes) {
    if (name == n) return t;
  }
  return std::nullopt;
}

Rigid3d JointMotion(JointType type, const Eigen::Vector3d& axis, double q) {
  return ModelOf(type).Motion(axis, q);
}

bool HasJointVariable(JointType type) { return ModelOf(type).HasVariable(); }

void CheckGraph(const ConstraintGraph& graph) {
  CheckValuesFit(graph.blocks, graph.nominal);
  const int num_blocks = static_cast<int>(graph.blocks.size());
  for (const Component& c : graph.components) {
    CFUSE_CHECK_GE(c.block, 0);
    CFUSE_CHECK_LT(c.block, num_blocks);
    CFUSE_CHECK(graph.blocks[c.block].kind == (c.rigid ? BlockKind::kPose : BlockKind::kPoint));
  }
  for (const Constraint& k : graph.constraints) {
    CFUSE_CHECK_MSG(k.residual != nullptr, fmt::format("constraint '{}' has no residual", k.name));
    int arity = 0;
    for (int b : k.blocks) {
      CFUSE_CHECK_GE(b, 0);
      CFUSE_CHECK_LT(b, num_blocks);
      arity += TangentDim(graph.blocks[b].kind);
    }
    CFUSE_CHECK_EQ(arity, k.residual->arity());
  }
}

int ConstraintGraph::tangent_dim() const {
  int n = 0;
  for (const Block& b : blocks) n += TangentDim(b.kind);
  return n;
}

int ConstraintGraph::num_equations() const {
  int m = 0;
  for (const Constraint& c : constraints) m += c.residual->dimension();
  return m;
}

template <typename Item>
static bool Named(const Item& item, std::string_view name) {
  if constexpr (requires { item.alias; }) {
    if (!item.alias.empty() && item.alias == name) return true;
  }
  return item.name == name;
}

template <typename Items>
static int FindByName(const Items& items, std::string_view name) {
  for (size_t i = 0; i < items.size(); ++i) {
    if (Named(items[i], name)) return static_cast<int>(i);
  }
  return -1;
}

int ConstraintGraph::FindComponent(std::string_view n) const { return FindByName(components, n); }
int ConstraintGraph::FindJoint(std::string_view n) const { return FindByName(joints, n); }
const MergedJoint* ConstraintGraph::FindMergedJoint(std::string_view n) const {
  const int i = FindByName(merged_joints, n);
  return i < 0 ? nullptr : &merged_joints[i];
}
int ConstraintGraph::FindConstraint(std::string_view n) const { return FindByName(constraints, n); }

std::optional<std::pair<int, Rigid3d>> ConstraintGraph::FindFrame(std::string_view n) const {
  for (size_t c = 0; c < components.size(); ++c) {
    if (!components[c].rigid) continue;
    if (Named(components[c], n)) return std::make_pair(static_cast<int>(c), Rigid3d());
    for (const ComponentFrame& f : components[c].frames) {
      if (Named(f, n)) return std::make_pair(static_cast<int>(c), f.component_from_frame);
    }
  }
  return std::nullopt;
}

std::vector<std::string> ConstraintGraph::SlotNames(const Constraint& c) const {
  std::vector<std::string> names;
  for (int b : c.blocks) names.push_back(blocks.at(b).name);
  return names;
}

std::string ConstraintGraph::Describe(const Constraint& c) const {
  return c.residual->Describe(SlotNames(c));
}

}  // namespace cfuse
