#include "cfuse/constraints/forward_kinematics.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <set>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/joint_residual.h"
#include "cfuse/kernel/batch_solver.h"
#include "cfuse/kernel/did_you_mean.h"
#include "cfuse/kernel/evaluate.h"

namespace cfuse {

std::map<std::string, double> CompleteJointValues(const ConstraintGraph& graph,
                                                  const std::vector<JointValue>& values) {
  std::map<std::string, double> given;  // by the joints' names, whichever name a value used
  std::vector<std::pair<const JointValue*, int>> mimics;  // checked once the leaders are known
  std::set<std::string> seen;
  for (const JointValue& v : values) {
    // References, not a structured binding: clang before 16 cannot capture one in a lambda.
    const std::string& name = v.name;
    const double value = v.value;
    const SourceLocation& where = v.where;
    if (!std::isfinite(value)) {
      throw InputError(where, fmt::format("joint '{}': the value is not finite", name));
    }
    const int j = graph.FindJoint(name);
    const MergedJoint* merged = j < 0 ? graph.FindMergedJoint(name) : nullptr;
    if (j < 0 && !merged) {
      std::vector<std::string> names;
      for (const Joint& joint : graph.joints) {
        if (HasJointVariable(joint.type)) names.push_back(joint.name);
      }
      throw InputError(where, fmt::format("'{}' is not a joint of model '{}'{}", name, graph.name,
                                          DidYouMean(name, names)));
    }
    if (!seen.insert(j >= 0 ? graph.joints[j].name : merged->name).second) {
      throw InputError(where, fmt::format("joint '{}' is given twice", name));
    }
    if (merged) {
      // A merged joint cannot move: its own value (or none) only.
      if (!merged->locked_at) {
        throw InputError(where, fmt::format("joint '{}' is fixed and has no variable", name));
      }
      if (std::abs(value - *merged->locked_at) > 1e-12 * std::max(1.0, std::abs(value))) {
        throw InputError(where, fmt::format("joint '{}' is locked at {} by its limits (lower = "
                                            "upper), not {}",
                                            name, *merged->locked_at, value));
      }
      continue;
    }
    const Joint& joint = graph.joints[j];
    if (!HasJointVariable(joint.type)) {
      throw InputError(where, fmt::format("joint '{}' is {} and has no variable", name,
                                          JointTypeName(joint.type)));
    }
    if (joint.mimic) {
      mimics.emplace_back(&v, j);
      continue;
    }
    given.emplace(joint.name, value);
  }
  std::map<std::string, double> out;
  // A mimic's leader may itself mimic another (a chain the builder keeps acyclic).
  std::function<double(int)> value_of = [&](int j) -> double {
    const Joint& joint = graph.joints[j];
    if (joint.mimic) {
      return joint.mimic->multiplier * value_of(joint.mimic->leader) + joint.mimic->offset;
    }
    const auto it = given.find(joint.name);
    return it == given.end() ? joint.nominal_position : it->second;
  };
  for (size_t j = 0; j < graph.joints.size(); ++j) {
    if (HasJointVariable(graph.joints[j].type)) {
      out[graph.joints[j].name] = value_of(static_cast<int>(j));
    }
  }
  // A mimic joint's value may be given when it agrees with its leader's (as a full
  // configuration lists every joint).
  for (const auto& [m, j] : mimics) {
    const Joint& joint = graph.joints[j];
    const double expected = out.at(joint.name);
    if (std::abs(m->value - expected) > 1e-9 * std::max(1.0, std::abs(expected))) {
      throw InputError(
          m->where, fmt::format("joint '{}' mimics joint '{}': its value is {} "
                                "times that one plus {}, {}, not {}",
                                m->name, graph.joints[joint.mimic->leader].name,
                                joint.mimic->multiplier, joint.mimic->offset, expected, m->value));
    }
  }
  return out;
}

Values ForwardKinematics(const ConstraintGraph& graph,
                         const std::map<std::string, double>& joint_values) {
  Values values = graph.nominal;
  const int n = static_cast<int>(graph.components.size());
  std::vector<int> parent_joint(n, -1);
  std::vector<std::vector<int>> child_joints(n);
  for (size_t j = 0; j < graph.joints.size(); ++j) {
    parent_joint[graph.joints[j].child] = static_cast<int>(j);
    child_joints[graph.joints[j].parent].push_back(static_cast<int>(j));
  }
  auto pose = [&](int c) -> Rigid3d& {
    return values.poses[graph.blocks[graph.components[c].block].index];
  };
  // Roots at a fixed pose where the model gives one.
  for (const Constraint& k : graph.constraints) {
    if (!k.fixed_pose) continue;
    for (int c = 0; c < n; ++c) {
      if (graph.components[c].rigid && graph.components[c].block == k.blocks[0] &&
          parent_joint[c] < 0) {
        pose(c) = *k.fixed_pose;
      }
    }
  }
  // Depth first from each root (iteratively: a chain may be long).
  std::vector<int> stack;
  for (int c = 0; c < n; ++c) {
    if (graph.components[c].rigid && parent_joint[c] < 0) stack.push_back(c);
  }
  while (!stack.empty()) {
    const int c = stack.back();
    stack.pop_back();
    for (int j : child_joints[c]) {
      const Joint& joint = graph.joints[j];
      double q = joint.nominal_position;
      if (HasJointVariable(joint.type)) {
        const auto it = joint_values.find(joint.name);
        q = it == joint_values.end() ? 0.0 : it->second;
      }
      pose(joint.child) = pose(c) * joint.parent_from_joint *
                          JointMotion(joint.type, joint.axis, q) * joint.child_from_joint.Inverse();
      pose(joint.child).rotation.normalize();
      stack.push_back(joint.child);
    }
  }
  return values;
}

std::vector<std::pair<std::string, Rigid3d>> FramePoses(const ConstraintGraph& graph,
                                                        const Values& values) {
  std::vector<std::pair<std::string, Rigid3d>> out;
  for (const Component& c : graph.components) {
    if (!c.rigid) continue;
    const Rigid3d& world_from_component = values.poses[graph.blocks[c.block].index];
    out.emplace_back(c.name, world_from_component);
    for (const ComponentFrame& f : c.frames) {
      out.emplace_back(f.name, world_from_component * f.component_from_frame);
    }
  }
  return out;
}

namespace {

// A joint's variable less a value: holds the joint there.
class JointAt : public ResidualFunction {
 public:
  JointAt(const Joint& j, double value)
      : ResidualFunction(1, {BlockKind::kPose, BlockKind::kPose}),
        q_(JointGeometry(j.parent_from_joint, j.child_from_joint, j.axis),
           ModelOf(j.type).VariableIsLength(), JointValueFunction::BranchCentre(j)),
        value_(value) {}
  void Evaluate(std::span<const BlockState<double>> x, double* r) const override {
    q_.Evaluate(x, r);
    r[0] -= value_;
  }
  void Evaluate(std::span<const BlockState<Jet>> x, Jet* r) const override {
    q_.Evaluate(x, r);
    r[0] -= value_;
  }
  std::string Describe(std::span<const std::string> names) const override {
    return q_.Describe(names) + fmt::format(" == {}", value_);
  }

 private:
  JointValueFunction q_;
  double value_;
};

}  // namespace

bool CloseLoops(const ConstraintGraph& graph, const std::map<std::string, double>& held,
                double extent, bool inequalities, Values* values) {
  std::vector<Factor> factors;
  for (const Constraint& c : graph.constraints) {
    if (c.slack_block >= 0 && !inequalities) continue;
    factors.push_back({c.residual, c.blocks, {}, c.name});
  }
  MatchSlacks(graph, values);
  const double tolerance = 1e-10 * extent;
  if (MaxConstraintResidual(factors, graph.blocks, *values) <= tolerance) return true;
  for (const auto& [name, value] : held) {
    const int j = graph.FindJoint(name);
    if (j < 0 || !HasJointVariable(graph.joints[j].type) || graph.joints[j].mimic) continue;
    const Joint& joint = graph.joints[j];
    factors.push_back({std::make_shared<JointAt>(joint, value),
                       {graph.components[joint.parent].block, graph.components[joint.child].block},
                       {},
                       name});
  }
  GaussianState state = MakePrior(graph.blocks, *values, PriorScale{0.01 * extent, 0.03, 1e-3});
  const BatchSummary summary = SolveBatch(factors, &state, {}, &graph.nominal);
  if (!summary.converged || !(summary.max_constraint_residual <= tolerance)) return false;
  *values = state.mean;
  if (!inequalities) MatchSlacks(graph, values);
  return true;
}

}  // namespace cfuse
