// ComputeSvd (cfuse/kernel/svd.h): A = U diag(s) Vᵀ with orthonormal vectors and descending
// values, for tall, wide and rank-deficient matrices.
#include "cfuse/kernel/svd.h"

#include <catch2/catch.hpp>
#include <random>

namespace cfuse {
namespace {

TEST_CASE("svd: the factors rebuild the matrix, orthonormal and in descending order", "[kernel]") {
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, 1);
  for (auto [m, n] : {std::pair{7, 3}, {3, 7}, {20, 20}, {40, 25}}) {
    Eigen::MatrixXd A(m, n);
    for (int i = 0; i < A.size(); ++i) A(i) = g(rng);
    if (m == 40) A.col(24) = A.col(0) + A.col(1);  // rank deficient
    const SingularValueDecomposition svd = ComputeSvd(A, SingularVectors::kThinUFullV);
    const int k = std::min(m, n);
    INFO(m << " x " << n);
    REQUIRE(svd.singular_values.size() == k);
    REQUIRE(svd.U.rows() == m);
    REQUIRE(svd.U.cols() == k);
    REQUIRE(svd.V.rows() == n);
    REQUIRE(svd.V.cols() == n);
    for (int i = 1; i < k; ++i) CHECK(svd.singular_values[i] <= svd.singular_values[i - 1]);
    CHECK(svd.singular_values.minCoeff() >= 0);
    const Eigen::MatrixXd rebuilt =
        svd.U * svd.singular_values.asDiagonal() * svd.V.leftCols(k).transpose();
    CHECK((rebuilt - A).norm() < 1e-12 * A.norm());
    CHECK((svd.U.transpose() * svd.U - Eigen::MatrixXd::Identity(k, k)).norm() < 1e-12);
    CHECK((svd.V.transpose() * svd.V - Eigen::MatrixXd::Identity(n, n)).norm() < 1e-12);
    if (m == 40) CHECK(svd.singular_values[k - 1] < 1e-12 * svd.singular_values[0]);
    // The same values without vectors, and only V when asked.
    const SingularValueDecomposition values = ComputeSvd(A, SingularVectors::kNone);
    CHECK(values.singular_values == svd.singular_values);
    CHECK(values.U.size() == 0);
    CHECK(values.V.size() == 0);
    const SingularValueDecomposition v = ComputeSvd(A, SingularVectors::kFullV);
    CHECK(v.U.size() == 0);
    CHECK(v.V.cols() == n);
  }
}

}  // namespace
}  // namespace cfuse
