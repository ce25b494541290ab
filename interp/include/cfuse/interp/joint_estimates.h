// Joint variables read off an estimate of the component poses: each joint's value is a
// function of its two components' poses (cfuse/constraints/kinds/joint_residual.h, on the branch
// centred on its limits), and their covariance is J P Jᵀ with P the poses' covariance.
// Results (`joints`), the benchmarks and the tests all read joints this way, whichever
// estimator produced the poses.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/estimator.h"

namespace cfuse {

struct JointEstimates {
  std::vector<int> joints;     // graph joint indices: every joint with a variable, in order
  Eigen::VectorXd values;      // rad or m
  Eigen::MatrixXd covariance;  // between them
};

// `independent_only` leaves out mimic joints (their values follow others exactly, so a
// covariance over all of them is singular).
JointEstimates EstimateJoints(const ConstraintGraph& graph, const GaussianState& state,
                              bool independent_only = false);

// The joint values of a configuration (no covariance).
Eigen::VectorXd JointValues(const ConstraintGraph& graph, const Values& values,
                            bool independent_only = false);

// d q / d x: one row per joint of JointValues, over the whole state's tangent coordinates.
Eigen::MatrixXd JointJacobian(const ConstraintGraph& graph, const Values& values,
                              bool independent_only = false);

}  // namespace cfuse
