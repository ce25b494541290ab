#include "kernel/estimator.h"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "kernel/check.h"
#include "kernel/evaluate.h"
#include "kernel/so3.h"

namespace cfuse {

const char* StatusName(FusionSummary::Status status) {
  switch (status) {
    case FusionSummary::Status::kFused:
      return "fused";
    case FusionSummary::Status::kPartlyRedundant:
      return "partly redundant";
    case FusionSummary::Status::kRedundant:
      return "redundant";
    case FusionSummary::Status::kContradiction:
      return "contradiction";
    case FusionSummary::Status::kNotConverged:
      return "not converged";
    case FusionSummary::Status::kInvalid:
      return "invalid";
  }
  return "?";
}

GaussianState MakePrior(const std::vector<Block>& blocks, const Values& mean,
                        const PriorScale& scale) {
  GaussianState state;
  state.blocks = blocks;
  state.mean = mean;
  int n = 0;
  for (const Block& b : blocks) n = std::max(n, b.tangent_offset + TangentDim(b.kind));
  state.prior_variance.resize(n);
  for (const Block& b : blocks) {
    const int o = b.tangent_offset;
    switch (b.kind) {
      case BlockKind::kPoint:
        state.prior_variance.segment<3>(o).setConstant(scale.position * scale.position);
        break;
      case BlockKind::kPose:
        state.prior_variance.segment<3>(o).setConstant(scale.rotation * scale.rotation);
        state.prior_variance.segment<3>(o + 3).setConstant(scale.position * scale.position);
        break;
      case BlockKind::kSlack:
        state.prior_variance[o] = scale.slack * scale.slack;
        break;
    }
  }
  state.covariance = state.prior_variance.asDiagonal();
  return state;
}

FusionSummary Fuse(const Factor& factor, GaussianState* state, const FusionOptions& options,
                   const Values* linearize_at) {
  const ResidualFunction& f = *factor.residual;
  const int m = f.dimension(), n = state->dim();
  FusionSummary summary;
  summary.rows = m;
  CFUSE_CHECK(factor.is_constraint() || (factor.noise.rows() == m && factor.noise.cols() == m));

  // The tangent coordinates the factor touches, in slot order (the Jacobian's columns).
  std::vector<int> index;
  for (int b : factor.blocks) {
    const Block& block = state->blocks.at(b);
    for (int i = 0; i < TangentDim(block.kind); ++i) index.push_back(block.tangent_offset + i);
  }
  const int a = static_cast<int>(index.size());
  const Eigen::MatrixXd& P0 = state->covariance;
  Eigen::MatrixXd P0_na(n, a), P0_aa(a, a);  // P0 restricted to the touched columns
  for (int j = 0; j < a; ++j) P0_na.col(j) = P0.col(index[j]);
  for (int i = 0; i < a; ++i) P0_aa.row(i) = P0_na.row(index[i]);
  const Eigen::MatrixXd R = factor.is_constraint() ? Eigen::MatrixXd::Zero(m, m) : factor.noise;

  Eigen::VectorXd delta = linearize_at ? LocalCoordinates(state->blocks, state->mean, *linearize_at)
                                       : Eigen::VectorXd::Zero(n);
  Eigen::VectorXd r;
  Eigen::MatrixXd H, K;  // m x a, n x k
  Eigen::MatrixXd U;     // m x k: the fused directions of the residual
  Eigen::MatrixXd HtU;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    EvaluateResidual(f, state->blocks, factor.blocks, state->mean, &r, &H, &delta);
    if (!r.allFinite() || !H.allFinite()) {
      summary.status = FusionSummary::Status::kInvalid;
      return summary;
    }
    const Eigen::MatrixXd S = H * P0_aa * H.transpose() + R;
    Eigen::MatrixXd S_init = H * state->prior_variance(index).asDiagonal() * H.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(0.5 * (S + S.transpose()));
    const Eigen::VectorXd innovation = H * delta(index) - r;
    std::vector<int> keep;
    double contradiction = 0;
    for (int i = 0; i < m; ++i) {
      const Eigen::VectorXd u = eigen.eigenvectors().col(i);
      const double initial = u.dot(S_init * u) + u.dot(R * u);
      const double variance = eigen.eigenvalues()[i];
      if (initial <= 0 || variance <= options.degeneracy_tolerance * initial) {
        // Already determined: the linearised factor is consistent only if its innovation has
        // no component along u (the state cannot move along Hᵀu).
        if (iteration == 0 && initial > 0) {
          contradiction = std::max(contradiction, std::abs(u.dot(innovation)) / std::sqrt(initial));
        }
        continue;
      }
      keep.push_back(i);
    }
    if (iteration == 0) {
      summary.contradiction = contradiction;
      if (contradiction > options.contradiction_tolerance) {
        summary.status = FusionSummary::Status::kContradiction;
        return summary;
      }
      if (keep.empty()) {
        summary.status = FusionSummary::Status::kRedundant;
        return summary;
      }
      summary.rows_fused = static_cast<int>(keep.size());
    }
    const int k = static_cast<int>(keep.size());
    U.resize(m, k);
    Eigen::VectorXd lambda(k);
    for (int j = 0; j < k; ++j) {
      U.col(j) = eigen.eigenvectors().col(keep[j]);
      lambda[j] = eigen.eigenvalues()[keep[j]];
    }
    HtU = H.transpose() * U;  // a x k
    K = P0_na * HtU * lambda.cwiseInverse().asDiagonal();
    if (iteration == 0) {
      const Eigen::VectorXd projected = U.transpose() * innovation;
      summary.innovation_nis = projected.dot(lambda.cwiseInverse().asDiagonal() * projected);
    }
    const Eigen::VectorXd next = K * (U.transpose() * innovation);
    const double step = (next - delta).lpNorm<Eigen::Infinity>();
    delta = next;
    summary.iterations = iteration + 1;
    if (step <= options.step_tolerance * (1 + delta.lpNorm<Eigen::Infinity>())) break;
    if (iteration + 1 == options.max_iterations && options.max_iterations > 1) {
      summary.status = FusionSummary::Status::kNotConverged;
    }
  }

  // K is the optimal gain for the final linearisation (K = P0 Huᵀ Su⁻¹ with Su = U Λ Uᵀ's kept
  // part, Hu = Uᵀ H embedded in the touched columns), for which the Joseph form
  // P0 - K Hu P0 - P0 Huᵀ Kᵀ + K Su Kᵀ equals P0 - K Hu P0: one product instead of three.
  // Symmetrising afterwards keeps it symmetric; the tests check it stays PSD.
  const Eigen::MatrixXd HuP0 = HtU.transpose() * P0_na.transpose();  // k x n
  Eigen::MatrixXd P1 = P0;
  P1.noalias() -= K * HuP0;

  // Move the mean and the covariance to the chart at x0 ⊞ δ*.
  Retract(state->blocks, delta, &state->mean);
  for (const Block& b : state->blocks) {
    if (b.kind != BlockKind::kPose) continue;
    const Eigen::Matrix3d G = RightJacobianSO3(delta.segment<3>(b.tangent_offset));
    const int o = b.tangent_offset;
    P1.middleRows(o, 3) = (G * P1.middleRows(o, 3)).eval();
    P1.middleCols(o, 3) = (P1.middleCols(o, 3) * G.transpose()).eval();
  }
  state->covariance = 0.5 * (P1 + P1.transpose());
  if (summary.status == FusionSummary::Status::kFused && summary.rows_fused < m) {
    summary.status = FusionSummary::Status::kPartlyRedundant;
  }
  return summary;
}

double MaxConstraintResidual(const std::vector<Factor>& factors, const std::vector<Block>& blocks,
                             const Values& values) {
  double worst = 0;
  Eigen::VectorXd r;
  for (const Factor& f : factors) {
    if (!f.is_constraint()) continue;
    EvaluateResidual(*f.residual, blocks, f.blocks, values, &r, nullptr);
    worst = std::max(worst, r.lpNorm<Eigen::Infinity>());
  }
  return worst;
}

SequenceSummary FuseSequence(const std::vector<Factor>& factors, GaussianState* state,
                             const SequenceOptions& options) {
  const GaussianState prior = *state;
  SequenceSummary summary;
  Values previous;
  for (int pass = 0; pass < options.max_passes; ++pass) {
    if (pass > 0) {
      previous = state->mean;
      *state = prior;
    }
    // Later passes linearise every factor once, about the previous estimate: the sequence of
    // linear updates is then one Gauss-Newton step of the whole problem.
    FusionOptions fusion = options.fusion;
    if (pass > 0) fusion.max_iterations = 1;
    summary.fusions.clear();
    for (const Factor& f : factors) {
      summary.fusions.push_back(Fuse(f, state, fusion, pass > 0 ? &previous : nullptr));
    }
    summary.passes = pass + 1;
    summary.max_constraint_residual = MaxConstraintResidual(factors, state->blocks, state->mean);
    if (summary.max_constraint_residual <= options.constraint_tolerance) {
      summary.converged = true;
      break;
    }
  }
  return summary;
}

}  // namespace cfuse
