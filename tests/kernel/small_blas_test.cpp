// The filter's small dense routines (kernel/src/small_blas.h) against Eigen's dense products and
// solves: the outer-product update and the rotation block's reset on a support of runs in any
// order, touching nothing outside it and leaving the matrix exactly symmetric; the small
// products, the quadratic form and the forward substitution; columns combined, packed and in
// place; scratch that only grows.
#include "small_blas.h"

#include <Eigen/Cholesky>
#include <catch2/catch.hpp>
#include <cstdlib>

namespace cfuse::internal {
namespace {

Eigen::MatrixXd Symmetric(int n, unsigned seed) {
  std::srand(seed);
  const Eigen::MatrixXd A = Eigen::MatrixXd::Random(n, n);
  const Eigen::MatrixXd S = A * A.transpose() + Eigen::MatrixXd::Identity(n, n);
  return 0.5 * (S + S.transpose());  // exactly symmetric, as the filter keeps its covariance
}

// The selection matrix of a support: row k of the support is coordinate `first + k - at`.
Eigen::MatrixXd Selection(const std::vector<Run>& runs, int n) {
  int size = 0;
  for (const Run& r : runs) size += r.size;
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(size, n);
  for (const Run& r : runs) {
    for (int k = 0; k < r.size; ++k) S(r.at + k, r.first + k) = 1;
  }
  return S;
}

// Entries of P outside the support's rows and columns.
Eigen::MatrixXd Outside(const std::vector<Run>& runs, Eigen::MatrixXd P) {
  for (const Run& r : runs) {
    P.middleRows(r.first, r.size).setZero();
    P.middleCols(r.first, r.size).setZero();
  }
  return P;
}

TEST_CASE("small blas: the outer-product update on a support of runs", "[kernel]") {
  const int n = 10;
  // Coordinates 6, 7 first in the support, then 1, 2, 3.
  const std::vector<Run> runs = {{6, 0, 2}, {1, 2, 3}};
  const Eigen::MatrixXd S = Selection(runs, n);
  std::vector<double> storage(5 * 2);
  Eigen::Map<Eigen::MatrixXd> W(storage.data(), 5, 2);
  W << 0.3, -1.2, 0.7, 0.4, -0.5, 0.9, 1.1, 0.2, 0.05, -0.6;
  const double signs[] = {1, -1};
  for (const double* s : {static_cast<const double*>(signs), static_cast<const double*>(nullptr)}) {
    const Eigen::MatrixXd P0 = Symmetric(n, 5);
    Eigen::MatrixXd P = P0;
    SubtractOuterProduct(runs, W, s, &P);
    const Eigen::Vector2d sign = s ? Eigen::Vector2d(1, -1) : Eigen::Vector2d(1, 1);
    const Eigen::MatrixXd expected = P0 - S.transpose() * W * sign.asDiagonal() * W.transpose() * S;
    CHECK((P - expected).cwiseAbs().maxCoeff() < 1e-14);
    CHECK(P == P.transpose());
    CHECK(Outside(runs, P) == Outside(runs, P0));
  }
}

TEST_CASE("small blas: a rotation block moved to another chart", "[kernel]") {
  const int n = 10;
  const std::vector<Run> runs = {{8, 0, 2}, {2, 2, 4}};  // the rotation block 3..5 straddles
  const int o = 3;
  const Eigen::Matrix3d G =
      (Eigen::Matrix3d() << 1, 0.1, -0.2, -0.1, 0.9, 0.3, 0.2, -0.3, 1.1).finished();
  Eigen::MatrixXd T = Eigen::MatrixXd::Identity(n, n);
  T.block<3, 3>(o, o) = G;
  const Eigen::MatrixXd P0 = Symmetric(n, 9);
  Eigen::MatrixXd P = P0;
  ResetRotationBlock(runs, o, G, &P);
  const Eigen::MatrixXd S = Selection(runs, n);
  const Eigen::MatrixXd expected = T * P0 * T.transpose();
  CHECK((S * (P - expected) * S.transpose()).cwiseAbs().maxCoeff() < 1e-14);
  CHECK(P == P.transpose());
  CHECK(Outside(runs, P) == Outside(runs, P0));
}

TEST_CASE("small blas: small products, the quadratic form, forward substitution", "[kernel]") {
  std::srand(17);
  std::vector<double> a(12), b(8), c(6), d(8);
  Eigen::Map<Eigen::MatrixXd> A(a.data(), 3, 4), B(b.data(), 4, 2), C(c.data(), 3, 2);
  A = Eigen::MatrixXd::Random(3, 4);
  B = Eigen::MatrixXd::Random(4, 2);
  SmallProduct(A, B, &C);
  CHECK((C - A * B).norm() < 1e-15);
  Eigen::Map<Eigen::MatrixXd> Bt(d.data(), 2, 4);
  Bt = B.transpose();
  SmallProductTransposed(A, Bt, &C);
  CHECK((C - A * B).norm() < 1e-15);
  Eigen::Map<Eigen::MatrixXd> At(a.data(), 4, 3);  // the same numbers seen as 4 x 3
  std::vector<double> e(6);
  Eigen::Map<Eigen::MatrixXd> E(e.data(), 3, 2);
  SmallTransposedProduct(At, B, &E);
  CHECK((E - At.transpose() * B).norm() < 1e-15);

  std::vector<double> p(16), q(4), scratch;
  Eigen::Map<Eigen::MatrixXd> P(p.data(), 4, 4), Q(q.data(), 2, 2);
  P = Symmetric(4, 21);
  QuadraticForm(B, P, &scratch, &Q);
  CHECK((Q - B.transpose() * P * B).norm() < 1e-13);
  CHECK(Q(0, 1) == Q(1, 0));

  const Eigen::Matrix3d Sm = Symmetric(3, 23);
  const Eigen::MatrixXd L = Sm.llt().matrixL();
  std::vector<double> f(6), z(3);
  Eigen::Map<Eigen::MatrixXd> F(f.data(), 2, 3);
  Eigen::Map<Eigen::VectorXd> Z(z.data(), 3);
  F = Eigen::MatrixXd::Random(2, 3);
  Z = Eigen::Vector3d(0.5, -1, 2);
  const Eigen::MatrixXd F0 = F;
  const Eigen::VectorXd Z0 = Z;
  ForwardSubstitute(L, &F, &Z);
  CHECK((F * L.transpose() - F0).norm() < 1e-14);
  CHECK((L * Z - Z0).norm() < 1e-14);
}

// Seven columns: one group of four and a remainder of three. In place, the columns are picked
// out of a larger matrix in any order and a block of their rows is combined, as the gain reads
// P(S, a) from the covariance a run at a time.
TEST_CASE("small blas: columns combined, packed and in place", "[kernel]") {
  std::srand(29);
  const Eigen::MatrixXd P = Eigen::MatrixXd::Random(9, 7);
  const Eigen::VectorXd c = Eigen::VectorXd::Random(7);
  Eigen::VectorXd out(9);
  CombineColumns(P.data(), 9, 7, c.data(), out.data());
  CHECK((out - P * c).norm() < 1e-14);

  const Eigen::MatrixXd big = Eigen::MatrixXd::Random(12, 12);
  const std::vector<int> picked = {10, 2, 7, 3, 0, 11, 5};
  std::vector<const double*> columns;
  for (int j : picked) columns.push_back(big.data() + 12L * j);
  Eigen::VectorXd rows(5);
  rows.setConstant(NAN);  // every entry written
  CombineColumns(columns.data(), 4, 5, 7, c.data(), rows.data());
  Eigen::VectorXd expected = Eigen::VectorXd::Zero(5);
  for (int l = 0; l < 7; ++l) expected += c(l) * big.col(picked[l]).segment(4, 5);
  CHECK((rows - expected).norm() < 1e-14);
}

TEST_CASE("small blas: scratch grows and keeps its storage", "[kernel]") {
  std::vector<double> storage;
  Eigen::Map<Eigen::MatrixXd> M = Scratch(&storage, 3, 4);
  CHECK(storage.size() == 12);
  CHECK(M.data() == storage.data());
  Scratch(&storage, 2, 2);
  CHECK(storage.size() == 12);
  CHECK(ScratchVector(&storage, 20).size() == 20);
  CHECK(storage.size() == 20);
  CHECK(ScratchVector(&storage, 5).data() == storage.data());
}

}  // namespace
}  // namespace cfuse::internal
