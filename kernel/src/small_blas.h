// Small dense routines for the filter's update: its matrices are a few rows by a few columns,
// where Eigen's product kernels and triangular solvers spend more on dispatch, packing and
// blocking than on arithmetic (Ceres keeps its small_blas.h for the same reason). Internal to
// kernel: not installed.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace cfuse::internal {

// A matrix view on a buffer that only grows, so that steady-state updates do not allocate.
inline Eigen::Map<Eigen::MatrixXd> Scratch(std::vector<double>* storage, int rows, int cols) {
  const size_t size = static_cast<size_t>(rows) * static_cast<size_t>(cols);
  if (storage->size() < size) storage->resize(size);
  return {storage->data(), rows, cols};
}

inline Eigen::Map<Eigen::VectorXd> ScratchVector(std::vector<double>* storage, int size) {
  if (storage->size() < static_cast<size_t>(size)) storage->resize(size);
  return {storage->data(), size};
}

// A maximal run of consecutive covariance coordinates [first, first + size) of the support,
// at `at` in the support's order. The support is a few such runs (blocks join groups mostly in
// the order they were declared), so the updates below are dense block products.
struct Run {
  int first, at, size;
};

// P(S, S) -= Σ_l sign_l w_l w_lᵀ, w_l the columns of W, sign_l = ±1 (all +1 if `signs` is null),
// exactly symmetric.
void SubtractOuterProduct(const std::vector<Run>& runs, const Eigen::Map<Eigen::MatrixXd>& W,
                          const double* signs, Eigen::MatrixXd* P);

// out = Σ_l coefficients[l] P(:, l) for a column-major `rows` x `cols` P (out = P c), for the
// quadratic forms below.
void CombineColumns(const double* P, long rows, long cols, const double* coefficients, double* out);

// The same over `cols` columns given by their starts, rows [offset, offset + rows) of each: the
// gain columns W = P(S, a) A of every update, read in place from the covariance, a run of the
// support at a time. Compiled for AVX2 but not FMA, so that its results do not depend on the
// CPU: the gain feeds every later update, and the tracker's edge-on lid
// (tests/track/places_test.cpp) is decided by roundoff in it.
void CombineColumns(const double* const* columns, long offset, long rows, long cols,
                    const double* coefficients, double* out);

// Moves rows and columns o..o+2 (a rotation block, inside the support) from the chart at x0
// to the chart at x0 ⊞ δ: P <- G P Gᵀ with G = Jr(δθ) on that block, exactly symmetric.
void ResetRotationBlock(const std::vector<Run>& runs, int o, const Eigen::Matrix3d& G,
                        Eigen::MatrixXd* P);

// C = A B for small dynamic matrices, coefficient by coefficient (A is a few rows: a Jacobian).
inline void SmallProduct(const Eigen::Map<Eigen::MatrixXd>& A, const Eigen::Map<Eigen::MatrixXd>& B,
                         Eigen::Map<Eigen::MatrixXd>* C) {
  for (int j = 0; j < B.cols(); ++j) {
    for (int i = 0; i < A.rows(); ++i) {
      double sum = 0;
      for (int l = 0; l < A.cols(); ++l) sum += A(i, l) * B(l, j);
      (*C)(i, j) = sum;
    }
  }
}

// C = A Bᵀ for small dynamic matrices.
inline void SmallProductTransposed(const Eigen::Map<Eigen::MatrixXd>& A,
                                   const Eigen::Map<Eigen::MatrixXd>& B,
                                   Eigen::Map<Eigen::MatrixXd>* C) {
  for (int j = 0; j < B.rows(); ++j) {
    for (int i = 0; i < A.rows(); ++i) {
      double sum = 0;
      for (int l = 0; l < A.cols(); ++l) sum += A(i, l) * B(j, l);
      (*C)(i, j) = sum;
    }
  }
}

// C = Aᵀ B for small dynamic matrices.
inline void SmallTransposedProduct(const Eigen::Map<Eigen::MatrixXd>& A,
                                   const Eigen::Map<Eigen::MatrixXd>& B,
                                   Eigen::Map<Eigen::MatrixXd>* C) {
  for (int j = 0; j < B.cols(); ++j) {
    for (int i = 0; i < A.cols(); ++i) (*C)(i, j) = A.col(i).dot(B.col(j));
  }
}

// out = Gᵀ P G (P symmetric), exactly symmetric; `storage` holds P G.
inline void QuadraticForm(const Eigen::Map<Eigen::MatrixXd>& G,
                          const Eigen::Map<Eigen::MatrixXd>& P, std::vector<double>* storage,
                          Eigen::Map<Eigen::MatrixXd>* out) {
  Eigen::Map<Eigen::MatrixXd> PG =
      Scratch(storage, static_cast<int>(P.rows()), static_cast<int>(G.cols()));
  for (long j = 0; j < G.cols(); ++j) {
    CombineColumns(P.data(), P.rows(), P.cols(), G.col(j).data(), PG.col(j).data());
  }
  for (int j = 0; j < G.cols(); ++j) {
    for (int i = 0; i <= j; ++i) {
      (*out)(i, j) = (*out)(j, i) = 0.5 * (G.col(i).dot(PG.col(j)) + G.col(j).dot(PG.col(i)));
    }
  }
}

// With L the lower triangle of `llt` (S = L Lᵀ): A <- A L⁻ᵀ (A is a x m, i.e. the rows of
// Aᵀ are solved) and z <- L⁻¹ z. Plain loops: m is a few rows, where Eigen's triangular
// solvers take their blocked matrix path.
inline void ForwardSubstitute(const Eigen::MatrixXd& llt, Eigen::Map<Eigen::MatrixXd>* A,
                              Eigen::Map<Eigen::VectorXd>* z) {
  const int m = static_cast<int>(llt.rows());
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < i; ++j) {
      A->col(i) -= llt(i, j) * A->col(j);
      (*z)(i) -= llt(i, j) * (*z)(j);
    }
    A->col(i) /= llt(i, i);
    (*z)(i) /= llt(i, i);
  }
}

}  // namespace cfuse::internal
