#include "constraints/evaluate.h"

#include <algorithm>

#include "kernel/check.h"

namespace cfuse {
namespace {

BlockState<double> StateOf(const Block& b, const Values& values) {
  BlockState<double> s;
  s.R.setIdentity();
  s.t.setZero();
  switch (b.kind) {
    case BlockKind::kPoint:
      s.t = values.points.at(b.index);
      break;
    case BlockKind::kPose:
      s.R = values.poses.at(b.index).RotationMatrix();
      s.t = values.poses.at(b.index).translation;
      break;
    case BlockKind::kSlack:
      s.t.x() = values.slacks.at(b.index);
      break;
  }
  return s;
}

// The state retracted by a perturbation whose coordinates [first, first + count) of this
// slot's tangent carry derivatives (index `derivative_offset` onwards), of `num_derivatives`.
BlockState<Jet> Perturbed(const Block& b, const BlockState<double>& base, int first, int count,
                          int derivative_offset, int num_derivatives) {
  const int dim = TangentDim(b.kind);
  Eigen::Matrix<Jet, 6, 1> delta;
  for (int i = 0; i < dim; ++i) {
    if (i >= first && i < first + count) {
      delta[i] = Jet(0.0, num_derivatives, derivative_offset + i - first);
    } else {
      delta[i] = Jet(0.0, JetDerivatives::Zero(num_derivatives));
    }
  }
  BlockState<Jet> s;
  s.R = base.R.cast<Jet>();
  s.t = base.t.cast<Jet>();
  switch (b.kind) {
    case BlockKind::kPoint:
      s.t += delta.head<3>();
      break;
    case BlockKind::kPose:
      s.R = s.R * ExpSO3<Jet>(delta.head<3>());
      s.t += delta.segment<3>(3);
      break;
    case BlockKind::kSlack:
      s.t.x() += delta[0];
      break;
  }
  return s;
}

}  // namespace

std::vector<BlockState<double>> GatherStates(const std::vector<Block>& graph_blocks,
                                             std::span<const int> blocks, const Values& values) {
  std::vector<BlockState<double>> states;
  states.reserve(blocks.size());
  for (int b : blocks) states.push_back(StateOf(graph_blocks.at(b), values));
  return states;
}

void EvaluateResidual(const ResidualFunction& f, const std::vector<Block>& graph_blocks,
                      std::span<const int> blocks, const Values& values, Eigen::VectorXd* residual,
                      Eigen::MatrixXd* jacobian) {
  CFUSE_CHECK(blocks.size() == f.slot_kinds().size());
  for (size_t k = 0; k < blocks.size(); ++k) {
    CFUSE_CHECK_MSG(graph_blocks.at(blocks[k]).kind == f.slot_kinds()[k], "slot kind mismatch");
  }
  const std::vector<BlockState<double>> base = GatherStates(graph_blocks, blocks, values);
  residual->resize(f.dimension());
  f.Evaluate(std::span<const BlockState<double>>(base), residual->data());
  if (jacobian == nullptr) return;

  const int arity = f.arity();
  jacobian->setZero(f.dimension(), arity);
  std::vector<Jet> r(f.dimension());
  std::vector<BlockState<Jet>> states(blocks.size());
  // Each pass differentiates with respect to the tangent coordinates [begin, end).
  for (int begin = 0; begin < arity; begin += kJetMaxDerivatives) {
    const int end = std::min(arity, begin + kJetMaxDerivatives);
    const int n = end - begin;
    int offset = 0;
    for (size_t k = 0; k < blocks.size(); ++k) {
      const Block& b = graph_blocks[blocks[k]];
      const int dim = TangentDim(b.kind);
      const int first = std::max(begin, offset) - offset;
      const int last = std::min(end, offset + dim) - offset;
      const int count = std::max(0, last - first);
      states[k] = Perturbed(b, base[k], first, count, offset + first - begin, n);
      offset += dim;
    }
    f.Evaluate(std::span<const BlockState<Jet>>(states), r.data());
    for (int i = 0; i < f.dimension(); ++i) {
      const JetDerivatives& d = r[i].derivatives();
      // A residual that does not depend on the state has an empty derivative vector.
      if (d.size() == n) jacobian->block(i, begin, 1, n) = d.transpose();
    }
  }
}

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
