// The Jacobian checker (tests/kernel/jacobian_checker.h) for a residual on a model's blocks.
#pragma once

#include "cfuse/constraints/graph.h"
#include "kernel/jacobian_checker.h"

namespace cfuse::testing {

inline void CheckJacobian(const ConstraintGraph& graph, const ResidualFunction& f,
                          const std::vector<int>& blocks, const Values& at) {
  CheckJacobian(graph.blocks, f, blocks, at);
}

}  // namespace cfuse::testing
