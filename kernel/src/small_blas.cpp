#include "small_blas.h"

namespace cfuse::internal {
namespace {

// P(S, S) -= W Wᵀ over the support S, one column of W at a time. Each rank-one step updates
// both P(i, j) and P(j, i) with the same product w_i w_j (multiplication commutes exactly in
// floating point), so P stays exactly symmetric without a triangular update and a mirror copy,
// and every inner loop runs down a contiguous column.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
// The hottest loop of the filter: compiled also for AVX2 + FMA and chosen at run time by the
// CPU's features, so the library still runs on any x86-64.
__attribute__((target_clones("arch=x86-64-v3", "default")))
#endif
void SubtractOuterProductColumns(const Run* runs, int num_runs, const double* w, double sign,
                                 double* P, long ld) {
  for (int c = 0; c < num_runs; ++c) {
    for (int j = 0; j < runs[c].size; ++j) {
      const double wj = sign * w[runs[c].at + j];  // sign is ±1: exact, P stays symmetric
      double* column = P + (runs[c].first + j) * ld;
      for (int r = 0; r < num_runs; ++r) {
        double* out = column + runs[r].first;
        const double* in = w + runs[r].at;
        for (int i = 0; i < runs[r].size; ++i) out[i] -= in[i] * wj;
      }
    }
  }
}

}  // namespace

void SubtractOuterProduct(const std::vector<Run>& runs, const Eigen::Map<Eigen::MatrixXd>& W,
                          const double* signs, Eigen::MatrixXd* P) {
  for (int l = 0; l < W.cols(); ++l) {
    SubtractOuterProductColumns(runs.data(), static_cast<int>(runs.size()), W.col(l).data(),
                                signs ? signs[l] : 1.0, P->data(), P->rows());
  }
}

void ResetRotationBlock(const std::vector<Run>& runs, int o, const Eigen::Matrix3d& G,
                        Eigen::MatrixXd* P) {
  const Eigen::Matrix3d diagonal = G * P->block<3, 3>(o, o) * G.transpose();
  for (const Run& run : runs) {
    const Eigen::Matrix<double, 3, Eigen::Dynamic> rows = G * P->block(o, run.first, 3, run.size);
    P->block(o, run.first, 3, run.size) = rows;
    P->block(run.first, o, run.size, 3) = rows.transpose();
  }
  P->block<3, 3>(o, o) = 0.5 * (diagonal + diagonal.transpose());
}

}  // namespace cfuse::internal
