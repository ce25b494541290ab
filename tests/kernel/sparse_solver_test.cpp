// The sparse solver on chains of points held at fixed distances, each point measured: the batch
// reference's answer, a repeated constraint left out, a stop once settled as the filter's, a
// measurement that is not finite refused, asked-for covariances only, and a factor that grows
// linearly with the chain. (On the example models: tests/fusion/sparse_solver_test.cpp.)
#include "cfuse/kernel/sparse_solver.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "cfuse/kernel/batch_solver.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/measurements/point3.h"

namespace cfuse {
namespace {

// |a - b| - length.
class Distance : public AutoDiffResidual<Distance> {
 public:
  explicit Distance(double length)
      : AutoDiffResidual(1, {BlockKind::kPoint, BlockKind::kPoint}), length_(length) {}
  template <typename T>
  void Compute(std::span<const BlockState<T>> x, T* r) const {
    using std::sqrt;
    r[0] = sqrt((x[0].t - x[1].t).squaredNorm()) - T(length_);
  }
  std::string Describe(std::span<const std::string>) const override { return "distance"; }

 private:
  double length_;
};

// n points 0.1 m apart along a zigzag (the prior's mean), held at those distances, each measured
// with 1 mm noise at the same shape moved by 0.3 m; `start` gets the measured points.
struct Chain {
  Chain(int n, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0, 0.001);
    for (int i = 0; i < n; ++i) {
      blocks.push_back({BlockKind::kPoint, i, 3 * i, "p" + std::to_string(i)});
      nominal.points.emplace_back(0.1 * i, 0.02 * (i % 3), 0);
    }
    start = nominal;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d z = nominal.points[i] + Eigen::Vector3d(0.3, 0, 0) +
                                Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      start.points[i] = z;
      factors.push_back({std::make_shared<Point3Residual>(z),
                         {i},
                         1e-6 * Eigen::Matrix3d::Identity(),
                         blocks[i].name});
    }
    for (int i = 0; i + 1 < n; ++i) {
      const double length = (nominal.points[i] - nominal.points[i + 1]).norm();
      factors.push_back(
          {std::make_shared<Distance>(length), {i, i + 1}, {}, "d" + std::to_string(i)});
    }
    variance = PriorVariance(blocks, PriorScale{});
  }
  std::vector<Block> blocks;
  Values nominal, start;
  std::vector<Factor> factors;
  Eigen::VectorXd variance;
};

TEST_CASE("sparse solver: a chain as the batch solver solves it; a repeated constraint left out",
          "[kernel]") {
  Chain chain(12, 4);
  SparseOptions strict;  // the reference's criterion
  strict.settled_fraction = 0;
  SparseEstimate once, twice;
  const SparseSummary a = SolveSparse(chain.factors, chain.blocks, chain.nominal, chain.variance,
                                      {{3, 4}}, &once, strict, &chain.start);
  GaussianState batch = MakePrior(chain.blocks, chain.nominal, PriorScale{});
  REQUIRE(SolveBatch(chain.factors, &batch, {}, &chain.start).converged);
  REQUIRE(a.converged);
  CHECK(a.max_constraint_residual < 1e-12);
  CHECK(LocalCoordinates(chain.blocks, batch.mean, once.mean).lpNorm<Eigen::Infinity>() < 1e-12);
  const double scale = batch.covariance.cwiseAbs().maxCoeff();
  for (int k = 0; k < 12; ++k) {
    CHECK(
        (once.Covariance(k, k) - batch.covariance.block<3, 3>(3 * k, 3 * k)).cwiseAbs().maxCoeff() <
        1e-9 * scale);
  }
  CHECK((once.Covariance(4, 3) - batch.covariance.block<3, 3>(12, 9)).cwiseAbs().maxCoeff() <
        1e-9 * scale);

  chain.factors.push_back(chain.factors.back());  // the last distance again
  const SparseSummary b = SolveSparse(chain.factors, chain.blocks, chain.nominal, chain.variance,
                                      {}, &twice, strict, &chain.start);
  REQUIRE(b.converged);
  CHECK(a.dependent_rows == 0);
  CHECK(b.dependent_rows == 1);
  CHECK(LocalCoordinates(chain.blocks, once.mean, twice.mean).lpNorm<Eigen::Infinity>() < 1e-12);
  for (int k = 0; k < 12; ++k) {
    CHECK((once.Covariance(k, k) - twice.Covariance(k, k)).cwiseAbs().maxCoeff() < 1e-15);
  }
  // Only what was asked for.
  CHECK(once.HasCovariance(3, 4));
  CHECK_FALSE(twice.HasCovariance(3, 4));
  CHECK_THROWS_AS(twice.Covariance(3, 4), InternalError);
}

TEST_CASE("sparse solver: stopped once settled, the reference's answer far inside the noise",
          "[kernel]") {
  const Chain chain(30, 7);
  SparseOptions strict;
  strict.settled_fraction = 0;
  SparseEstimate settled, reference;
  const SparseSummary s = SolveSparse(chain.factors, chain.blocks, chain.nominal, chain.variance,
                                      {}, &settled, {}, &chain.start);
  const SparseSummary r = SolveSparse(chain.factors, chain.blocks, chain.nominal, chain.variance,
                                      {}, &reference, strict, &chain.start);
  REQUIRE(s.converged);
  REQUIRE(r.converged);
  CHECK(s.iterations < r.iterations);
  CHECK(s.max_constraint_residual < 1e-10);
  // 1 mm noise: a micrometre is a thousandth of it.
  CHECK(LocalCoordinates(chain.blocks, reference.mean, settled.mean).lpNorm<Eigen::Infinity>() <
        1e-6);
}

TEST_CASE("sparse solver: a measurement that is not finite fails the factorisation, said",
          "[kernel]") {
  Chain chain(4, 6);
  chain.factors[1].residual = std::make_shared<Point3Residual>(Eigen::Vector3d(NAN, 0, 0));
  SparseEstimate estimate;
  const SparseSummary s =
      SolveSparse(chain.factors, chain.blocks, chain.nominal, chain.variance, {}, &estimate);
  CHECK_FALSE(s.factorized);
  CHECK_FALSE(s.converged);
  CHECK(s.iterations == 0);
  CHECK(estimate.mean.points[0] == chain.nominal.points[0]);
  CHECK(estimate.Covariance(0, 0).size() == 0);
}

TEST_CASE("sparse solver: a chain's factor grows linearly with its length", "[kernel]") {
  long nonzeros[2] = {0, 0};
  int k = 0;
  for (int n : {1000, 2000}) {
    const Chain chain(n, 5);
    std::vector<std::pair<int, int>> neighbours;
    for (int i = 0; i + 1 < n; ++i) neighbours.emplace_back(i, i + 1);
    SparseEstimate estimate;
    const SparseSummary s = SolveSparse(chain.factors, chain.blocks, chain.nominal, chain.variance,
                                        neighbours, &estimate, {}, &chain.start);
    REQUIRE(s.converged);
    CHECK(s.max_constraint_residual < 1e-10);
    // A measured point is known to about its noise, less along the chain's constraints.
    for (int i = 0; i < n; ++i) {
      const double variance = estimate.Covariance(i, i).trace() / 3;
      REQUIRE(variance > 0);
      REQUIRE(variance <= 1e-6 * (1 + 1e-9));
    }
    nonzeros[k++] = s.factor_nonzeros;
  }
  INFO("factor entries " << nonzeros[0] << " and " << nonzeros[1]);
  CHECK(nonzeros[1] <= 2.05 * nonzeros[0]);
}

}  // namespace
}  // namespace cfuse
