#include "cfuse/interp/joint_estimates.h"

#include <algorithm>

#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/joint_residual.h"
#include "cfuse/kernel/evaluate.h"

namespace cfuse {
namespace {

// Value and Jacobian (1 x 12: parent pose, child pose) of joint j's variable at `values`.
double JointValue(const ConstraintGraph& g, const Joint& j, const Values& values,
                  Eigen::MatrixXd* jacobian) {
  const JointValueFunction q(JointGeometry(j.parent_from_joint, j.child_from_joint, j.axis),
                             ModelOf(j.type).VariableIsLength(), JointValueFunction::BranchCentre(j));
  const std::vector<int> blocks = {g.components[j.parent].block, g.components[j.child].block};
  Eigen::VectorXd value;
  EvaluateResidual(q, g.blocks, blocks, values, &value, jacobian);
  return value[0];
}

std::vector<int> JointsWithVariables(const ConstraintGraph& g, bool independent_only) {
  std::vector<int> out;
  for (size_t j = 0; j < g.joints.size(); ++j) {
    if (HasJointVariable(g.joints[j].type) && !(independent_only && g.joints[j].mimic)) {
      out.push_back(static_cast<int>(j));
    }
  }
  return out;
}

}  // namespace

JointEstimates EstimateJoints(const ConstraintGraph& graph, const GaussianState& state,
                              bool independent_only) {
  JointEstimates out;
  out.joints = JointsWithVariables(graph, independent_only);
  const int n = static_cast<int>(out.joints.size());
  out.values.resize(n);
  // Each row touches two pose blocks: the covariance is gathered block by block.
  std::vector<Eigen::MatrixXd> jacobians(n);
  std::vector<std::array<int, 2>> offsets(n);
  for (int i = 0; i < n; ++i) {
    const Joint& j = graph.joints[out.joints[i]];
    out.values[i] = JointValue(graph, j, state.mean, &jacobians[i]);
    offsets[i] = {graph.blocks[graph.components[j.parent].block].tangent_offset,
                  graph.blocks[graph.components[j.child].block].tangent_offset};
  }
  out.covariance.resize(n, n);
  for (int a = 0; a < n; ++a) {
    for (int b = a; b < n; ++b) {
      double c = 0;
      for (int u = 0; u < 2; ++u)
        for (int v = 0; v < 2; ++v)
          c += (jacobians[a].middleCols<6>(6 * u) *
                state.covariance.block<6, 6>(offsets[a][u], offsets[b][v]) *
                jacobians[b].middleCols<6>(6 * v).transpose())(0, 0);
      out.covariance(a, b) = out.covariance(b, a) = c;
    }
  }
  return out;
}

Eigen::VectorXd JointValues(const ConstraintGraph& graph, const Values& values,
                            bool independent_only) {
  const std::vector<int> joints = JointsWithVariables(graph, independent_only);
  Eigen::VectorXd out(static_cast<int>(joints.size()));
  for (size_t i = 0; i < joints.size(); ++i) {
    out[static_cast<int>(i)] = JointValue(graph, graph.joints[joints[i]], values, nullptr);
  }
  return out;
}

Eigen::MatrixXd JointJacobian(const ConstraintGraph& graph, const Values& values,
                              bool independent_only) {
  const std::vector<int> joints = JointsWithVariables(graph, independent_only);
  int n = 0;
  for (const Block& b : graph.blocks) n = std::max(n, b.tangent_offset + TangentDim(b.kind));
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(static_cast<int>(joints.size()), n);
  Eigen::MatrixXd jacobian;
  for (size_t i = 0; i < joints.size(); ++i) {
    const Joint& j = graph.joints[joints[i]];
    JointValue(graph, j, values, &jacobian);
    const int row = static_cast<int>(i);
    out.row(row).segment<6>(graph.blocks[graph.components[j.parent].block].tangent_offset) +=
        jacobian.leftCols<6>();
    out.row(row).segment<6>(graph.blocks[graph.components[j.child].block].tangent_offset) +=
        jacobian.rightCols<6>();
  }
  return out;
}

}  // namespace cfuse
