// The largest residual of a model's equality constraints at some values: how far they are from
// holding (inequalities, which have a slack, are left out).
#pragma once

#include <algorithm>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/evaluate.h"

namespace cfuse::testing {

inline double LargestEquality(const ConstraintGraph& g, const Values& values) {
  double largest = 0;
  Eigen::VectorXd r;
  for (const Constraint& c : g.constraints) {
    EvaluateResidual(*c.residual, g.blocks, c.blocks, values, &r, nullptr);
    if (c.slack_block < 0) largest = std::max(largest, r.cwiseAbs().maxCoeff());
  }
  return largest;
}

}  // namespace cfuse::testing
