#include "cfuse/constraints/dof.h"

#include <Eigen/QR>
#include <algorithm>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/kernel/svd.h"

namespace cfuse {

namespace {

// The singular values (descending) above kRankTolerance * max(1, σ_max).
int RankOfSingularValues(const Eigen::VectorXd& s) {
  const double threshold = kRankTolerance * std::max(1.0, s.size() ? s[0] : 0.0);
  int rank = 0;
  for (int i = 0; i < s.size(); ++i) rank += s[i] > threshold ? 1 : 0;
  return rank;
}

}  // namespace

int NumericalRank(const Eigen::MatrixXd& A) {
  if (A.size() == 0) return 0;
  return RankOfSingularValues(ComputeSvd(A, SingularVectors::kNone).singular_values);
}

namespace {

// The constraints' Jacobian at `at`, an inequality's rows replaced by its slack's direction.
Eigen::MatrixXd SlackedJacobian(const ConstraintGraph& graph, const Values& at) {
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  EvaluateConstraints(graph, at, &r, &J);
  // An inequality's row counts as its slack's own direction: with the slack away from 0 that
  // is what it adds anyway, and at a boundary (slack 0, e.g. a gripper at its lower limit) its
  // row alone would pin the other variables as an equality does.
  int row = 0;
  for (const Constraint& c : graph.constraints) {
    if (c.slack_block >= 0) {
      for (int i = 0; i < c.residual->dimension(); ++i) {
        J.row(row + i).setZero();
        J(row + i, graph.blocks[c.slack_block].tangent_offset) = 1;
      }
    }
    row += c.residual->dimension();
  }
  return J;
}

// Gram-Schmidt over J's rows in constraint order (re-orthogonalised): each constraint's rows
// that add a new direction.
std::vector<std::vector<int>> RowsAddingRank(const ConstraintGraph& graph,
                                             const Eigen::MatrixXd& J) {
  std::vector<std::vector<int>> out;
  std::vector<Eigen::VectorXd> basis;
  int row = 0;
  for (const Constraint& c : graph.constraints) {
    out.emplace_back();
    for (int i = 0; i < c.residual->dimension(); ++i, ++row) {
      Eigen::VectorXd v = J.row(row).transpose();
      const double norm0 = v.norm();
      if (norm0 == 0) continue;
      for (int pass = 0; pass < 2; ++pass)
        for (const Eigen::VectorXd& q : basis) v -= q.dot(v) * q;
      if (v.norm() > kRankTolerance * norm0) {
        basis.push_back(v.normalized());
        out.back().push_back(i);
      }
    }
  }
  return out;
}

}  // namespace

Eigen::MatrixXd FreeDirections(const ConstraintGraph& graph, const Values& at,
                               const std::vector<bool>* use) {
  const int n = graph.tangent_dim();
  if (n > kMaxDofStateDim) return Eigen::MatrixXd(n, 0);
  Eigen::MatrixXd J = SlackedJacobian(graph, at);
  if (use) {
    int row = 0;
    for (size_t k = 0; k < graph.constraints.size(); ++k) {
      const int dim = graph.constraints[k].residual->dimension();
      if (!(*use)[k]) J.middleRows(row, dim).setZero();
      row += dim;
    }
  }
  if (J.rows() == 0) return Eigen::MatrixXd::Identity(n, n);
  const SingularValueDecomposition svd = ComputeSvd(J, SingularVectors::kFullV);
  return svd.V.rightCols(n - RankOfSingularValues(svd.singular_values));
}

std::vector<std::vector<int>> IndependentRows(const ConstraintGraph& graph, const Values& at) {
  if (graph.tangent_dim() > kMaxDofStateDim) return {};
  return RowsAddingRank(graph, SlackedJacobian(graph, at));
}

std::vector<int> ImplyingConstraints(const ConstraintGraph& graph, const Values& at,
                                     int constraint) {
  if (graph.tangent_dim() > kMaxDofStateDim) return {};
  const Eigen::MatrixXd J = SlackedJacobian(graph, at);
  const std::vector<std::vector<int>> kept = RowsAddingRank(graph, J);
  std::vector<int> first_row(graph.constraints.size() + 1, 0);
  for (size_t k = 0; k < graph.constraints.size(); ++k) {
    first_row[k + 1] = first_row[k] + graph.constraints[k].residual->dimension();
  }
  const int before = first_row[constraint];
  if (before == 0) return {};
  // Each repeated row as a combination of the rows before it (least squares, minimum norm).
  const Eigen::MatrixXd A = J.topRows(before).transpose();
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(A);
  std::vector<double> weight(graph.constraints.size(), 0.0);
  const std::vector<int>& adding = kept[constraint];
  for (int i = 0; i < graph.constraints[constraint].residual->dimension(); ++i) {
    if (std::find(adding.begin(), adding.end(), i) != adding.end()) continue;
    const Eigen::VectorXd row = J.row(first_row[constraint] + i).transpose();
    const Eigen::VectorXd x = cod.solve(row);
    for (int k = 0; k < constraint; ++k) {
      for (int r = first_row[k]; r < first_row[k + 1]; ++r) {
        weight[k] = std::max(weight[k], std::abs(x[r]) * J.row(r).norm() / row.norm());
      }
    }
  }
  std::vector<int> out;
  for (int k = 0; k < constraint; ++k) {
    if (weight[k] > 1e-6) out.push_back(k);
  }
  return out;
}

DofReport AnalyzeDof(const ConstraintGraph& graph, const Values& at) {
  DofReport report;
  report.state_dim = graph.tangent_dim();
  report.equations = graph.num_equations();
  if (report.state_dim > kMaxDofStateDim) return report;
  report.computed = true;
  const Eigen::MatrixXd J = SlackedJacobian(graph, at);
  const std::vector<std::vector<int>> kept = RowsAddingRank(graph, J);
  for (size_t i = 0; i < graph.constraints.size(); ++i) {
    const Constraint& c = graph.constraints[i];
    const int dim = c.residual->dimension();
    const int added = static_cast<int>(kept[i].size());
    report.rank += added;
    if (added < dim) report.redundant.emplace_back(c.name, dim - added);
  }
  report.dof = report.state_dim - report.rank;

  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(report.state_dim, 6);  // columns: ω, v
  for (const Block& b : graph.blocks) {
    const int o = b.tangent_offset;
    if (b.kind == BlockKind::kPoint) {
      const Eigen::Vector3d& p = at.points[b.index];
      G.block<3, 3>(o, 0) = -Hat<double>(p);
      G.block<3, 3>(o, 3).setIdentity();
    } else if (b.kind == BlockKind::kPose) {
      const Rigid3d& pose = at.poses[b.index];
      G.block<3, 3>(o, 0) = pose.RotationMatrix().transpose();
      G.block<3, 3>(o + 3, 0) = -Hat<double>(pose.translation);
      G.block<3, 3>(o + 3, 3).setIdentity();
    }
  }
  report.rigid_body = NumericalRank(G) - NumericalRank(J * G);
  report.internal = report.dof - report.rigid_body;
  return report;
}

}  // namespace cfuse
