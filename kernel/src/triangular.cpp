#include "cfuse/kernel/triangular.h"

#include "cfuse/kernel/check.h"

namespace cfuse {

Eigen::MatrixXd LowerTriangularInverse(const Eigen::MatrixXd& L) {
  CFUSE_CHECK_EQ(L.rows(), L.cols());
  const Eigen::Index n = L.rows();
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index j = 0; j < n; ++j) {
    auto x = X.col(j);
    x[j] = 1;
    for (Eigen::Index k = j; k < n; ++k) {
      x[k] /= L(k, k);
      x.tail(n - k - 1).noalias() -= x[k] * L.col(k).tail(n - k - 1);
    }
  }
  return X;
}

}  // namespace cfuse
