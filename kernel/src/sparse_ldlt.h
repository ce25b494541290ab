// A sparse LDLᵀ factorisation in a fixed order, without pivoting (T. A. Davis's up-looking LDL,
// as Eigen's SimplicialLDLT), for the sparse solver's KKT systems. Written out rather than taken
// from Eigen for two things Eigen's does not do:
//  - a pivot that vanishes is dropped instead of failing: its row is treated as absent (its
//    column of L zero, its entry of D⁻¹ zero), which is how a constraint row that is a
//    combination of others leaves the system;
//  - the selected inverse: the entries of K⁻¹ on the pattern of L (Takahashi's recurrences),
//    which hold every variance and every covariance a caller made room for by an explicit
//    entry of K, at a cost of the order of the factor's entries, not of K⁻¹'s.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

namespace cfuse::internal {

class SparseLdlt {
 public:
  // `upper`: the pattern of K's upper triangle, column-compressed, diagonal included. The
  // pattern (not the values) is fixed from here on.
  void Analyze(const Eigen::SparseMatrix<double>& upper);

  // Factorises K (the analysed pattern). Pivot k is dropped when |d_k| <= drop_below[k]; a pivot
  // with drop_below[k] < 0 must be positive (a row of a positive definite part). False when one
  // is not, or is not finite.
  bool Factorize(const Eigen::SparseMatrix<double>& upper, const Eigen::VectorXd& drop_below);

  // x <- K⁺ x, the dropped rows' entries set to 0.
  void Solve(Eigen::VectorXd* x) const;

  // The entries of K⁻¹ (the dropped rows left out) on the pattern of L and the diagonal;
  // then Inverse(i, j) reads them.
  void ComputeSelectedInverse();
  // Whether it was computed since the last factorisation.
  bool has_selected_inverse() const { return inverse_ready_; }
  // K⁻¹(i, j) for i == j or (i, j) in the pattern of L (either order). InternalError if not.
  double Inverse(int i, int j) const;

  // The leading count x count block of K⁺ whole (the dropped rows' entries 0): count solves
  // with the factor at once, O(count · entries of L).
  Eigen::MatrixXd InverseLeading(int count) const;

  int size() const { return static_cast<int>(d_.size()); }
  // Pivots dropped by the factorisation (meaningful after one that succeeded).
  int dropped() const;
  long nonzeros() const { return static_cast<long>(row_.size()); }

 private:
  // Position of row i in column j's part of row_ (i > j), or -1.
  long Find(int i, int j) const;

  std::vector<int> parent_;    // elimination tree
  std::vector<long> start_;    // column j of L: entries start_[j] .. start_[j + 1]
  std::vector<int> row_;       // their rows, increasing within a column
  std::vector<double> l_;      // their values
  std::vector<double> z_;      // the selected inverse on the same pattern
  Eigen::VectorXd d_;          // D
  Eigen::VectorXd d_inverse_;  // 1 / D, 0 for a dropped pivot
  Eigen::VectorXd z_diagonal_;
  bool inverse_ready_ = false;
};

}  // namespace cfuse::internal
