#include "constraints/dof.h"

#include <Eigen/SVD>

#include "constraints/evaluate.h"

namespace cfuse {

int NumericalRank(const Eigen::MatrixXd& A) {
  if (A.size() == 0) return 0;
  Eigen::BDCSVD<Eigen::MatrixXd> svd(A);
  const Eigen::VectorXd& s = svd.singularValues();
  const double threshold = kRankTolerance * std::max(1.0, s.size() ? s[0] : 0.0);
  int rank = 0;
  for (int i = 0; i < s.size(); ++i) rank += s[i] > threshold ? 1 : 0;
  return rank;
}

DofReport AnalyzeDof(const ConstraintGraph& graph, const Values& at) {
  DofReport report;
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  EvaluateConstraints(graph, at, &r, &J);
  report.state_dim = static_cast<int>(J.cols());
  report.equations = static_cast<int>(J.rows());
  report.rank = NumericalRank(J);
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

  // Redundancy: the rank added by each constraint's rows, in order.
  int row = 0, rank_so_far = 0;
  for (const Constraint& c : graph.constraints) {
    const int dim = c.residual->dimension();
    const int rank = NumericalRank(J.topRows(row + dim));
    if (rank - rank_so_far < dim) report.redundant.emplace_back(c.name, dim - (rank - rank_so_far));
    rank_so_far = rank;
    row += dim;
  }
  return report;
}

}  // namespace cfuse
