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

// out[i] = Σ_l coefficients[l] column(l)[i], four columns at a time, so each entry of `out` is
// loaded and stored once per four products.
template <typename ColumnAt>
inline void Combine(const ColumnAt& column, long rows, long cols, const double* coefficients,
                    double* out) {
  for (long i = 0; i < rows; ++i) out[i] = 0;
  long l = 0;
  for (; l + 4 <= cols; l += 4) {
    const double c0 = coefficients[l], c1 = coefficients[l + 1], c2 = coefficients[l + 2],
                 c3 = coefficients[l + 3];
    const double *p0 = column(l), *p1 = column(l + 1), *p2 = column(l + 2), *p3 = column(l + 3);
    for (long i = 0; i < rows; ++i) out[i] += p0[i] * c0 + p1[i] * c1 + p2[i] * c2 + p3[i] * c3;
  }
  for (; l < cols; ++l) {
    const double c = coefficients[l];
    const double* p = column(l);
    for (long i = 0; i < rows; ++i) out[i] += p[i] * c;
  }
}

}  // namespace

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
__attribute__((target_clones("arch=x86-64-v3", "default")))
#endif
void CombineColumns(const double* P, long rows, long cols, const double* coefficients,
                    double* out) {
  Combine([&](long l) { return P + l * rows; }, rows, cols, coefficients, out);
}

// AVX2 without FMA: twice SSE2's width, the same products and sums (see small_blas.h).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
__attribute__((target_clones("avx2", "default")))
#endif
void CombineColumns(const double* const* columns, long offset, long rows, long cols,
                    const double* coefficients, double* out) {
  Combine([&](long l) { return columns[l] + offset; }, rows, cols, coefficients, out);
}

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
