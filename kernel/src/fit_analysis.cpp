#include "cfuse/kernel/fit_analysis.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/svd.h"

namespace cfuse {
namespace {

// A direction is determined when its eigenvalue in the measurements' information, restricted
// to the constraints' null space, is above this share of the largest: a singular value ratio of
// 1e-6, far above roundoff (1e-16 of the largest eigenvalue) and far below any real
// measurement's weight next to another's.
constexpr double kInformationTolerance = 1e-12;
// A constraint row (normalised) counts when its singular value is above this.
constexpr double kConstraintTolerance = 1e-9;

}  // namespace

FitAnalysis AnalyseFit(const std::vector<Factor>& factors, const std::vector<Block>& blocks,
                       const Values& values, double extent, bool ranks) {
  FitAnalysis out;
  int n = 0;
  for (const Block& b : blocks) n = std::max(n, b.tangent_offset + TangentDim(b.kind));
  out.state_dim = n;
  // Column scale: a position perturbation in units of the extent, a rotation in radians.
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(n);
  for (const Block& b : blocks) {
    if (b.kind == BlockKind::kPose) scale.segment<3>(b.tangent_offset + 3).setConstant(extent);
    if (b.kind == BlockKind::kPoint) scale.segment<3>(b.tangent_offset).setConstant(extent);
  }
  const bool analyse = ranks && n <= kMaxAnalysedDim;
  out.analysed = analyse;
  Eigen::MatrixXd information = analyse ? Eigen::MatrixXd::Zero(n, n) : Eigen::MatrixXd();
  std::vector<Eigen::RowVectorXd> constraint_rows;
  int constraint_count = 0;
  Eigen::VectorXd r;
  Eigen::MatrixXd jacobian;
  for (const Factor& f : factors) {
    EvaluateResidual(*f.residual, blocks, f.blocks, values, &r, analyse ? &jacobian : nullptr);
    if (!r.allFinite() || (analyse && !jacobian.allFinite())) continue;
    Eigen::MatrixXd full;
    if (analyse) {  // the Jacobian over the whole state, scaled
      full = Eigen::MatrixXd::Zero(r.size(), n);
      int column = 0;
      for (int block : f.blocks) {
        const Block& b = blocks[block];
        const int dim = TangentDim(b.kind);
        full.middleCols(b.tangent_offset, dim) +=
            jacobian.middleCols(column, dim) *
            scale.segment(b.tangent_offset, dim).asDiagonal();
        column += dim;
      }
    }
    if (f.is_constraint()) {
      constraint_count += static_cast<int>(r.size());
      for (int i = 0; analyse && i < full.rows(); ++i) {
        const double norm = full.row(i).norm();
        if (norm > 0) constraint_rows.push_back(full.row(i) / norm);
      }
      continue;
    }
    const Eigen::LLT<Eigen::MatrixXd> llt(f.noise);
    if (llt.info() != Eigen::Success) continue;
    out.fit.chi2 += llt.matrixL().solve(r).squaredNorm();
    out.fit.residuals += static_cast<int>(r.size());
    if (analyse) {
      const Eigen::MatrixXd whitened = llt.matrixL().solve(full);
      information.noalias() += whitened.transpose() * whitened;
    }
  }
  if (!analyse) {
    out.model_dof = std::max(0, n - constraint_count);
    out.determined = std::min(out.model_dof, out.fit.residuals);
  } else {
    // The constraints' null space: the model's degrees of freedom at this estimate.
    Eigen::MatrixXd null_space = Eigen::MatrixXd::Identity(n, n);
    if (!constraint_rows.empty()) {
      Eigen::MatrixXd c(static_cast<int>(constraint_rows.size()), n);
      for (size_t i = 0; i < constraint_rows.size(); ++i) c.row(static_cast<int>(i)) = constraint_rows[i];
      const SingularValueDecomposition svd = ComputeSvd(c, SingularVectors::kFullV);
      const Eigen::VectorXd& s = svd.singular_values;
      int rank = 0;
      for (int i = 0; i < s.size(); ++i) rank += s[i] > kConstraintTolerance * s[0];
      null_space = svd.V.rightCols(n - rank);
    }
    out.model_dof = static_cast<int>(null_space.cols());
    if (out.model_dof > 0) {
      const Eigen::MatrixXd reduced = null_space.transpose() * information * null_space;
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(reduced);
      const Eigen::VectorXd& lambda = eigen.eigenvalues();  // ascending
      const double largest = lambda[lambda.size() - 1];
      int free = 0;
      while (free < lambda.size() && !(lambda[free] > kInformationTolerance * largest)) ++free;
      out.determined = out.model_dof - free;
      if (free > 0) {
        out.free_directions = scale.asDiagonal() * null_space * eigen.eigenvectors().leftCols(free);
        out.free_directions.colwise().normalize();
      }
    }
  }
  out.fit.dof = std::max(0, out.fit.residuals - out.determined);
  out.fit.p_value = out.fit.dof > 0 ? 1 - ChiSquareCdf(out.fit.chi2, out.fit.dof) : 1.0;
  return out;
}

bool MovesAlong(const Eigen::RowVectorXd& gradient, const Eigen::MatrixXd& basis,
                double tolerance) {
  if (basis.cols() == 0) return false;
  const double norm = gradient.norm();
  if (!(norm > 0)) return false;
  return ((gradient * basis).cwiseAbs().maxCoeff()) > tolerance * norm;
}

}  // namespace cfuse
