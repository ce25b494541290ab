#include "constraints/evaluate.h"

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

}  // namespace cfuse
