#include "kinematic_forest.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/joint_residual.h"
#include "cfuse/kernel/evaluate.h"

namespace cfuse::internal {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

Rigid3d Motion(const Joint& joint, const Forest& f, const Configuration& x, int j) {
  if (HasJointVariable(joint.type)) {
    const double q = f.multiplier[j] * x.q[f.leader[j]] + f.offset[j];
    return JointMotion(joint.type, joint.axis, q);
  }
  if (ModelOf(joint.type).ParameterCount() == 0) return Rigid3d();
  return x.motion[j];
}

}  // namespace

std::string BuildForest(const ConstraintGraph& g, ForestRules rules, Forest* forest) {
  Forest f;
  const int nc = static_cast<int>(g.components.size());
  for (const Component& c : g.components) {
    if (!c.rigid) {
      return fmt::format(
          "component '{}' is a single point: only rigid components joined by "
          "joints have a parametric form",
          c.name);
    }
  }
  const bool every = rules == ForestRules::kEveryConstraint;
  f.parent_joint.assign(nc, -1);
  for (size_t j = 0; j < g.joints.size(); ++j) {
    const Joint& joint = g.joints[j];
    if (f.parent_joint[joint.child] >= 0) {
      return fmt::format(
          "component '{}' is the child of joints '{}' and '{}': the joints form a "
          "closed loop",
          g.components[joint.child].name, g.joints[f.parent_joint[joint.child]].name, joint.name);
    }
    f.parent_joint[joint.child] = static_cast<int>(j);
  }
  f.held.assign(g.constraints.size(), false);
  // Under the parametric rules every constraint must be a joint's own, its limit, a mimic, or
  // a root's fixed pose.
  std::vector<bool> accounted(g.constraints.size(), false);
  for (const Joint& joint : g.joints) {
    for (int k : {joint.constraint, joint.mimic ? joint.mimic->constraint : -1}) {
      if (k >= 0) accounted[k] = f.held[k] = true;
    }
    if (every && joint.limit_constraint >= 0) accounted[joint.limit_constraint] = true;
  }
  f.fixed.assign(nc, nullptr);
  for (size_t k = 0; k < g.constraints.size(); ++k) {
    if (accounted[k]) continue;
    const Constraint& c = g.constraints[k];
    // A root pose held by a `fixed:` entry (both position and orientation).
    const std::optional<Rigid3d>& fix = c.fixed_pose;
    int component = -1;
    for (int i = 0; i < nc; ++i) {
      if (fix && g.components[i].block == c.blocks[0]) component = i;
    }
    if (!fix || component < 0 || f.parent_joint[component] >= 0 || f.fixed[component]) {
      if (!every) continue;
      return fmt::format(
          "constraint '{}' ({}) is not a joint, a joint limit, a mimic or a fixed "
          "root pose: the parametric form cannot hold it",
          c.name, c.kind_name);
    }
    f.fixed[component] = &*fix;
    f.held[k] = true;
  }
  // Joints from the roots down (breadth first); a cycle leaves some unreached.
  std::vector<std::vector<int>> children(nc);
  for (size_t j = 0; j < g.joints.size(); ++j)
    children[g.joints[j].parent].push_back(static_cast<int>(j));
  std::vector<int> queue;
  for (int c = 0; c < nc; ++c) {
    if (f.parent_joint[c] < 0) queue.push_back(c);
  }
  for (size_t i = 0; i < queue.size(); ++i) {
    for (int j : children[queue[i]]) {
      f.order.push_back(j);
      queue.push_back(g.joints[j].child);
    }
  }
  if (f.order.size() != g.joints.size()) {
    for (const Joint& joint : g.joints) {
      if (std::find(queue.begin(), queue.end(), joint.child) == queue.end()) {
        return fmt::format("joint '{}' is part of a cycle of joints", joint.name);
      }
    }
  }
  if (forest) *forest = std::move(f);
  return "";
}

void LayoutParameters(const ConstraintGraph& g, double position_sigma, double rotation_sigma,
                      Forest* f, bool names) {
  const int nc = static_cast<int>(g.components.size());
  auto add = [&](const auto& name, double sigma) {
    if (names) f->names.push_back(name());
    f->prior_sigma.push_back(sigma);
    f->lower.push_back(-kInf);
    f->upper.push_back(kInf);
    return f->size++;
  };
  f->root_parameter.assign(nc, -1);
  for (int c = 0; c < nc; ++c) {
    if (f->parent_joint[c] >= 0 || f->fixed[c]) continue;
    const std::string& n = g.components[c].name;
    f->root_parameter[c] = f->size;
    for (const char* axis : {"rx", "ry", "rz"}) add([&] { return n + "." + axis; }, rotation_sigma);
    for (const char* axis : {"tx", "ty", "tz"}) add([&] { return n + "." + axis; }, position_sigma);
  }
  const int nj = static_cast<int>(g.joints.size());
  f->joint_parameter.assign(nj, -1);
  f->leader.resize(nj);
  f->multiplier.assign(nj, 1.0);
  f->offset.assign(nj, 0.0);
  for (int j = 0; j < nj; ++j) {
    // A mimic chain resolved to its independent joint (the builder keeps chains acyclic).
    int leader = j;
    while (g.joints[leader].mimic) {
      const JointMimic& m = *g.joints[leader].mimic;
      f->offset[j] += f->multiplier[j] * m.offset;
      f->multiplier[j] *= m.multiplier;
      leader = m.leader;
    }
    f->leader[j] = leader;
  }
  for (int j : f->order) {
    const Joint& joint = g.joints[j];
    if (joint.mimic) continue;
    const JointModel& model = ModelOf(joint.type);
    const int count = model.ParameterCount();
    if (count == 0) continue;
    f->joint_parameter[j] = f->size;
    for (const JointModel::Parameter& parameter : model.Parameters()) {
      add([&] { return *parameter.suffix ? joint.name + "." + parameter.suffix : joint.name; },
          parameter.angle ? rotation_sigma : position_sigma);
    }
  }
  f->twists = f->size;
  f->mimic_twist.assign(nj, -1);
  for (int j = 0; j < nj; ++j) {
    if (g.joints[j].mimic && HasJointVariable(g.joints[j].type)) f->mimic_twist[j] = f->twists++;
  }
  // Bounds on each independent variable from its own limits and its mimics'.
  for (int j = 0; j < nj; ++j) {
    const Joint& joint = g.joints[j];
    if (!HasJointVariable(joint.type) || !joint.limits || joint.limit_constraint < 0) continue;
    const int p = f->joint_parameter[f->leader[j]];
    const double m = f->multiplier[j], o = f->offset[j];
    if (p < 0 || m == 0) continue;
    double lo = (joint.limits->first - o) / m, hi = (joint.limits->second - o) / m;
    if (m < 0) std::swap(lo, hi);
    f->lower[p] = std::max(f->lower[p], lo);
    f->upper[p] = std::min(f->upper[p], hi);
  }
}

Placement Place(const ConstraintGraph& g, const Forest& f, const Configuration& x) {
  Placement p;
  p.world_from_component.resize(g.components.size());
  p.A.resize(g.joints.size());
  p.B.resize(g.joints.size());
  for (size_t c = 0; c < g.components.size(); ++c) {
    if (f.parent_joint[c] < 0) p.world_from_component[c] = f.fixed[c] ? *f.fixed[c] : x.root[c];
  }
  for (int j : f.order) {
    const Joint& joint = g.joints[j];
    p.A[j] = p.world_from_component[joint.parent] * joint.parent_from_joint;
    p.B[j] = p.A[j] * Motion(joint, f, x, j);
    p.world_from_component[joint.child] = p.B[j] * joint.child_from_joint.Inverse();
    p.world_from_component[joint.child].rotation.normalize();
  }
  return p;
}

// The world twists (ω, v) of every parameter: a point moved by parameter i moves by
// ω_i × p + v_i. Columns of a 6 x n matrix [ω; v].
Eigen::MatrixXd Twists(const ConstraintGraph& g, const Forest& f, const Placement& p,
                       const Configuration& x) {
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(6, f.twists);
  auto rotation_about = [&](int column, const Eigen::Vector3d& omega, const Eigen::Vector3d& o) {
    T.col(column).head<3>() = omega;
    T.col(column).tail<3>() = o.cross(omega);  // ω × (p - o) = ω × p + o × ω
  };
  for (size_t c = 0; c < g.components.size(); ++c) {
    const int r = f.root_parameter[c];
    if (r < 0) continue;
    const Eigen::Matrix3d R = x.root[c].RotationMatrix();
    for (int i = 0; i < 3; ++i) {
      rotation_about(r + i, R.col(i), x.root[c].translation);
      T.col(r + 3 + i).tail<3>() = Eigen::Vector3d::Unit(i);
    }
  }
  for (int j : f.order) {
    const int k = f.mimic_twist[j] >= 0 ? f.mimic_twist[j] : f.joint_parameter[j];
    if (k < 0) continue;
    const Joint& joint = g.joints[j];
    ModelOf(joint.type).Twists(joint.axis, p.A[j], p.B[j], &T, k);
  }
  return T;
}

// Per component, the parameters that move it and by how much (a mimic's leader by its
// multiplier): the root's six and every joint's on the way up.
std::vector<std::vector<Influence>> Influences(const ConstraintGraph& g, const Forest& f) {
  std::vector<std::vector<Influence>> out(g.components.size());
  for (size_t c = 0; c < g.components.size(); ++c) {
    int at = static_cast<int>(c);
    while (f.parent_joint[at] >= 0) {
      const int j = f.parent_joint[at];
      const int leader = f.leader[j];
      const int k = f.joint_parameter[leader];
      if (k >= 0 && f.multiplier[j] != 0) {
        for (int i = 0; i < ModelOf(g.joints[leader].type).ParameterCount(); ++i) {
          out[c].push_back(
              {k + i, f.multiplier[j], f.mimic_twist[j] >= 0 ? f.mimic_twist[j] : k + i});
        }
      }
      at = g.joints[j].parent;
    }
    if (f.root_parameter[at] >= 0) {
      for (int i = 0; i < 6; ++i) {
        out[c].push_back({f.root_parameter[at] + i, 1.0, f.root_parameter[at] + i});
      }
    }
  }
  return out;
}

// x ⊞ δ.
void Retract(const ConstraintGraph& g, const Forest& f, const Eigen::VectorXd& d,
             Configuration* x) {
  for (size_t c = 0; c < g.components.size(); ++c) {
    const int r = f.root_parameter[c];
    if (r < 0) continue;
    Rigid3d& pose = x->root[c];
    pose.rotation =
        (pose.rotation * Eigen::Quaterniond(ExpSO3<double>(d.segment<3>(r)))).normalized();
    pose.translation += d.segment<3>(r + 3);
  }
  for (int j : f.order) {
    const int k = f.joint_parameter[j];
    if (k < 0) continue;
    const Joint& joint = g.joints[j];
    ModelOf(joint.type).Retract(joint.axis, d.data() + k, &x->q[j], &x->motion[j]);
  }
}

// δ with to = from ⊞ δ (to first order for the rotations, which is all the prior term needs).
Eigen::VectorXd Difference(const ConstraintGraph& g, const Forest& f, const Configuration& from,
                           const Configuration& to) {
  Eigen::VectorXd d = Eigen::VectorXd::Zero(f.size);
  for (size_t c = 0; c < g.components.size(); ++c) {
    const int r = f.root_parameter[c];
    if (r < 0) continue;
    d.segment<3>(r) =
        LogSO3((from.root[c].rotation.conjugate() * to.root[c].rotation).toRotationMatrix());
    d.segment<3>(r + 3) = to.root[c].translation - from.root[c].translation;
  }
  for (int j : f.order) {
    const int k = f.joint_parameter[j];
    if (k < 0) continue;
    const Joint& joint = g.joints[j];
    ModelOf(joint.type)
        .Difference(joint.axis, from.q[j], to.q[j], from.motion[j], to.motion[j], d.data() + k);
  }
  return d;
}

// Parameters from component poses that need not meet the joints (the closed-form starts):
// each root where its start is, each joint's motion read off its two components' starts,
// joint variables on the branch centred on their limits and clamped into them.
Configuration FromPoses(const ConstraintGraph& g, const Forest& f, const Values& start) {
  Configuration x;
  const int nc = static_cast<int>(g.components.size());
  const int nj = static_cast<int>(g.joints.size());
  x.root.resize(nc);
  x.q.assign(nj, 0.0);
  x.motion.resize(nj);
  auto pose = [&](int c) { return start.poses[g.blocks[g.components[c].block].index]; };
  for (int c = 0; c < nc; ++c) x.root[c] = pose(c);
  for (int j : f.order) {
    const Joint& joint = g.joints[j];
    const Rigid3d M = (pose(joint.parent) * joint.parent_from_joint).Inverse() *
                      (pose(joint.child) * joint.child_from_joint);
    if (HasJointVariable(joint.type)) {
      const JointValueFunction value(
          JointGeometry(joint.parent_from_joint, joint.child_from_joint, joint.axis),
          !ModelOf(joint.type).Parameters()[0].angle, JointValueFunction::BranchCentre(joint));
      const std::vector<int> blocks = {g.components[joint.parent].block,
                                       g.components[joint.child].block};
      double q = 0;
      EvaluateResidualAt(value, g.blocks, blocks, start, nullptr, &q, nullptr);
      x.q[j] = std::isfinite(q) ? q : 0.0;
    } else {
      x.motion[j] = ModelOf(joint.type).Nearest(joint.axis, M);
    }
  }
  for (int j : f.order) {
    const int k = f.joint_parameter[j];
    if (k >= 0 && HasJointVariable(g.joints[j].type))
      x.q[j] = std::clamp(x.q[j], f.lower[k], f.upper[k]);
  }
  return x;
}

void ComponentPoses(const ConstraintGraph& graph, const Forest& f,
                    const std::vector<std::vector<Influence>>& influence, const Configuration& x,
                    Values* values, Eigen::MatrixXd* G) {
  const Placement place = Place(graph, f, x);
  for (size_t c = 0; c < graph.components.size(); ++c) {
    values->poses[graph.blocks[graph.components[c].block].index] = place.world_from_component[c];
  }
  const Eigen::MatrixXd T = Twists(graph, f, place, x);
  G->setZero(graph.tangent_dim(), f.size);
  for (size_t c = 0; c < graph.components.size(); ++c) {
    const Rigid3d& pose = place.world_from_component[c];
    const int offset = graph.blocks[graph.components[c].block].tangent_offset;
    const Eigen::Matrix3d Rt = pose.RotationMatrix().transpose();
    for (const Influence& in : influence[c]) {
      const auto t = T.col(in.twist);
      G->block<3, 1>(offset, in.parameter) += in.multiplier * (Rt * t.head<3>());
      G->block<3, 1>(offset + 3, in.parameter) +=
          in.multiplier * (t.head<3>().cross(pose.translation) + t.tail<3>());
    }
  }
}

}  // namespace cfuse::internal
