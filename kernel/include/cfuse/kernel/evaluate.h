// Evaluating residual functions and their Jacobians on block values.
//
// The Jacobian is with respect to the tangent coordinates of each slot (values.h): column
// block k holds d r / d ε_k, the perturbation ε_k of slot k's block, columns in slot order.
// It is computed by forward-mode automatic differentiation (cfuse/kernel/jet.h), in passes of at
// most kJetMaxDerivatives tangent coordinates.
//
// Optionally the blocks are first moved by a tangent offset δ in the chart of `values`
// (x = values ⊞ δ) and the derivative is taken there, in the same chart:
//   J = d r(values ⊞ (δ + ε)) / d ε  at ε = 0.
// The iterated Kalman update relinearises this way about each iterate without leaving the
// chart of its prior, so no chart-transition approximation enters the local iterations.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "cfuse/kernel/residual.h"
#include "cfuse/kernel/values.h"

namespace cfuse {

// Block states of `blocks` (ids into graph_blocks) read from `values`, in double.
std::vector<BlockState<double>> GatherStates(const std::vector<Block>& graph_blocks,
                                             std::span<const int> blocks, const Values& values);

// residual (dimension) and, if jacobian is not null, d residual / d tangent
// (dimension x arity). `offset`, if not null, is a tangent vector over all graph_blocks
// (laid out by Block::tangent_offset) applied before evaluating, as described above.
void EvaluateResidual(const ResidualFunction& f, const std::vector<Block>& graph_blocks,
                      std::span<const int> blocks, const Values& values, Eigen::VectorXd* residual,
                      Eigen::MatrixXd* jacobian, const Eigen::VectorXd* offset = nullptr);

// The same into caller-owned storage, without allocating: `residual` holds dimension()
// numbers; `jacobian`, if not null, dimension() x arity() in column-major order;
// `slot_offset`, if not null, the arity() tangent coordinates of δ in slot order.
void EvaluateResidualAt(const ResidualFunction& f, const std::vector<Block>& graph_blocks,
                        std::span<const int> blocks, const Values& values,
                        const double* slot_offset, double* residual, double* jacobian);

}  // namespace cfuse
