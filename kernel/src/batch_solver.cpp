#include "cfuse/kernel/batch_solver.h"

#include <Eigen/Cholesky>

#include "cfuse/kernel/check.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/so3.h"
#include "cfuse/kernel/svd.h"

namespace cfuse {
namespace {

// Scatters a factor's Jacobian columns (slot order) into state columns.
void Scatter(const std::vector<Block>& blocks, const Factor& f, const Eigen::MatrixXd& local,
             Eigen::Ref<Eigen::MatrixXd> out) {
  int col = 0;
  for (int b : f.blocks) {
    const Block& block = blocks[b];
    const int dim = TangentDim(block.kind);
    out.middleCols(block.tangent_offset, dim) += local.middleCols(col, dim);
    col += dim;
  }
}

}  // namespace

BatchSummary SolveBatch(const std::vector<Factor>& factors, GaussianState* state,
                        const BatchOptions& options, const Values* initial) {
  const int n = state->dim();
  int m_meas = 0, m_cons = 0;
  for (const Factor& f : factors) {
    (f.is_constraint() ? m_cons : m_meas) += f.residual->dimension();
  }
  const Eigen::MatrixXd prior_information = state->covariance.inverse();
  Eigen::VectorXd delta =
      initial ? LocalCoordinates(state->blocks, state->mean, *initial) : Eigen::VectorXd::Zero(n);
  Eigen::MatrixXd J(m_meas, n), A(m_cons, n), W = Eigen::MatrixXd::Zero(m_meas, m_meas);
  Eigen::VectorXd r(m_meas), c(m_cons);
  Eigen::MatrixXd Z;
  Eigen::MatrixXd Lambda;
  BatchSummary summary;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    J.setZero();
    A.setZero();
    int row_m = 0, row_c = 0;
    Eigen::VectorXd ri;
    Eigen::MatrixXd Ji;
    for (const Factor& f : factors) {
      EvaluateResidual(*f.residual, state->blocks, f.blocks, state->mean, &ri, &Ji, &delta);
      const int d = static_cast<int>(ri.size());
      if (f.is_constraint()) {
        c.segment(row_c, d) = ri;
        Scatter(state->blocks, f, Ji, A.middleRows(row_c, d));
        row_c += d;
      } else {
        r.segment(row_m, d) = ri;
        Scatter(state->blocks, f, Ji, J.middleRows(row_m, d));
        W.block(row_m, row_m, d, d) = f.noise.inverse();
        row_m += d;
      }
    }
    Lambda = prior_information + J.transpose() * W * J;
    const Eigen::VectorXd g = J.transpose() * W * (J * delta - r);
    Eigen::VectorXd next;
    if (m_cons == 0) {
      Z = Eigen::MatrixXd::Identity(n, n);
      next = Lambda.ldlt().solve(g);
    } else {
      const SingularValueDecomposition svd = ComputeSvd(A, SingularVectors::kThinUFullV);
      const Eigen::VectorXd& s = svd.singular_values;
      int rank = 0;
      while (rank < s.size() && s[rank] > options.rank_tolerance * std::max(1.0, s[0])) ++rank;
      const Eigen::VectorXd b = A * delta - c;
      // The minimum-norm solution of A δ = b, then the optimum along null(A).
      const Eigen::VectorXd particular =
          svd.V.leftCols(rank) * (svd.U.leftCols(rank).transpose() * b).cwiseQuotient(s.head(rank));
      Z = svd.V.rightCols(n - rank);
      const Eigen::MatrixXd reduced = Z.transpose() * Lambda * Z;
      next = particular + Z * reduced.ldlt().solve(Z.transpose() * (g - Lambda * particular));
    }
    const double step = (next - delta).lpNorm<Eigen::Infinity>();
    delta = next;
    summary.iterations = iteration + 1;
    if (step <= options.step_tolerance * (1 + delta.lpNorm<Eigen::Infinity>())) {
      summary.converged = true;
      break;
    }
  }
  // The covariance on the constraint surface, in the prior's chart, then at the solution.
  Eigen::MatrixXd P = Z * (Z.transpose() * Lambda * Z).inverse() * Z.transpose();
  Retract(state->blocks, delta, &state->mean);
  for (const Block& b : state->blocks) {
    if (b.kind != BlockKind::kPose) continue;
    const Eigen::Matrix3d G = RightJacobianSO3(delta.segment<3>(b.tangent_offset));
    P.middleRows(b.tangent_offset, 3) = (G * P.middleRows(b.tangent_offset, 3)).eval();
    P.middleCols(b.tangent_offset, 3) = (P.middleCols(b.tangent_offset, 3) * G.transpose()).eval();
  }
  state->covariance = 0.5 * (P + P.transpose());
  state->groups.MergeAll();
  for (const Factor& f : factors) {
    if (!f.is_constraint()) continue;
    Eigen::VectorXd ri;
    EvaluateResidual(*f.residual, state->blocks, f.blocks, state->mean, &ri, nullptr);
    summary.max_constraint_residual =
        std::max(summary.max_constraint_residual, ri.lpNorm<Eigen::Infinity>());
  }
  return summary;
}

}  // namespace cfuse
