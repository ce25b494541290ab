#include "cfuse/constraints/model_builder.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "cfuse/constraints/dof.h"
#include "cfuse/constraints/evaluate.h"
#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/fix_pose.h"
#include "cfuse/constraints/kinds/joint_residual.h"
#include "cfuse/constraints/kinds/mimic_joint.h"
#include "cfuse/constraints/kinds/registry.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/evaluate.h"
#include "kinds/kind_support.h"
#include "row_selection.h"

namespace cfuse {
namespace {

std::string Located(const SourceLocation& where) {
  return where.known() ? " (at " + where.ToString() + ")" : "";
}

// An edge's or face's name within its component ('/' cannot occur in a name).
std::string PartKey(int component, const std::string& name) {
  return fmt::format("{}/{}", component, name);
}

}  // namespace

ModelBuilder::ModelBuilder(std::string model_name, std::string source) {
  graph_.name = std::move(model_name);
  graph_.source = std::move(source);
}

bool ModelBuilder::IsIdentifier(std::string_view name) {
  if (name.empty()) return false;
  auto alpha = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; };
  if (!alpha(name[0])) return false;
  for (char c : name) {
    if (!alpha(c) && !(c >= '0' && c <= '9')) return false;
  }
  return true;
}

void ModelBuilder::RequireIdentifier(const std::string& name, const char* what,
                                     const SourceLocation& where) {
  if (!IsIdentifier(name)) {
    throw InputError(where, fmt::format("invalid {} name '{}': names are letters, digits and '_', "
                                        "not starting with a digit",
                                        what, name));
  }
  // The expression language's keywords could never be referenced.
  if (name == "in" || name == "nominal") {
    throw InputError(where, fmt::format("invalid {} name '{}': it is a reserved word", what, name));
  }
}

int ModelBuilder::AddBlock(BlockKind kind, const std::string& name) {
  Block b;
  b.kind = kind;
  b.name = name;
  b.tangent_offset = tangent_dim_;
  tangent_dim_ += TangentDim(kind);
  switch (kind) {
    case BlockKind::kPoint:
      b.index = static_cast<int>(graph_.nominal.points.size());
      graph_.nominal.points.push_back(Eigen::Vector3d::Zero());
      break;
    case BlockKind::kPose:
      b.index = static_cast<int>(graph_.nominal.poses.size());
      graph_.nominal.poses.push_back(Rigid3d());
      break;
    case BlockKind::kSlack:
      b.index = static_cast<int>(graph_.nominal.slacks.size());
      graph_.nominal.slacks.push_back(0.0);
      break;
  }
  graph_.blocks.push_back(b);
  return static_cast<int>(graph_.blocks.size()) - 1;
}

namespace {
int Lookup(const std::unordered_map<std::string, int>& index, const std::string& name) {
  const auto it = index.find(name);
  return it == index.end() ? -1 : it->second;
}
}  // namespace

int ModelBuilder::FindComponent(const std::string& name) const {
  return Lookup(component_index_, name);
}
int ModelBuilder::FindJoint(const std::string& name) const { return Lookup(joint_index_, name); }
int ModelBuilder::FindConstraint(const std::string& name) const {
  return Lookup(constraint_index_, name);
}

const std::vector<std::pair<int, int>>& ModelBuilder::FindBarePoint(const std::string& name) const {
  static const std::vector<std::pair<int, int>> kNone;
  const auto it = bare_points_.find(name);
  return it == bare_points_.end() ? kNone : it->second;
}

void ModelBuilder::IndexComponent(int component) {
  const Component& c = graph_.components[component];
  component_index_[c.name] = component;
  if (!c.alias.empty()) component_index_[c.alias] = component;
  for (size_t f = 0; f < c.frames.size(); ++f) {
    frame_index_[c.frames[f].name] = {component, static_cast<int>(f)};
    if (!c.frames[f].alias.empty())
      frame_index_[c.frames[f].alias] = {component, static_cast<int>(f)};
  }
  if (!c.rigid) bare_points_[c.name].emplace_back(component, -1);
  for (size_t i = 0; i < c.points.size(); ++i) {
    bare_points_[c.points[i].name].emplace_back(component, static_cast<int>(i));
  }
  Component& indexed = graph_.components[component];
  if (indexed.point_index.size() != indexed.points.size()) {
    indexed.point_index.clear();
    for (size_t i = 0; i < c.points.size(); ++i) indexed.point_index[c.points[i].name] = int(i);
  }
  for (const Edge& e : c.edges) edge_keys_.insert(PartKey(component, e.name));
  for (const Face& f : c.faces) face_keys_.insert(PartKey(component, f.name));
}

void ModelBuilder::RequireUniqueComponent(const std::string& name,
                                          const SourceLocation& where) const {
  if (static_cast<int>(graph_.components.size()) >= kMaxComponents) {
    throw InputError(where, fmt::format("the model has more than {} components", kMaxComponents));
  }
  const int existing = FindComponent(name);
  if (existing >= 0) {
    throw InputError(where, fmt::format("duplicate component name '{}', first defined{}", name,
                                        Located(graph_.components[existing].where)));
  }
  if (const auto f = frame_index_.find(name); f != frame_index_.end()) {
    const ComponentFrame& frame = graph_.components[f->second.first].frames[f->second.second];
    throw InputError(where,
                     fmt::format("'{}' is already a frame on component '{}'{}", name,
                                 graph_.components[f->second.first].name, Located(frame.where)));
  }
}

void ModelBuilder::RequireUniqueConstraint(const std::string& name,
                                           const SourceLocation& where) const {
  if (static_cast<int>(graph_.constraints.size()) >= kMaxConstraints) {
    throw InputError(where, fmt::format("the model has more than {} constraints", kMaxConstraints));
  }
  const int existing = FindConstraint(name);
  if (existing >= 0) {
    throw InputError(where, fmt::format("duplicate constraint name '{}', first defined{}", name,
                                        Located(graph_.constraints[existing].where)));
  }
}

int ModelBuilder::AddPointComponent(const std::string& name, const Eigen::Vector3d& position,
                                    const SourceLocation& where) {
  RequireIdentifier(name, "point", where);
  RequireUniqueComponent(name, where);
  Component c;
  c.name = name;
  c.rigid = false;
  c.block = AddBlock(BlockKind::kPoint, name);
  c.where = where;
  graph_.nominal.points[graph_.blocks[c.block].index] = position;
  graph_.components.push_back(std::move(c));
  IndexComponent(static_cast<int>(graph_.components.size()) - 1);
  return static_cast<int>(graph_.components.size()) - 1;
}

int ModelBuilder::AddRigidComponent(const std::string& name,
                                    const std::optional<Rigid3d>& world_from_component,
                                    const SourceLocation& where) {
  RequireIdentifier(name, "component", where);
  RequireUniqueComponent(name, where);
  Component c;
  c.name = name;
  c.rigid = true;
  c.block = AddBlock(BlockKind::kPose, name);
  c.where = where;
  graph_.components.push_back(std::move(c));
  const int index = static_cast<int>(graph_.components.size()) - 1;
  IndexComponent(index);
  SetNominalPose(index, world_from_component.value_or(Rigid3d()));
  graph_.components[index].pose_given = world_from_component.has_value();
  return index;
}

void ModelBuilder::SetNominalPose(int component, const Rigid3d& world_from_component) {
  const Component& c = graph_.components.at(component);
  CFUSE_CHECK(c.rigid);
  for (const Constraint& k : graph_.constraints) {
    for (int b : k.blocks) CFUSE_CHECK_MSG(b != c.block, "nominal pose changed under a constraint");
  }
  Rigid3d pose = world_from_component;
  pose.rotation.normalize();
  graph_.nominal.poses[graph_.blocks[c.block].index] = pose;
}

int ModelBuilder::AddFeaturePoint(int component, const std::string& name,
                                  const Eigen::Vector3d& position, const SourceLocation& where) {
  Component& c = graph_.components.at(component);
  CFUSE_CHECK(c.rigid);
  RequireIdentifier(name, "point", where);
  const int existing = c.FindPoint(name);
  if (existing >= 0) {
    throw InputError(where, fmt::format("duplicate point name '{}' in component '{}', first "
                                        "defined{}",
                                        name, c.name, Located(c.points[existing].where)));
  }
  if (num_feature_points_ >= kMaxFeaturePoints) {
    throw InputError(where, fmt::format("the model has more than {} points", kMaxFeaturePoints));
  }
  ++num_feature_points_;
  c.points.push_back({name, position, where});
  c.point_index[name] = static_cast<int>(c.points.size()) - 1;
  bare_points_[name].emplace_back(component, static_cast<int>(c.points.size()) - 1);
  return static_cast<int>(c.points.size()) - 1;
}

void ModelBuilder::AddFrame(int component, const std::string& name,
                            const Rigid3d& component_from_frame, const SourceLocation& where) {
  CFUSE_CHECK(graph_.components.at(component).rigid);
  RequireIdentifier(name, "frame", where);
  RequireUniqueComponent(name, where);
  Component& c = graph_.components[component];
  c.frames.push_back({name, component_from_frame, where, ""});
  c.frames.back().component_from_frame.rotation.normalize();
  frame_index_[name] = {component, static_cast<int>(c.frames.size()) - 1};
}

std::optional<std::pair<int, Rigid3d>> ModelBuilder::FindFrame(const std::string& name) const {
  if (const int c = FindComponent(name); c >= 0 && graph_.components[c].rigid) {
    return std::make_pair(c, Rigid3d());
  }
  const auto f = frame_index_.find(name);
  if (f == frame_index_.end()) return std::nullopt;
  return std::make_pair(
      f->second.first,
      graph_.components[f->second.first].frames[f->second.second].component_from_frame);
}

void ModelBuilder::AddEdge(int component, const std::string& name, int a, int b,
                           const SourceLocation& where) {
  Component& c = graph_.components.at(component);
  RequireIdentifier(name, "edge", where);
  if (edge_keys_.count(PartKey(component, name))) {
    for (const Edge& e : c.edges) {
      if (e.name == name) {
        throw InputError(where, fmt::format("duplicate edge name '{}' in component '{}', first "
                                            "defined{}",
                                            name, c.name, Located(e.where)));
      }
    }
  }
  if (a == b) throw InputError(where, fmt::format("edge '{}' joins a point to itself", name));
  c.edges.push_back({name, a, b, where});
  edge_keys_.insert(PartKey(component, name));
}

void ModelBuilder::AddFace(int component, const std::string& name, std::vector<int> loop,
                           const SourceLocation& where) {
  Component& c = graph_.components.at(component);
  RequireIdentifier(name, "face", where);
  if (face_keys_.count(PartKey(component, name))) {
    for (const Face& f : c.faces) {
      if (f.name == name) {
        throw InputError(where, fmt::format("duplicate face name '{}' in component '{}', first "
                                            "defined{}",
                                            name, c.name, Located(f.where)));
      }
    }
  }
  if (loop.size() < 3) {
    throw InputError(
        where, fmt::format("face '{}' has {} points; a face needs at least 3", name, loop.size()));
  }
  std::unordered_set<int> visited;
  for (const int p : loop) {
    if (!visited.insert(p).second) {
      throw InputError(where,
                       fmt::format("face '{}' visits point '{}' twice", name, c.points[p].name));
    }
  }
  c.faces.push_back({name, std::move(loop), where});
  face_keys_.insert(PartKey(component, name));
}

int ModelBuilder::AddJoint(const JointSpec& spec) {
  RequireIdentifier(spec.name, "joint", spec.where);
  if (FindJoint(spec.name) >= 0) {
    throw InputError(spec.where,
                     fmt::format("duplicate joint name '{}', first defined{}", spec.name,
                                 Located(graph_.joints[FindJoint(spec.name)].where)));
  }
  RequireUniqueConstraint(spec.name, spec.where);
  if (merged_joint_names_.count(spec.name)) {
    throw InputError(spec.where, fmt::format("duplicate joint name '{}'", spec.name));
  }
  const Component& parent = graph_.components.at(spec.parent);
  const Component& child = graph_.components.at(spec.child);
  for (const Component* c : {&parent, &child}) {
    if (!c->rigid) {
      throw InputError(spec.where, fmt::format("joint '{}': '{}' is a single-point component; "
                                               "joints connect rigid components",
                                               spec.name, c->name));
    }
  }
  if (spec.parent == spec.child) {
    throw InputError(spec.where,
                     fmt::format("joint '{}' connects '{}' to itself", spec.name, parent.name));
  }
  for (const Joint& j : graph_.joints) {
    if (j.child == spec.child) {
      throw InputError(spec.where,
                       fmt::format("joint '{}': component '{}' is already the child of joint "
                                   "'{}'{}; close a kinematic loop with a constraint instead",
                                   spec.name, child.name, j.name, Located(j.where)));
    }
  }
  // A cycle: the parent is a descendant of the child.
  for (int c = spec.parent;;) {
    int up = -1;
    for (const Joint& j : graph_.joints) {
      if (j.child == c) up = j.parent;
    }
    if (up < 0) break;
    if (up == spec.child) {
      throw InputError(spec.where, fmt::format("joint '{}' closes a cycle: '{}' is already an "
                                               "ancestor of '{}'",
                                               spec.name, child.name, parent.name));
    }
    c = up;
  }
  const double axis_norm = spec.axis.norm();
  if (!(axis_norm > 1e-9) || !std::isfinite(axis_norm)) {
    throw InputError(spec.where, fmt::format("joint '{}': the axis has zero length", spec.name));
  }
  const bool has_variable = HasJointVariable(spec.type);
  if (spec.limits) {
    if (!has_variable || spec.type == JointType::kContinuous) {
      throw InputError(
          spec.where,
          fmt::format("joint '{}': a {} joint has no limits{}", spec.name, JointTypeName(spec.type),
                      spec.type == JointType::kContinuous ? " (use revolute)" : ""));
    }
    if (!(spec.limits->first < spec.limits->second)) {
      throw InputError(spec.where, fmt::format("joint '{}': the lower limit is not below the "
                                               "upper limit",
                                               spec.name));
    }
  }
  if (!has_variable && spec.position != 0) {
    throw InputError(spec.where, fmt::format("joint '{}': a {} joint has no position", spec.name,
                                             JointTypeName(spec.type)));
  }

  Joint joint;
  joint.name = spec.name;
  joint.type = spec.type;
  joint.parent = spec.parent;
  joint.child = spec.child;
  joint.parent_from_joint = spec.parent_from_joint;
  joint.parent_from_joint.rotation.normalize();
  joint.axis = spec.axis / axis_norm;
  joint.limits = spec.limits;
  joint.nominal_position = spec.position;
  joint.where = spec.where;

  const Rigid3d world_from_parent = graph_.nominal.poses[graph_.blocks[parent.block].index];
  const Rigid3d world_from_joint_c = world_from_parent * joint.parent_from_joint *
                                     JointMotion(spec.type, joint.axis, spec.position);
  if (!child.pose_given) {
    for (const Constraint& k : graph_.constraints) {
      if (std::find(k.blocks.begin(), k.blocks.end(), child.block) != k.blocks.end()) {
        throw InputError(spec.where,
                         fmt::format("joint '{}' would place component '{}', but constraint '{}'{} "
                                     "already uses its nominal pose: give '{}' a pose",
                                     spec.name, child.name, k.name, Located(k.where), child.name));
      }
    }
    SetNominalPose(spec.child, world_from_joint_c);
    graph_.components[spec.child].pose_given = true;
    joint.child_from_joint = Rigid3d();
  } else {
    const Rigid3d world_from_child = graph_.nominal.poses[graph_.blocks[child.block].index];
    joint.child_from_joint = world_from_child.Inverse() * world_from_joint_c;
  }

  const JointGeometry geometry(joint.parent_from_joint, joint.child_from_joint, joint.axis);
  if (spec.type != JointType::kFloating) {
    ConstraintParts parts{MakeJointResidual(spec.type, geometry), {parent.block, child.block}, -1};
    joint.constraint = AddConstraint(spec.name, ConstraintKind::kJoint,
                                     fmt::format("{} joint", JointTypeName(spec.type)),
                                     std::move(parts), spec.where);
  }
  const bool prismatic = ModelOf(spec.type).VariableIsLength();
  // A revolute range of a full turn or more does not restrict the angle.
  if (spec.limits && (prismatic || spec.limits->second - spec.limits->first < 2 * M_PI)) {
    const std::string name = UniqueConstraintName(spec.name + "_limit");
    const int slack = AddSlack(name);
    const auto [lo, hi] = *spec.limits;
    const double half = 0.5 * (hi - lo);
    const double u = (spec.position - 0.5 * (lo + hi)) / half;
    SetSlackNominal(slack, internal::NominalSlack(1 - u * u));
    ConstraintParts limit{std::make_shared<JointLimitResidual>(geometry, prismatic, lo, hi),
                          {parent.block, child.block, slack},
                          slack};
    joint.limit_constraint = AddConstraint(name, ConstraintKind::kJointLimit, "joint limit",
                                           std::move(limit), spec.where);
  }
  joint_index_[joint.name] = static_cast<int>(graph_.joints.size());
  graph_.joints.push_back(std::move(joint));
  return static_cast<int>(graph_.joints.size()) - 1;
}

void ModelBuilder::AddMergedJoint(const std::string& name, std::optional<double> locked_at,
                                  const SourceLocation& where) {
  RequireIdentifier(name, "joint", where);
  if (FindJoint(name) >= 0 || merged_joint_names_.count(name)) {
    throw InputError(where, fmt::format("duplicate joint name '{}'", name));
  }
  merged_joint_names_.insert(name);
  graph_.merged_joints.push_back({name, locked_at, where, ""});
}

void ModelBuilder::AddMimic(int follower, int leader, double multiplier, double offset,
                            const SourceLocation& where) {
  const Joint& f = graph_.joints.at(follower);
  const Joint& l = graph_.joints.at(leader);
  if (follower == leader) {
    throw InputError(where, fmt::format("joint '{}' mimics itself", f.name));
  }
  for (const Joint* j : {&f, &l}) {
    if (!HasJointVariable(j->type)) {
      throw InputError(where, fmt::format("joint '{}' mimics joint '{}', but a {} joint has no "
                                          "variable",
                                          f.name, l.name, JointTypeName(j->type)));
    }
  }
  if (f.mimic) {
    throw InputError(where, fmt::format("joint '{}' already mimics joint '{}'", f.name,
                                        graph_.joints[f.mimic->leader].name));
  }
  // A chain of mimics must end: the leader may not follow the follower, directly or not.
  for (int j = leader; graph_.joints[j].mimic; j = graph_.joints[j].mimic->leader) {
    if (graph_.joints[j].mimic->leader == follower) {
      throw InputError(
          where, fmt::format("joint '{}' mimics joint '{}', which mimics it back", f.name, l.name));
    }
  }
  if (!std::isfinite(multiplier) || !std::isfinite(offset)) {
    throw InputError(where, fmt::format("joint '{}': the mimic multiplier and offset must be "
                                        "finite",
                                        f.name));
  }
  // The slots: the distinct pose blocks of the two joints.
  std::vector<int> blocks;
  auto slot = [&](int component) {
    const int b = graph_.components[component].block;
    const auto it = std::find(blocks.begin(), blocks.end(), b);
    if (it != blocks.end()) return static_cast<int>(it - blocks.begin());
    blocks.push_back(b);
    return static_cast<int>(blocks.size()) - 1;
  };
  auto side = [&](const Joint& j) {
    MimicResidual::Side s{JointGeometry(j.parent_from_joint, j.child_from_joint, j.axis),
                          ModelOf(j.type).VariableIsLength(), 0, 0};
    s.parent_slot = slot(j.parent);
    s.child_slot = slot(j.child);
    return s;
  };
  MimicResidual::Side fs = side(f), ls = side(l);
  const int slots = static_cast<int>(blocks.size());
  ConstraintParts parts{
      std::make_shared<MimicResidual>(std::move(fs), std::move(ls), slots, multiplier, offset),
      blocks, -1};
  const std::string name = UniqueConstraintName(f.name + "_mimic");
  const int constraint =
      AddConstraint(name, ConstraintKind::kMimicJoint, "mimic joint", std::move(parts), where);
  graph_.joints[follower].mimic = JointMimic{leader, multiplier, offset, constraint};
}

int ModelBuilder::AddSlack(const std::string& constraint_name) {
  return AddBlock(BlockKind::kSlack, constraint_name + ".slack");
}

void ModelBuilder::SetSlackNominal(int slack_block, double value) {
  const Block& b = graph_.blocks.at(slack_block);
  CFUSE_CHECK(b.kind == BlockKind::kSlack);
  graph_.nominal.slacks[b.index] = value;
}

std::string ModelBuilder::UniqueConstraintName(const std::string& preferred) const {
  if (FindConstraint(preferred) < 0) return preferred;
  for (int i = 2;; ++i) {
    const std::string name = fmt::format("{}_{}", preferred, i);
    if (FindConstraint(name) < 0) return name;
  }
}

int ModelBuilder::AddConstraint(const std::string& name, ConstraintKind kind,
                                const std::string& kind_name, ConstraintParts parts,
                                const SourceLocation& where) {
  RequireUniqueConstraint(name, where);
  CFUSE_CHECK(parts.residual != nullptr);
  Constraint c;
  c.name = name;
  c.kind = kind;
  c.kind_name = kind_name;
  c.residual = std::move(parts.residual);
  c.blocks = std::move(parts.blocks);
  c.slack_block = parts.slack_block;
  c.where = where;
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  EvaluateResidual(*c.residual, graph_.blocks, c.blocks, graph_.nominal, &r, &J);
  if (!r.allFinite() || !J.allFinite()) {
    throw InputError(where, fmt::format("constraint '{}' ({}) is not differentiable at the nominal "
                                        "geometry: a length or an angle in it is degenerate there "
                                        "(coincident points, a zero-length vector, or an angle of "
                                        "exactly 0 or 180 degrees)",
                                        name, graph_.Describe(c)));
  }
  constraint_index_[c.name] = static_cast<int>(graph_.constraints.size());
  graph_.constraints.push_back(std::move(c));
  return static_cast<int>(graph_.constraints.size()) - 1;
}

int ModelBuilder::FixComponent(int component, bool position, bool orientation,
                               const Rigid3d& target, const SourceLocation& where) {
  const Component& c = graph_.components.at(component);
  CFUSE_CHECK(c.rigid && (position || orientation));
  const char* what = position && orientation ? "pose" : position ? "position" : "orientation";
  const std::string name = UniqueConstraintName(fmt::format("fixed_{}", c.name));
  ConstraintParts parts{
      std::make_shared<FixPoseResidual>(target, position, orientation), {c.block}, -1};
  const int k = AddConstraint(name, ConstraintKind::kFixed, fmt::format("fixed {}", what),
                              std::move(parts), where);
  if (position && orientation) graph_.constraints[k].fixed_pose = target;
  return k;
}

KindContext ModelBuilder::Context(int slack_block) const {
  return KindContext{&graph_.blocks, &graph_.nominal, slack_block};
}

void ModelBuilder::Merge(const ConstraintGraph& other, const std::string& prefix,
                         const SourceLocation& where) {
  const int block0 = static_cast<int>(graph_.blocks.size());
  const int component0 = static_cast<int>(graph_.components.size());
  const int constraint0 = static_cast<int>(graph_.constraints.size());
  const int joint0 = static_cast<int>(graph_.joints.size());
  if (graph_.components.size() + other.components.size() > size_t(kMaxComponents) ||
      graph_.constraints.size() + other.constraints.size() > size_t(kMaxConstraints)) {
    throw InputError(where, fmt::format("including '{}' makes the model larger than {} components "
                                        "or {} constraints",
                                        other.source, kMaxComponents, kMaxConstraints));
  }
  for (const Component& c : other.components) {
    for (const ComponentFrame& f : c.frames) {
      if (FindFrame(prefix + f.name)) {
        throw InputError(where, fmt::format("including '{}' defines frame '{}'{} again, as a "
                                            "component or frame already defined",
                                            other.source, prefix + f.name, Located(f.where)));
      }
    }
    if (FindComponent(prefix + c.name) >= 0 || frame_index_.count(prefix + c.name)) {
      throw InputError(
          where, fmt::format("including '{}' defines component '{}'{} again, first "
                             "defined{}",
                             other.source, prefix + c.name, Located(c.where),
                             Located(graph_.components[FindComponent(prefix + c.name)].where)));
    }
  }
  for (const Joint& j : other.joints) {
    if (FindJoint(prefix + j.name) >= 0) {
      throw InputError(where, fmt::format("including '{}' defines joint '{}'{} again", other.source,
                                          prefix + j.name, Located(j.where)));
    }
  }
  for (const Constraint& c : other.constraints) {
    if (FindConstraint(prefix + c.name) >= 0) {
      throw InputError(where, fmt::format("including '{}' defines constraint '{}'{} again",
                                          other.source, prefix + c.name, Located(c.where)));
    }
  }
  for (const Block& b : other.blocks) {
    const int id = AddBlock(b.kind, prefix + b.name);
    const Block& nb = graph_.blocks[id];
    switch (b.kind) {
      case BlockKind::kPoint:
        graph_.nominal.points[nb.index] = other.nominal.points[b.index];
        break;
      case BlockKind::kPose:
        graph_.nominal.poses[nb.index] = other.nominal.poses[b.index];
        break;
      case BlockKind::kSlack:
        graph_.nominal.slacks[nb.index] = other.nominal.slacks[b.index];
        break;
    }
  }
  for (Component c : other.components) {
    c.name = prefix + c.name;
    if (!c.alias.empty()) c.alias = prefix + c.alias;
    c.block += block0;
    for (ComponentFrame& f : c.frames) {
      f.name = prefix + f.name;
      if (!f.alias.empty()) f.alias = prefix + f.alias;
    }
    if (c.rigid && num_feature_points_ + static_cast<int>(c.points.size()) > kMaxFeaturePoints) {
      throw InputError(where, fmt::format("including '{}' makes the model larger than {} points",
                                          other.source, kMaxFeaturePoints));
    }
    num_feature_points_ += static_cast<int>(c.points.size());
    graph_.components.push_back(std::move(c));
    IndexComponent(static_cast<int>(graph_.components.size()) - 1);
  }
  for (Constraint c : other.constraints) {
    c.name = prefix + c.name;
    for (int& b : c.blocks) b += block0;
    if (c.slack_block >= 0) c.slack_block += block0;
    constraint_index_[c.name] = static_cast<int>(graph_.constraints.size());
    graph_.constraints.push_back(std::move(c));
  }
  for (MergedJoint m : other.merged_joints) {
    m.name = prefix + m.name;
    if (!m.alias.empty()) m.alias = prefix + m.alias;
    if (FindJoint(m.name) >= 0 || !merged_joint_names_.insert(m.name).second) {
      throw InputError(where, fmt::format("including '{}' defines joint '{}'{} again", other.source,
                                          m.name, Located(m.where)));
    }
    graph_.merged_joints.push_back(std::move(m));
  }
  for (Joint j : other.joints) {
    j.name = prefix + j.name;
    if (!j.alias.empty()) j.alias = prefix + j.alias;
    j.parent += component0;
    j.child += component0;
    if (j.constraint >= 0) j.constraint += constraint0;
    if (j.limit_constraint >= 0) j.limit_constraint += constraint0;
    if (j.mimic) {
      j.mimic->leader += joint0;
      j.mimic->constraint += constraint0;
    }
    joint_index_[j.name] = static_cast<int>(graph_.joints.size());
    if (!j.alias.empty()) joint_index_[j.alias] = static_cast<int>(graph_.joints.size());
    graph_.joints.push_back(std::move(j));
  }
}

ConstraintGraph ModelBuilder::Build() && {
  // A constraint partly implied by those before it keeps its independent rows
  // (constraints/src/row_selection.h). Ranks are taken at the nominal geometry, and only when the
  // constraints hold there: off the constraint surface, rows that depend on each other on it
  // need not.
  const std::vector<std::vector<int>> kept = IndependentRows(graph_, graph_.nominal);
  bool on_surface = !kept.empty();
  Eigen::VectorXd r;
  for (const Constraint& c : graph_.constraints) {
    if (!on_surface) break;
    EvaluateResidual(*c.residual, graph_.blocks, c.blocks, graph_.nominal, &r, nullptr);
    on_surface = r.allFinite() && r.lpNorm<Eigen::Infinity>() <= 1e-9;
  }
  for (size_t i = 0; on_surface && i < kept.size(); ++i) {
    Constraint& c = graph_.constraints[i];
    const int dim = c.residual->dimension();
    const int independent = static_cast<int>(kept[i].size());
    if (independent == 0 || independent == dim || c.slack_block >= 0) continue;
    c.redundant_rows += dim - independent;
    c.residual = std::make_shared<RowSelection>(c.residual, kept[i]);
  }
  return std::move(graph_);
}

}  // namespace cfuse
