// The sparse LDLᵀ of the sparse solver against dense references: solves and the selected
// inverse of random quasi-definite KKT matrices, a dependent constraint row dropped as if it
// were absent, and a state pivot that is not positive refused.
#include "sparse_ldlt.h"

#include <Eigen/Dense>
#include <catch2/catch.hpp>
#include <random>

#include "cfuse/kernel/check.h"

namespace cfuse::internal {
namespace {

Eigen::SparseMatrix<double> Upper(const Eigen::MatrixXd& K, const Eigen::MatrixXi& pattern) {
  std::vector<Eigen::Triplet<double>> t;
  for (int j = 0; j < K.cols(); ++j) {
    for (int i = 0; i <= j; ++i) {
      if (pattern(i, j)) t.emplace_back(i, j, K(i, j));
    }
  }
  Eigen::SparseMatrix<double> upper(K.rows(), K.cols());
  upper.setFromTriplets(t.begin(), t.end());
  return upper;
}

// [Λ Aᵀ; A 0] with Λ sparse positive definite (n x n) and A sparse (m x n), and its pattern.
Eigen::MatrixXd RandomKkt(std::mt19937& rng, int n, int m, Eigen::MatrixXi* pattern) {
  std::normal_distribution<double> g(0, 1);
  std::bernoulli_distribution keep(0.25);
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(n, n), A = Eigen::MatrixXd::Zero(m, n);
  for (int i = 0; i < n; ++i) {
    B(i, i) = 1 + std::abs(g(rng));
    for (int j = 0; j < i; ++j) {
      if (keep(rng)) B(i, j) = g(rng);
    }
  }
  for (int i = 0; i < m; ++i) {
    A(i, i % n) = 1 + std::abs(g(rng));  // full row rank
    for (int j = 0; j < n; ++j) {
      if (keep(rng)) A(i, j) += g(rng);
    }
  }
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n + m, n + m);
  K.topLeftCorner(n, n) = B * B.transpose();
  K.bottomLeftCorner(m, n) = A;
  K.topRightCorner(n, m) = A.transpose();
  *pattern = (K.array() != 0).cast<int>();
  pattern->diagonal().setOnes();
  return K;
}

TEST_CASE("sparse ldlt: solves and the selected inverse match the dense inverse", "[kernel]") {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 4 + trial % 7, m = 1 + trial % 4;
    Eigen::MatrixXi pattern;
    const Eigen::MatrixXd K = RandomKkt(rng, n, m, &pattern);
    const Eigen::SparseMatrix<double> upper = Upper(K, pattern);
    Eigen::VectorXd drop = Eigen::VectorXd::Constant(n + m, -1.0);
    drop.tail(m).setConstant(1e-12);
    SparseLdlt ldlt;
    ldlt.Analyze(upper);
    REQUIRE(ldlt.Factorize(upper, drop));
    CHECK(ldlt.dropped() == 0);
    CHECK_FALSE(ldlt.has_selected_inverse());
    CHECK_THROWS_AS(ldlt.Inverse(0, 0), InternalError);  // not computed for this factor yet
    const Eigen::VectorXd b = Eigen::VectorXd::Random(n + m);
    Eigen::VectorXd x = b;
    ldlt.Solve(&x);
    CHECK((K * x - b).norm() < 1e-9 * (1 + b.norm()));
    ldlt.ComputeSelectedInverse();
    const Eigen::MatrixXd inverse = K.inverse();
    // Every entry of K's own pattern is on L's (L's pattern holds K's, and the fill).
    for (int j = 0; j < n + m; ++j) {
      for (int i = 0; i <= j; ++i) {
        if (!pattern(i, j)) continue;
        INFO("trial " << trial << " entry " << i << ", " << j);
        CHECK(ldlt.Inverse(i, j) == Approx(inverse(i, j)).margin(1e-9));
        CHECK(ldlt.Inverse(j, i) == ldlt.Inverse(i, j));
      }
    }
    // The state's block whole, and every column when asked for all.
    CHECK((ldlt.InverseLeading(n) - inverse.topLeftCorner(n, n)).cwiseAbs().maxCoeff() < 1e-9);
    CHECK((ldlt.InverseLeading(n + m) - inverse).cwiseAbs().maxCoeff() < 1e-9);
  }
}

TEST_CASE("sparse ldlt: a constraint row that repeats others is dropped as if absent", "[kernel]") {
  std::mt19937 rng(8);
  const int n = 6, m = 2;
  Eigen::MatrixXi pattern;
  const Eigen::MatrixXd K = RandomKkt(rng, n, m, &pattern);
  // A third row: the sum of the first two.
  Eigen::MatrixXd K3 = Eigen::MatrixXd::Zero(n + 3, n + 3);
  K3.topLeftCorner(n + m, n + m) = K;
  const Eigen::RowVectorXd sum = K.row(n).head(n) + K.row(n + 1).head(n);
  K3.block(n + 2, 0, 1, n) = sum;
  K3.block(0, n + 2, n, 1) = sum.transpose();
  Eigen::MatrixXi pattern3 = (K3.array() != 0).cast<int>();
  pattern3.diagonal().setOnes();
  Eigen::VectorXd drop = Eigen::VectorXd::Constant(n + 3, -1.0);
  drop.tail(3).setConstant(1e-12 * sum.squaredNorm());
  SparseLdlt ldlt;
  const Eigen::SparseMatrix<double> upper = Upper(K3, pattern3);
  ldlt.Analyze(upper);
  REQUIRE(ldlt.Factorize(upper, drop));
  CHECK(ldlt.dropped() == 1);
  // A consistent right-hand side: the repeated row's is the sum of the others'.
  Eigen::VectorXd b = Eigen::VectorXd::Random(n + 3);
  b[n + 2] = b[n] + b[n + 1];
  Eigen::VectorXd x = b;
  ldlt.Solve(&x);
  const Eigen::VectorXd reference = K.lu().solve(b.head(n + m));
  CHECK((x.head(n) - reference.head(n)).norm() < 1e-9);
  CHECK(x[n + 2] == 0);
  ldlt.ComputeSelectedInverse();
  const Eigen::MatrixXd inverse = K.inverse();
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      if (i == j || pattern3(std::min(i, j), std::max(i, j))) {
        CHECK(ldlt.Inverse(i, j) == Approx(inverse(i, j)).margin(1e-9));
      }
    }
  }
  CHECK(ldlt.Inverse(n + 2, n + 2) == 0);
  const Eigen::MatrixXd leading = ldlt.InverseLeading(n + 3);
  CHECK((leading.topLeftCorner(n + m, n + m) - inverse).cwiseAbs().maxCoeff() < 1e-9);
  CHECK(leading.row(n + 2).cwiseAbs().maxCoeff() == 0);
  CHECK(leading.col(n + 2).cwiseAbs().maxCoeff() == 0);
}

TEST_CASE("sparse ldlt: a state pivot that is not positive fails the factorisation", "[kernel]") {
  Eigen::MatrixXd K(2, 2);
  K << 1, 2, 2, 1;  // indefinite
  const Eigen::MatrixXi pattern = Eigen::MatrixXi::Ones(2, 2);
  SparseLdlt ldlt;
  const Eigen::SparseMatrix<double> upper = Upper(K, pattern);
  ldlt.Analyze(upper);
  CHECK_FALSE(ldlt.Factorize(upper, Eigen::Vector2d(-1, -1)));
  // As a constraint row the second pivot (1 - 4 = -3) is fine.
  CHECK(ldlt.Factorize(upper, Eigen::Vector2d(-1, 0)));
}

}  // namespace
}  // namespace cfuse::internal
