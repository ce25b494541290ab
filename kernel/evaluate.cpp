#include "kernel/evaluate.h"

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

// base ⊞ delta in scalar T (values.h's chart).
template <typename T>
BlockState<T> Retracted(const Block& b, const BlockState<double>& base,
                        const Eigen::Matrix<T, 6, 1>& delta) {
  BlockState<T> s;
  s.R = base.R.cast<T>();
  s.t = base.t.cast<T>();
  switch (b.kind) {
    case BlockKind::kPoint:
      s.t += delta.template head<3>();
      break;
    case BlockKind::kPose:
      s.R = s.R * ExpSO3<T>(delta.template head<3>());
      s.t += delta.template segment<3>(3);
      break;
    case BlockKind::kSlack:
      s.t.x() += delta[0];
      break;
  }
  return s;
}

// The state base ⊞ (shift + ε), where the coordinates [first, first + count) of ε carry
// derivatives (index `derivative_offset` onwards, of `num_derivatives`).
BlockState<Jet> Perturbed(const Block& b, const BlockState<double>& base, const double* shift,
                          int first, int count, int derivative_offset, int num_derivatives) {
  const int dim = TangentDim(b.kind);
  Eigen::Matrix<Jet, 6, 1> delta;
  for (int i = 0; i < dim; ++i) {
    const double value = shift ? shift[i] : 0.0;
    if (i >= first && i < first + count) {
      delta[i] = Jet(value, num_derivatives, derivative_offset + i - first);
    } else {
      delta[i] = Jet(value, JetDerivatives::Zero(num_derivatives));
    }
  }
  return Retracted<Jet>(b, base, delta);
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
                      Eigen::MatrixXd* jacobian, const Eigen::VectorXd* offset) {
  CFUSE_CHECK(blocks.size() == f.slot_kinds().size());
  for (size_t k = 0; k < blocks.size(); ++k) {
    CFUSE_CHECK_MSG(graph_blocks.at(blocks[k]).kind == f.slot_kinds()[k], "slot kind mismatch");
  }
  const std::vector<BlockState<double>> base = GatherStates(graph_blocks, blocks, values);
  auto shift_of = [&](const Block& b) -> const double* {
    return offset ? offset->data() + b.tangent_offset : nullptr;
  };
  residual->resize(f.dimension());
  if (offset == nullptr) {
    f.Evaluate(std::span<const BlockState<double>>(base), residual->data());
  } else {
    std::vector<BlockState<double>> shifted(blocks.size());
    for (size_t k = 0; k < blocks.size(); ++k) {
      const Block& b = graph_blocks[blocks[k]];
      CFUSE_CHECK(b.tangent_offset + TangentDim(b.kind) <= offset->size());
      Eigen::Matrix<double, 6, 1> delta = Eigen::Matrix<double, 6, 1>::Zero();
      delta.head(TangentDim(b.kind)) = offset->segment(b.tangent_offset, TangentDim(b.kind));
      shifted[k] = Retracted<double>(b, base[k], delta);
    }
    f.Evaluate(std::span<const BlockState<double>>(shifted), residual->data());
  }
  if (jacobian == nullptr) return;

  const int arity = f.arity();
  jacobian->setZero(f.dimension(), arity);
  std::vector<Jet> r(f.dimension());
  std::vector<BlockState<Jet>> states(blocks.size());
  // Each pass differentiates with respect to the tangent coordinates [begin, end).
  for (int begin = 0; begin < arity; begin += kJetMaxDerivatives) {
    const int end = std::min(arity, begin + kJetMaxDerivatives);
    const int n = end - begin;
    int column = 0;
    for (size_t k = 0; k < blocks.size(); ++k) {
      const Block& b = graph_blocks[blocks[k]];
      const int dim = TangentDim(b.kind);
      const int first = std::max(begin, column) - column;
      const int last = std::min(end, column + dim) - column;
      const int count = std::max(0, last - first);
      states[k] = Perturbed(b, base[k], shift_of(b), first, count, column + first - begin, n);
      column += dim;
    }
    f.Evaluate(std::span<const BlockState<Jet>>(states), r.data());
    for (int i = 0; i < f.dimension(); ++i) {
      const JetDerivatives& d = r[i].derivatives();
      // A residual that does not depend on the state has an empty derivative vector.
      if (d.size() == n) jacobian->block(i, begin, 1, n) = d.transpose();
    }
  }
}

}  // namespace cfuse
