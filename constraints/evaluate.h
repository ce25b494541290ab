// Evaluating residual functions and their Jacobians on a graph's values.
//
// The Jacobian is with respect to the tangent coordinates of each slot (values.h):
// column block k holds d r / d δ_k evaluated at δ = 0, δ_k the perturbation of slot k's
// block, columns in slot order. It is computed by forward-mode automatic differentiation
// (kernel/jet.h), in passes of at most kJetMaxDerivatives tangent coordinates.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "constraints/graph.h"

namespace cfuse {

// Block states of `blocks` read from `values`, in double.
std::vector<BlockState<double>> GatherStates(const std::vector<Block>& graph_blocks,
                                             std::span<const int> blocks, const Values& values);

// residual (dimension) and, if jacobian is not null, d residual / d tangent
// (dimension x arity). The slots are `blocks`, ids into graph_blocks.
void EvaluateResidual(const ResidualFunction& f, const std::vector<Block>& graph_blocks,
                      std::span<const int> blocks, const Values& values, Eigen::VectorXd* residual,
                      Eigen::MatrixXd* jacobian);

// All constraints of the graph stacked: r (num_equations) and J (num_equations x tangent_dim),
// rows in constraint order.
void EvaluateConstraints(const ConstraintGraph& graph, const Values& values, Eigen::VectorXd* r,
                         Eigen::MatrixXd* J);

}  // namespace cfuse
