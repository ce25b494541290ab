#include "cfuse/kernel/evaluate.h"

#include <algorithm>

#include "cfuse/kernel/check.h"
#include "cfuse/kernel/so3.h"

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

// base ⊞ shift (values.h's chart); shift may be null (zero).
BlockState<double> Shifted(const Block& b, const BlockState<double>& base, const double* shift) {
  if (shift == nullptr) return base;
  BlockState<double> s = base;
  switch (b.kind) {
    case BlockKind::kPoint:
      s.t += Eigen::Map<const Eigen::Vector3d>(shift);
      break;
    case BlockKind::kPose:
      s.R = base.R * ExpSO3<double>(Eigen::Map<const Eigen::Vector3d>(shift));
      s.t += Eigen::Map<const Eigen::Vector3d>(shift + 3);
      break;
    case BlockKind::kSlack:
      s.t.x() += shift[0];
      break;
  }
  return s;
}

// Sets `x` to `value` with the unit derivative vector `seed`, or zero derivatives for
// seed < 0. Written in place rather than built and copied.
void SetSeeded(double value, int seed, Jet* x) {
  x->value() = value;
  x->derivatives().setZero();
  if (seed >= 0) x->derivatives()[seed] = 1;
}

// The state (base ⊞ shift) ⊞ ε in Jets, where tangent coordinate i of the block carries the
// derivative index seed0 + i when that lies in [0, n). Only first derivatives are needed, so
// the rotation's are written directly: R Exp(shift + ε) = R' Exp(Jr(shift) ε) + O(ε²) with
// R' = R Exp(shift), hence d R / d ε_k = R' [Jr(shift) e_k]x. This avoids the exponential
// in Jets, the costliest part of differentiating a pose.
void Perturbed(const Block& b, const BlockState<double>& base, const double* shift, int seed0,
               int n, BlockState<Jet>* out) {
  const BlockState<double> s = Shifted(b, base, shift);
  auto seed = [&](int i) {
    const int k = seed0 + i;
    return k >= 0 && k < n ? k : -1;
  };
  switch (b.kind) {
    case BlockKind::kPoint:
    case BlockKind::kSlack: {
      // R is unused by point and slack blocks (residual.h), so it is not written: copying nine
      // Jets per block cost more than the residual itself.
      const int dim = TangentDim(b.kind);
      for (int i = 0; i < 3; ++i) SetSeeded(s.t[i], i < dim ? seed(i) : -1, &out->t[i]);
      break;
    }
    case BlockKind::kPose: {
      const Eigen::Matrix3d Jr = shift ? RightJacobianSO3(Eigen::Map<const Eigen::Vector3d>(shift))
                                       : Eigen::Matrix3d::Identity();
      for (int i = 0; i < 9; ++i) SetSeeded(s.R(i), -1, &out->R(i));
      for (int k = 0; k < 3; ++k) {
        const int d = seed(k);
        if (d < 0) continue;
        const Eigen::Matrix3d dR = s.R * Hat<double>(Jr.col(k));
        for (int i = 0; i < 9; ++i) out->R(i).derivatives()[d] = dR(i);
      }
      for (int i = 0; i < 3; ++i) SetSeeded(s.t[i], seed(3 + i), &out->t[i]);
      break;
    }
  }
}

}  // namespace

std::vector<BlockState<double>> GatherStates(const std::vector<Block>& graph_blocks,
                                             std::span<const int> blocks, const Values& values) {
  std::vector<BlockState<double>> states;
  states.reserve(blocks.size());
  for (int b : blocks) states.push_back(StateOf(graph_blocks.at(b), values));
  return states;
}

void EvaluateResidualAt(const ResidualFunction& f, const std::vector<Block>& graph_blocks,
                        std::span<const int> blocks, const Values& values,
                        const double* slot_offset, double* residual, double* jacobian) {
  CFUSE_CHECK_EQ(blocks.size(), f.slot_kinds().size());
  // Scratch reused across calls: the estimator evaluates thousands of small residuals, and
  // their allocations cost more than their arithmetic.
  thread_local std::vector<BlockState<double>> base;
  thread_local std::vector<BlockState<Jet>> states;
  thread_local std::vector<Jet> r;
  base.resize(blocks.size());
  for (size_t k = 0; k < blocks.size(); ++k) {
    const Block& b = graph_blocks.at(blocks[k]);
    CFUSE_CHECK_MSG(b.kind == f.slot_kinds()[k], "slot kind mismatch");
    base[k] = StateOf(b, values);
  }
  const int arity = f.arity();
  if (jacobian == nullptr) {
    if (slot_offset != nullptr) {
      int column = 0;
      for (size_t k = 0; k < blocks.size(); ++k) {
        const Block& b = graph_blocks[blocks[k]];
        base[k] = Shifted(b, base[k], slot_offset + column);
        column += TangentDim(b.kind);
      }
    }
    f.Evaluate(std::span<const BlockState<double>>(base), residual);
    return;
  }

  const int m = f.dimension();
  Eigen::Map<Eigen::MatrixXd> J(jacobian, m, arity);
  J.setZero();
  r.resize(m);
  states.resize(blocks.size());
  // Each pass differentiates with respect to the tangent coordinates [begin, end).
  for (int begin = 0; begin < arity; begin += kJetMaxDerivatives) {
    const int end = std::min(arity, begin + kJetMaxDerivatives);
    const int n = end - begin;
    int column = 0;
    for (size_t k = 0; k < blocks.size(); ++k) {
      const Block& b = graph_blocks[blocks[k]];
      Perturbed(b, base[k], slot_offset ? slot_offset + column : nullptr, column - begin, n,
                &states[k]);
      column += TangentDim(b.kind);
    }
    f.Evaluate(std::span<const BlockState<Jet>>(states), r.data());
    for (int i = 0; i < m; ++i) {
      if (begin == 0) residual[i] = r[i].value();
      const JetDerivatives& d = r[i].derivatives();
      J.block(i, begin, 1, n) = d.head(n).transpose();
    }
  }
}

void EvaluateResidual(const ResidualFunction& f, const std::vector<Block>& graph_blocks,
                      std::span<const int> blocks, const Values& values, Eigen::VectorXd* residual,
                      Eigen::MatrixXd* jacobian, const Eigen::VectorXd* offset) {
  Eigen::VectorXd slot_offset;
  if (offset != nullptr) {
    slot_offset.resize(f.arity());
    int column = 0;
    for (int id : blocks) {
      const Block& b = graph_blocks.at(id);
      const int dim = TangentDim(b.kind);
      CFUSE_CHECK(b.tangent_offset + dim <= offset->size());
      slot_offset.segment(column, dim) = offset->segment(b.tangent_offset, dim);
      column += dim;
    }
  }
  residual->resize(f.dimension());
  if (jacobian) jacobian->resize(f.dimension(), f.arity());
  EvaluateResidualAt(f, graph_blocks, blocks, values, offset ? slot_offset.data() : nullptr,
                     residual->data(), jacobian ? jacobian->data() : nullptr);
}

}  // namespace cfuse
