#include "cfuse/constraints/evaluate.h"

#include <cmath>

namespace cfuse {

void EvaluateConstraints(const ConstraintGraph& graph, const Values& values, Eigen::VectorXd* r,
                         Eigen::MatrixXd* J) {
  const int m = graph.num_equations(), n = graph.tangent_dim();
  r->setZero(m);
  if (J) J->setZero(m, n);
  int row = 0;
  Eigen::VectorXd ri;
  Eigen::MatrixXd Ji;
  for (const Constraint& c : graph.constraints) {
    EvaluateResidual(*c.residual, graph.blocks, c.blocks, values, &ri, J ? &Ji : nullptr);
    r->segment(row, ri.size()) = ri;
    if (J) {
      int col = 0;
      for (int b : c.blocks) {
        const Block& block = graph.blocks[b];
        const int dim = TangentDim(block.kind);
        J->block(row, block.tangent_offset, ri.size(), dim) += Ji.block(0, col, ri.size(), dim);
        col += dim;
      }
    }
    row += ri.size();
  }
}

void MatchSlacks(const ConstraintGraph& graph, Values* values) {
  double residual = 0;
  for (const Constraint& c : graph.constraints) {
    if (c.slack_block < 0 || c.residual->dimension() != 1) continue;
    double& slack = values->slacks[graph.blocks[c.slack_block].index];
    const double sign = slack < 0 ? -1 : 1;
    slack = 0;
    EvaluateResidualAt(*c.residual, graph.blocks, c.blocks, *values, nullptr, &residual, nullptr);
    slack = std::isfinite(residual) ? sign * std::sqrt(std::max(residual, 0.0)) : 0;
  }
}

}  // namespace cfuse
