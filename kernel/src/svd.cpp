#include "cfuse/kernel/svd.h"

#include <Eigen/SVD>

namespace cfuse {

SingularValueDecomposition ComputeSvd(const Eigen::MatrixXd& A, SingularVectors vectors) {
  unsigned int options = 0;
  if (vectors == SingularVectors::kFullV) options = Eigen::ComputeFullV;
  if (vectors == SingularVectors::kThinUFullV) options = Eigen::ComputeThinU | Eigen::ComputeFullV;
  const Eigen::BDCSVD<Eigen::MatrixXd> svd(A, options);
  SingularValueDecomposition out;
  out.singular_values = svd.singularValues();
  if (vectors == SingularVectors::kThinUFullV) out.U = svd.matrixU();
  if (vectors != SingularVectors::kNone) out.V = svd.matrixV();
  return out;
}

}  // namespace cfuse
