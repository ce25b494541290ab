#include "cfuse/dsl/model_writer.h"

#include <fmt/format.h>

#include <set>

#include "cfuse/constraints/model_builder.h"

namespace cfuse {
namespace {

std::string Num(double v) { return fmt::format("{:.17g}", v == 0 ? 0.0 : v); }

std::string Vec(const Eigen::Vector3d& v) {
  return fmt::format("[{}, {}, {}]", Num(v.x()), Num(v.y()), Num(v.z()));
}

std::string PoseText(const Rigid3d& pose) {
  const Eigen::Quaterniond q = pose.rotation.normalized();
  return fmt::format("{{xyz: {}, quaternion: [{}, {}, {}, {}]}}", Vec(pose.translation), Num(q.w()),
                     Num(q.x()), Num(q.y()), Num(q.z()));
}

// The name a model file refers to an item by: an imported name that is no identifier (a URDF's
// 'arm-1') has its identifier as alias.
template <typename Item>
const std::string& Ident(const Item& item) {
  return ModelBuilder::IsIdentifier(item.name) || item.alias.empty() ? item.name : item.alias;
}

}  // namespace

std::string WriteModel(const ConstraintGraph& graph) {
  std::set<int> joint_constraints;
  for (const Joint& j : graph.joints) {
    for (int k : {j.constraint, j.limit_constraint, j.mimic ? j.mimic->constraint : -1}) {
      if (k >= 0) joint_constraints.insert(k);
    }
  }
  for (size_t k = 0; k < graph.constraints.size(); ++k) {
    if (!joint_constraints.count(static_cast<int>(k))) {
      const Constraint& c = graph.constraints[k];
      throw InputError(c.where.known() ? c.where : SourceLocation(graph.source),
                       fmt::format("cannot write constraint '{}' ({}) as a model file: only "
                                   "joints are written",
                                   c.name, c.kind_name));
    }
  }
  std::string out;
  std::string title = graph.name;
  for (char& c : title) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  out += fmt::format("# {} as a cfuse model, written by `cfuse import` from {}.\n", title,
                     graph.source);
  out += "# Lengths in metres, angles in radians; docs/urdf.md and docs/cao.md explain the "
         "names.\n";
  std::string name;
  for (char c : graph.name) {
    if (c == '"' || c == '\\') name += '\\';
    if (c == '\n' || c == '\r') {
      name += c == '\n' ? "\\n" : "\\r";
      continue;
    }
    name += c;
  }
  out += fmt::format("name: \"{}\"\n", name);
  out += "units: {length: m, angle: rad}\n";
  bool any_rigid = false, any_point = false;
  for (const Component& c : graph.components) (c.rigid ? any_rigid : any_point) = true;
  if (any_rigid) {
    out += "components:\n";
    for (const Component& c : graph.components) {
      if (!c.rigid) continue;
      out += fmt::format("  {}:\n", Ident(c));
      if (c.pose_given) {
        out += fmt::format("    pose: {}\n",
                           PoseText(graph.nominal.poses[graph.blocks[c.block].index]));
      }
      if (!c.frames.empty()) {
        out += "    frames:\n";
        for (const ComponentFrame& f : c.frames) {
          out += fmt::format("      {}: {}\n", Ident(f), PoseText(f.component_from_frame));
        }
      }
      if (c.points.empty()) {
        out += "    points: {}\n";
      } else {
        out += "    points:\n";
        for (const FeaturePoint& p : c.points) {
          out += fmt::format("      {}: {}\n", p.name, Vec(p.position));
        }
      }
      if (!c.edges.empty()) {
        out += "    edges:\n";
        for (const Edge& e : c.edges) {
          out +=
              fmt::format("      {}: [{}, {}]\n", e.name, c.points[e.a].name, c.points[e.b].name);
        }
      }
      if (!c.faces.empty()) {
        out += "    faces:\n";
        for (const Face& f : c.faces) {
          std::string loop;
          for (int i : f.loop) loop += (loop.empty() ? "" : ", ") + c.points[i].name;
          out += fmt::format("      {}: [{}]\n", f.name, loop);
        }
      }
    }
  }
  if (any_point) {
    out += "points:\n";
    for (const Component& c : graph.components) {
      if (!c.rigid) {
        out += fmt::format("  {}: {}\n", Ident(c),
                           Vec(graph.nominal.points[graph.blocks[c.block].index]));
      }
    }
  }
  if (!graph.joints.empty()) {
    out += "joints:\n";
    for (const Joint& j : graph.joints) {
      out += fmt::format("  {}:\n", Ident(j));
      out += fmt::format("    type: {}\n", JointTypeName(j.type));
      out += fmt::format("    parent: {}\n", Ident(graph.components[j.parent]));
      out += fmt::format("    child: {}\n", Ident(graph.components[j.child]));
      out += fmt::format("    origin: {}\n", PoseText(j.parent_from_joint));
      if (HasJointVariable(j.type) || j.type == JointType::kPlanar) {
        out += fmt::format("    axis: {}\n", Vec(j.axis));
      }
      if (j.limits) {
        out += fmt::format("    limits: [{}, {}]\n", Num(j.limits->first), Num(j.limits->second));
      }
      if (HasJointVariable(j.type) && j.nominal_position != 0) {
        out += fmt::format("    position: {}\n", Num(j.nominal_position));
      }
      if (j.mimic) {
        out += fmt::format("    mimic: {{joint: {}, multiplier: {}, offset: {}}}\n",
                           Ident(graph.joints[j.mimic->leader]), Num(j.mimic->multiplier),
                           Num(j.mimic->offset));
      }
    }
  }
  return out;
}

}  // namespace cfuse
