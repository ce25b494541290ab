// Evaluating all the constraints of a graph at once (cfuse/kernel/evaluate.h evaluates one).
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/evaluate.h"

namespace cfuse {

// All constraints of the graph stacked: r (num_equations) and J (num_equations x tangent_dim),
// rows in constraint order.
void EvaluateConstraints(const ConstraintGraph& graph, const Values& values, Eigen::VectorXd* r,
                         Eigen::MatrixXd* J);

// Every inequality's slack from its constraint at the other blocks' values, λ = ±√max(g, 0)
// (keeping λ's sign), so that a start (a guess, a tracker's first frame) does not begin with
// violated slack equations.
void MatchSlacks(const ConstraintGraph& graph, Values* values);

}  // namespace cfuse
