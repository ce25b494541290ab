// LowerTriangularInverse against Eigen's triangular solve, at a marker's few rows and at a
// robot's hundred, reading only the lower triangle.
#include "cfuse/kernel/triangular.h"

#include <Eigen/Cholesky>
#include <catch2/catch.hpp>
#include <cstdlib>

namespace cfuse {
namespace {

TEST_CASE("triangular: the inverse of a lower-triangular factor", "[kernel]") {
  std::srand(11);
  for (const int n : {1, 2, 3, 9, 40, 114}) {
    INFO(n << " rows");
    const Eigen::MatrixXd A = Eigen::MatrixXd::Random(n, n);
    const Eigen::MatrixXd S = A * A.transpose() + 0.1 * Eigen::MatrixXd::Identity(n, n);
    Eigen::MatrixXd L = Eigen::LLT<Eigen::MatrixXd>(S).matrixL();
    L.triangularView<Eigen::StrictlyUpper>().setConstant(7);  // not read
    const Eigen::MatrixXd X = LowerTriangularInverse(L);
    const Eigen::MatrixXd expected =
        L.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(n, n));
    CHECK((X - expected).norm() <= 1e-12 * expected.norm());
    CHECK(X.triangularView<Eigen::StrictlyUpper>().toDenseMatrix().isZero(0));
  }
  CHECK(LowerTriangularInverse(Eigen::MatrixXd(0, 0)).size() == 0);
}

}  // namespace
}  // namespace cfuse
