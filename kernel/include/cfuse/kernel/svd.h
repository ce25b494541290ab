// The singular value decomposition of a dense matrix of any size, compiled once.
//
// Eigen's BDCSVD is a template that every translation unit using it instantiates anew, at the
// cost of minutes of compilation under the sanitizers. The few places that need the SVD of a
// dynamic matrix (numerical ranks, null spaces, minimum-norm solutions) call this instead; the
// result is Eigen's, bit for bit.
#pragma once

#include <Eigen/Core>

namespace cfuse {

// Which singular vectors to compute besides the singular values.
enum class SingularVectors { kNone, kFullV, kThinUFullV };

// A = U diag(singular_values) Vᵀ for an m x n matrix A, with k = min(m, n).
struct SingularValueDecomposition {
  Eigen::VectorXd singular_values;  // k values, descending, non-negative
  Eigen::MatrixXd U;                // m x k (thin) for kThinUFullV, else empty
  Eigen::MatrixXd V;                // n x n (full) unless kNone, else empty
};

SingularValueDecomposition ComputeSvd(const Eigen::MatrixXd& A, SingularVectors vectors);

}  // namespace cfuse
