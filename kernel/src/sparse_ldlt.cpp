#include "sparse_ldlt.h"

#include <algorithm>
#include <cmath>

#include "cfuse/kernel/check.h"

namespace cfuse::internal {

void SparseLdlt::Analyze(const Eigen::SparseMatrix<double>& upper) {
  CFUSE_CHECK_EQ(upper.rows(), upper.cols());
  const int n = static_cast<int>(upper.cols());
  parent_.assign(n, -1);
  std::vector<int> flag(n), count(n, 0);
  // Row k of L is nonzero where the elimination tree's paths from K's entries (i, k), i < k,
  // reach before k.
  for (int k = 0; k < n; ++k) {
    flag[k] = k;
    for (Eigen::SparseMatrix<double>::InnerIterator it(upper, k); it; ++it) {
      for (int i = static_cast<int>(it.row()); i < k && flag[i] != k; i = parent_[i]) {
        if (parent_[i] == -1) parent_[i] = k;
        ++count[i];
        flag[i] = k;
      }
    }
  }
  start_.assign(n + 1, 0);
  for (int j = 0; j < n; ++j) start_[j + 1] = start_[j] + count[j];
  row_.assign(start_[n], 0);
  l_.assign(start_[n], 0.0);
  z_.clear();
  inverse_ready_ = false;
  d_ = Eigen::VectorXd::Zero(n);
  d_inverse_ = Eigen::VectorXd::Zero(n);
}

bool SparseLdlt::Factorize(const Eigen::SparseMatrix<double>& upper,
                           const Eigen::VectorXd& drop_below) {
  const int n = size();
  CFUSE_CHECK_EQ(upper.cols(), n);
  CFUSE_CHECK_EQ(drop_below.size(), n);
  z_.clear();
  inverse_ready_ = false;
  std::vector<double> y(n, 0.0);
  std::vector<int> flag(n), pattern(n), filled(n, 0);
  for (int k = 0; k < n; ++k) {
    // Scatter column k of K's upper triangle and find row k's pattern of L in topological order.
    int top = n;
    flag[k] = k;
    for (Eigen::SparseMatrix<double>::InnerIterator it(upper, k); it; ++it) {
      int i = static_cast<int>(it.row());
      y[i] += it.value();
      int len = 0;
      for (; i < k && flag[i] != k; i = parent_[i]) {
        pattern[len++] = i;
        flag[i] = k;
      }
      while (len > 0) pattern[--top] = pattern[--len];
    }
    double d = y[k];
    y[k] = 0;
    for (; top < n; ++top) {
      const int i = pattern[top];
      const double yi = y[i];
      y[i] = 0;
      const long end = start_[i] + filled[i];
      // A dropped pivot's column is zero: its row takes no part in the rows after it.
      double l_ki = 0;
      if (d_inverse_[i] != 0) {
        for (long p = start_[i]; p < end; ++p) y[row_[p]] -= l_[p] * yi;
        l_ki = yi * d_inverse_[i];
        d -= l_ki * yi;
      }
      row_[end] = k;
      l_[end] = l_ki;
      ++filled[i];
    }
    d_[k] = d;
    if (!std::isfinite(d)) return false;
    if (drop_below[k] < 0) {
      if (d <= 0) return false;
      d_inverse_[k] = 1 / d;
    } else {
      d_inverse_[k] = std::abs(d) <= drop_below[k] ? 0.0 : 1 / d;
    }
  }
  return true;
}

void SparseLdlt::Solve(Eigen::VectorXd* x) const {
  const int n = size();
  CFUSE_CHECK_EQ(x->size(), n);
  Eigen::VectorXd& v = *x;
  for (int j = 0; j < n; ++j) {
    for (long p = start_[j]; p < start_[j + 1]; ++p) v[row_[p]] -= l_[p] * v[j];
  }
  v.array() *= d_inverse_.array();
  for (int j = n - 1; j >= 0; --j) {
    double s = v[j];
    for (long p = start_[j]; p < start_[j + 1]; ++p) s -= l_[p] * v[row_[p]];
    v[j] = s;
  }
}

Eigen::MatrixXd SparseLdlt::InverseLeading(int count) const {
  const int n = size();
  CFUSE_CHECK(count >= 0 && count <= n);
  // K⁺ E, E the first `count` columns of the identity, by rows: each step of the substitutions
  // moves a row, contiguous in row-major storage. Forward, each row is nonzero only between the
  // columns [lo, hi] it has gathered (a state coordinate's within its block, where K's state
  // part is block-diagonal); backward, the rows above `count` are needed only up to the
  // diagonal, the rest is the transpose.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> v =
      Eigen::MatrixXd::Identity(n, count);
  std::vector<int> lo(n, count), hi(n, -1);
  for (int r = 0; r < count; ++r) lo[r] = hi[r] = r;
  for (int j = 0; j < n; ++j) {
    if (lo[j] > hi[j]) continue;
    const int width = hi[j] - lo[j] + 1;
    for (long p = start_[j]; p < start_[j + 1]; ++p) {
      const int r = row_[p];
      lo[r] = std::min(lo[r], lo[j]);
      hi[r] = std::max(hi[r], hi[j]);
      v.row(r).segment(lo[j], width) -= l_[p] * v.row(j).segment(lo[j], width);
    }
  }
  v.array().colwise() *= d_inverse_.array();
  for (int j = n - 1; j >= 0; --j) {
    const int width = j < count ? j + 1 : count;
    for (long p = start_[j]; p < start_[j + 1]; ++p) {
      v.row(j).head(width) -= l_[p] * v.row(row_[p]).head(width);
    }
  }
  Eigen::MatrixXd out = v.topRows(count);
  out.triangularView<Eigen::StrictlyUpper>() = out.transpose();
  return out;
}

long SparseLdlt::Find(int i, int j) const {
  const auto first = row_.begin() + start_[j], last = row_.begin() + start_[j + 1];
  const auto it = std::lower_bound(first, last, i);
  return it != last && *it == i ? static_cast<long>(it - row_.begin()) : -1;
}

double SparseLdlt::Inverse(int i, int j) const {
  CFUSE_CHECK(inverse_ready_);
  if (i == j) return z_diagonal_[i];
  const long p = Find(std::max(i, j), std::min(i, j));
  CFUSE_CHECK_MSG(p >= 0, fmt::format("an entry outside the factor's pattern: ({}, {})", i, j));
  return z_[p];
}

// Z = K⁻¹ = D⁻¹ L⁻¹ + (I - Lᵀ) Z, read on the pattern of L from the last column back:
//   Z(i, j) = δ_ij / d_j - Σ_{k > j, L(k, j) ≠ 0} L(k, j) Z(k, i)   for i >= j.
// Every Z(k, i) needed lies on the pattern already computed: two rows k < i of column j are
// rows of column k too (L's pattern is that of a chordal graph). Each such Z(i, k) serves both
// sums, Z(i, j)'s and Z(k, j)'s; column k of Z is scattered into a dense vector to read them.
void SparseLdlt::ComputeSelectedInverse() {
  const int n = size();
  z_.assign(l_.size(), 0.0);
  z_diagonal_.resize(n);
  std::vector<double> w(n, 0.0);
  for (int j = n - 1; j >= 0; --j) {
    const long first = start_[j], last = start_[j + 1];
    if (d_inverse_[j] == 0) {
      z_diagonal_[j] = 0;
      continue;  // its column of L is zero and of Z too
    }
    for (long q = first; q < last; ++q) {
      const int k = row_[q];
      const double l_kj = l_[q];
      z_[q] -= l_kj * z_diagonal_[k];
      for (long e = start_[k]; e < start_[k + 1]; ++e) w[row_[e]] = z_[e];
      for (long q2 = q + 1; q2 < last; ++q2) {
        const double z_ik = w[row_[q2]];
        z_[q2] -= l_kj * z_ik;
        z_[q] -= l_[q2] * z_ik;
      }
      for (long e = start_[k]; e < start_[k + 1]; ++e) w[row_[e]] = 0;
    }
    double s = d_inverse_[j];
    for (long q = first; q < last; ++q) s -= l_[q] * z_[q];
    z_diagonal_[j] = s;
  }
  inverse_ready_ = true;
}

int SparseLdlt::dropped() const {
  int count = 0;
  for (int i = 0; i < size(); ++i) count += d_inverse_[i] == 0;
  return count;
}

}  // namespace cfuse::internal
