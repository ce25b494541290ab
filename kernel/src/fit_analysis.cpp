#include "cfuse/kernel/fit_analysis.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SPQRSupport>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>

#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/svd.h"
#include "cfuse/kernel/triangular.h"

namespace cfuse {
namespace {

// A direction is determined when its eigenvalue in the measurements' information, restricted
// to the constraints' null space, is above this share of the largest: a singular value ratio of
// 1e-6, far above roundoff (1e-16 of the largest eigenvalue) and far below any real
// measurement's weight next to another's.
constexpr double kInformationTolerance = 1e-12;
constexpr double kSingularTolerance = 1e-6;  // its square root, for ranks of the stacked rows
// A constraint row (normalised) counts when its singular value is above this.
constexpr double kConstraintTolerance = 1e-9;

// Below this state dimension the dense decompositions are as fast as setting up the sparse
// ones (a hinged box: 13).
constexpr int kDenseBelowDim = 40;

using SparseMatrix = Eigen::SparseMatrix<double>;
using Triplets = std::vector<Eigen::Triplet<double>>;

// The numerical rank of `a` by sparse QR in a fill-reducing column order: a column whose part
// outside the span of the columns before it is below `tolerance` times the largest column norm
// counts as dependent (Heath's rule, as in SuiteSparseQR). Exact dependencies, the ones a model
// has (a joint no measurement reaches), leave a part at roundoff; the cost follows the
// sparsity, so a tree of joints costs about linear time where a dense SVD costs cubic.
// Heath's rule can miss a near dependency (all parts above the tolerance while the smallest
// singular value is below it) but not an exact one; and a column it wrongly calls dependent
// only sends the analysis to the dense decompositions, which decide. (The pivots of a shifted
// Cholesky factor of the Gram matrix, tried first, missed exact ones: a dependent column's
// pivot is the shift times 1 + |its coefficients|², and a slack near its boundary has large
// ones.)
int SparseRank(SparseMatrix a, double tolerance) {
  if (a.rows() < a.cols()) a = SparseMatrix(a.transpose());
  a.makeCompressed();
  double largest = 0;
  for (int k = 0; k < a.outerSize(); ++k) largest = std::max(largest, a.col(k).norm());
  if (!(largest > 0)) return 0;
  Eigen::SPQR<SparseMatrix> qr;
  qr.setPivotThreshold(tolerance * largest);
  qr.compute(a);
  return static_cast<int>(qr.rank());
}

// The dense analysis, for a state with free directions to name.
void NameFreeDirections(const SparseMatrix& constraints, const SparseMatrix& measurements,
                        const Eigen::VectorXd& scale, FitAnalysis* out) {
  const Eigen::MatrixXd free = FreeDirections(
      Eigen::MatrixXd(constraints), Eigen::MatrixXd(measurements.transpose() * measurements),
      &out->model_dof, &out->determined);
  if (free.cols() > 0) {
    out->free_directions = scale.asDiagonal() * free;
    out->free_directions.colwise().normalize();
  }
}

// Where every measurement reaches one block, M is block-diagonal, and so is a basis F of its
// null space (each block's eigenvectors of negligible information): the directions left free
// are F y with C F y = 0, as many as the null space of C F, a matrix with a column per
// direction some block leaves free (few, usually: a part without markers, the slacks).
int FreeUnderConstraints(const std::vector<Block>& blocks,
                         const std::vector<Eigen::MatrixXd>& block_information,
                         const SparseMatrix& constraints) {
  const int n = static_cast<int>(constraints.cols());
  double largest = 0;
  std::vector<Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>> eigen(blocks.size());
  for (size_t b = 0; b < blocks.size(); ++b) {
    if (block_information[b].size() == 0) continue;
    eigen[b].compute(block_information[b]);
    largest = std::max(largest, eigen[b].eigenvalues().maxCoeff());
  }
  Triplets free_entries;
  int free = 0;
  for (size_t b = 0; b < blocks.size(); ++b) {
    const int o = blocks[b].tangent_offset, dim = TangentDim(blocks[b].kind);
    for (int i = 0; i < dim; ++i) {
      if (block_information[b].size() == 0) {
        free_entries.emplace_back(o + i, free++, 1.0);
      } else if (!(eigen[b].eigenvalues()[i] > kInformationTolerance * largest)) {
        for (int k = 0; k < dim; ++k) {
          free_entries.emplace_back(o + k, free, eigen[b].eigenvectors()(k, i));
        }
        ++free;
      }
    }
  }
  if (free == 0 || constraints.rows() == 0) return free;
  SparseMatrix unmeasured(n, free);
  unmeasured.setFromTriplets(free_entries.begin(), free_entries.end());
  return free - SparseRank(constraints * unmeasured, kConstraintTolerance);
}

}  // namespace

// The constraints' null space N by SVD, then the eigenvalues of Nᵀ I N (when a bound from its
// Cholesky factor cannot show them all above the tolerance), and its eigenvectors only when
// some are negligible.
Eigen::MatrixXd FreeDirections(const Eigen::MatrixXd& constraints,
                               const Eigen::MatrixXd& information, int* model_dof,
                               int* determined) {
  const int n = static_cast<int>(information.cols());
  Eigen::MatrixXd null_space;
  if (constraints.rows() > 0) {
    const SingularValueDecomposition svd = ComputeSvd(constraints, SingularVectors::kFullV);
    const Eigen::VectorXd& s = svd.singular_values;
    int rank = 0;
    for (int i = 0; i < s.size(); ++i) rank += s[i] > kConstraintTolerance * s[0];
    null_space = svd.V.rightCols(n - rank);
  }
  *model_dof = constraints.rows() > 0 ? static_cast<int>(null_space.cols()) : n;
  *determined = 0;
  if (*model_dof == 0) return Eigen::MatrixXd(n, 0);
  const Eigen::MatrixXd reduced =
      constraints.rows() > 0 ? Eigen::MatrixXd(null_space.transpose() * information * null_space)
                             : information;
  const auto count_free = [&](const Eigen::VectorXd& lambda) {  // ascending
    const double largest = lambda[lambda.size() - 1];
    int free = 0;
    while (free < lambda.size() && !(lambda[free] > kInformationTolerance * largest)) ++free;
    return free;
  };
  // Every eigenvalue is above the tolerance, without computing one, when λmin ≥ 1 / tr(A⁻¹)
  // is above it times tr(A) ≥ λmax; tr(A⁻¹) = ‖L⁻¹‖² from A's Cholesky factor.
  const Eigen::LLT<Eigen::MatrixXd> llt(reduced);
  if (llt.info() == Eigen::Success) {
    const double inverse_trace = LowerTriangularInverse(llt.matrixLLT()).squaredNorm();
    if (1 / inverse_trace > kInformationTolerance * reduced.trace()) {
      *determined = *model_dof;
      return Eigen::MatrixXd(n, 0);
    }
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> values(reduced, Eigen::EigenvaluesOnly);
  *determined = *model_dof - count_free(values.eigenvalues());
  if (*determined == *model_dof) return Eigen::MatrixXd(n, 0);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(reduced);
  const int free = count_free(eigen.eigenvalues());
  *determined = *model_dof - free;
  const Eigen::MatrixXd basis = eigen.eigenvectors().leftCols(free);
  return constraints.rows() > 0 ? Eigen::MatrixXd(null_space * basis) : basis;
}

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
  out.analysed = ranks;
  // The scaled Jacobians' rows: the constraints' normalised, the measurements' whitened.
  Triplets constraint_entries, measurement_entries;
  int constraint_rows = 0, constraint_count = 0;
  double largest_measurement_row = 0;
  Eigen::VectorXd r;
  Eigen::MatrixXd jacobian, rows;
  // The measurements' information block by block, while every measurement reaches one block.
  std::vector<Eigen::MatrixXd> block_information(blocks.size());
  bool one_block_each = true;
  const auto append = [&](const Factor& f, const Eigen::MatrixXd& compact, int first_row,
                          double row_scale, Triplets* entries) {
    for (int i = 0; i < compact.rows(); ++i) {
      int column = 0;
      for (int block : f.blocks) {
        const Block& b = blocks[block];
        for (int k = 0; k < TangentDim(b.kind); ++k, ++column) {
          const double v = compact(i, column);
          if (v != 0) entries->emplace_back(first_row + i, b.tangent_offset + k, v * row_scale);
        }
      }
    }
  };
  for (const Factor& f : factors) {
    EvaluateResidual(*f.residual, blocks, f.blocks, values, &r, ranks ? &jacobian : nullptr);
    if (!r.allFinite() || (ranks && !jacobian.allFinite())) continue;
    if (ranks) {  // scaled by the blocks' column scales
      int column = 0;
      for (int block : f.blocks) {
        const Block& b = blocks[block];
        const int dim = TangentDim(b.kind);
        jacobian.middleCols(column, dim) *= scale.segment(b.tangent_offset, dim).asDiagonal();
        column += dim;
      }
    }
    if (f.is_constraint()) {
      constraint_count += static_cast<int>(r.size());
      for (int i = 0; ranks && i < jacobian.rows(); ++i) {
        const double norm = jacobian.row(i).norm();
        if (!(norm > 0)) continue;
        append(f, jacobian.row(i), constraint_rows++, 1 / norm, &constraint_entries);
      }
      continue;
    }
    const Eigen::LLT<Eigen::MatrixXd> llt(f.noise);
    if (llt.info() != Eigen::Success) continue;
    out.fit.chi2 += llt.matrixL().solve(r).squaredNorm();
    if (ranks) {
      rows = llt.matrixL().solve(jacobian);
      largest_measurement_row = std::max(largest_measurement_row, rows.rowwise().norm().maxCoeff());
      append(f, rows, out.fit.residuals, 1, &measurement_entries);
      if (f.blocks.size() == 1) {
        Eigen::MatrixXd& information = block_information[f.blocks[0]];
        if (information.size() == 0) information.setZero(rows.cols(), rows.cols());
        information.noalias() += rows.transpose() * rows;
      } else {
        one_block_each = false;
      }
    }
    out.fit.residuals += static_cast<int>(r.size());
  }
  if (!ranks) {
    out.model_dof = std::max(0, n - constraint_count);
    out.determined = std::min(out.model_dof, out.fit.residuals);
  } else {
    SparseMatrix constraints(constraint_rows, n), measurements(out.fit.residuals, n);
    constraints.setFromTriplets(constraint_entries.begin(), constraint_entries.end());
    measurements.setFromTriplets(measurement_entries.begin(), measurement_entries.end());
    if (n <= kDenseBelowDim) {
      NameFreeDirections(constraints, measurements, scale, &out);  // counts, and names
    } else {
      const int constraint_rank = SparseRank(constraints, kConstraintTolerance);
      out.model_dof = n - constraint_rank;
      if (one_block_each) {
        out.determined =
            std::clamp(out.model_dof - FreeUnderConstraints(blocks, block_information, constraints),
                       0, out.model_dof);
      } else {
        // determined = rank [C; M] − rank C, with C's rows as strong as M's strongest.
        const double weight = largest_measurement_row > 0 ? largest_measurement_row : 1.0;
        for (auto& e : constraint_entries) {
          e = {e.row() + out.fit.residuals, e.col(), e.value() * weight};
        }
        measurement_entries.insert(measurement_entries.end(), constraint_entries.begin(),
                                   constraint_entries.end());
        SparseMatrix stacked(out.fit.residuals + constraint_rows, n);
        stacked.setFromTriplets(measurement_entries.begin(), measurement_entries.end());
        out.determined = std::clamp(
            SparseRank(std::move(stacked), kSingularTolerance) - constraint_rank, 0, out.model_dof);
      }
      // Free directions are named (and counted again, densely) only where there are some.
      if (out.determined < out.model_dof && n <= kMaxAnalysedDim) {
        NameFreeDirections(constraints, measurements, scale, &out);
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
