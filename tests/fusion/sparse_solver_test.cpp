// The sparse solver against the dense batch reference (batch_solver.h) on the example models,
// points and poses, joints, limits and closed loops: the same solution and the same covariance
// blocks; a repeated constraint left out; and on long chains a factor whose size grows linearly.
#include "cfuse/kernel/sparse_solver.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/constraints/model_builder.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/kernel/batch_solver.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/measurements/point3.h"
#include "test_util.h"

namespace cfuse {
namespace {

// Every feature point of every component measured at `world_from_model` times its nominal
// place, 1 mm noise; then every constraint. `truth` gets the nominal values moved.
std::vector<Factor> Measured(const ConstraintGraph& g, const Rigid3d& world_from_model,
                             std::mt19937& rng, Values* truth) {
  std::normal_distribution<double> n(0, 0.001);
  const Eigen::Matrix3d noise = 1e-6 * Eigen::Matrix3d::Identity();
  *truth = g.nominal;
  for (Rigid3d& pose : truth->poses) pose = world_from_model * pose;
  for (Eigen::Vector3d& p : truth->points) p = world_from_model * p;
  std::vector<Factor> factors;
  for (const Component& c : g.components) {
    const Block& b = g.blocks[c.block];
    const auto e = [&] { return Eigen::Vector3d(n(rng), n(rng), n(rng)); };
    if (!c.rigid) {
      factors.push_back({std::make_shared<Point3Residual>(truth->points[b.index] + e()),
                         {c.block},
                         noise,
                         c.name});
      continue;
    }
    for (const FeaturePoint& f : c.points) {
      const Eigen::Vector3d z = truth->poses[b.index] * f.position + e();
      factors.push_back(
          {std::make_shared<Point3Residual>(f.position, z), {c.block}, noise, c.name});
    }
  }
  for (const Constraint& c : g.constraints) factors.push_back({c.residual, c.blocks, {}, c.name});
  return factors;
}

std::vector<std::pair<int, int>> AllPairs(int blocks) {
  std::vector<std::pair<int, int>> pairs;
  for (int a = 0; a < blocks; ++a) {
    for (int b = a + 1; b < blocks; ++b) pairs.emplace_back(a, b);
  }
  return pairs;
}

// Solves with both and compares the solutions and every block of the covariance. An
// inequality's slack λ enters as λ² only: ±λ are the same solution, and the two solvers may
// end at either, so slacks are compared by magnitude and their covariances not at all.
void CheckAgainstBatch(const ConstraintGraph& g, const std::vector<Factor>& factors,
                       const Values& start) {
  GaussianState batch = MakePrior(g.blocks, g.nominal, PriorScale{});
  const BatchSummary b = SolveBatch(factors, &batch, {}, &start);
  INFO("batch: " << b.iterations << " iterations, constraints to " << b.max_constraint_residual);
  REQUIRE(b.converged);
  CHECK(b.max_constraint_residual < 1e-10);
  SparseEstimate sparse;
  SparseOptions strict;  // the reference's criterion, so that both take the same iterations
  strict.settled_fraction = 0;
  const SparseSummary s =
      SolveSparse(factors, g.blocks, g.nominal, PriorVariance(g.blocks, PriorScale{}),
                  AllPairs(static_cast<int>(g.blocks.size())), &sparse, strict, &start);
  INFO("sparse: " << s.iterations << " iterations, constraints to " << s.max_constraint_residual);
  REQUIRE(s.converged);
  CHECK(s.iterations == b.iterations);
  CHECK(s.max_constraint_residual < 1e-10);
  double worst_mean = 0, worst = 0, scale = 0;
  for (size_t a = 0; a < g.blocks.size(); ++a) {
    const Block& ba = g.blocks[a];
    if (ba.kind == BlockKind::kSlack) {
      worst_mean = std::max(worst_mean, std::abs(std::abs(sparse.mean.slacks[ba.index]) -
                                                 std::abs(batch.mean.slacks[ba.index])));
      continue;
    }
    Eigen::VectorXd d(TangentDim(ba.kind));
    LocalCoordinatesOfBlock(ba, batch.mean, sparse.mean, d.data());
    worst_mean = std::max(worst_mean, d.lpNorm<Eigen::Infinity>());
    for (size_t c = 0; c < g.blocks.size(); ++c) {
      const Block& bc = g.blocks[c];
      if (bc.kind == BlockKind::kSlack) continue;
      const Eigen::MatrixXd reference = batch.covariance.block(
          ba.tangent_offset, bc.tangent_offset, TangentDim(ba.kind), TangentDim(bc.kind));
      scale = std::max(scale, reference.cwiseAbs().maxCoeff());
      worst =
          std::max(worst, (sparse.Covariance(static_cast<int>(a), static_cast<int>(c)) - reference)
                              .cwiseAbs()
                              .maxCoeff());
    }
  }
  INFO(g.name << ": worst covariance difference " << worst << " of " << scale);
  CHECK(worst_mean < 1e-9);
  CHECK(worst < 1e-7 * scale);
}

TEST_CASE("sparse solver: the batch solver's answer and covariance on the example models",
          "[kernel]") {
  std::mt19937 rng(21);
  const Rigid3d motion(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized())),
      Eigen::Vector3d(0.2, -0.1, 1.4));
  // Not the planar arm: plain Gauss-Newton creeps on it (its slacks are not projected as the
  // filter's passes project them), and the reference stops unconverged after 100 iterations.
  for (const char* file :
       {"examples/lamp.yaml", "examples/hinged-box.yaml", "examples/four-bar.yaml",
        "examples/stewart-platform.yaml", "examples/cabinet.yaml"}) {
    const ConstraintGraph g = LoadModel(testing::SourcePath(file));
    INFO(file);
    Values truth;
    const std::vector<Factor> factors = Measured(g, motion, rng, &truth);
    CheckAgainstBatch(g, factors, truth);
  }
}

// A chain of points at fixed distances, each measured.
ConstraintGraph Chain(int n) {
  ModelBuilder b("chain", "test");
  for (int i = 0; i < n; ++i) {
    b.AddPointComponent("p" + std::to_string(i), Eigen::Vector3d(0.1 * i, 0.02 * (i % 3), 0), {});
  }
  std::string why;
  const auto P = [&](int k) { return MakePointRef(b.graph().components[k].block); };
  for (int i = 0; i + 1 < n; ++i) {
    const double nominal = (b.graph().nominal.points[i] - b.graph().nominal.points[i + 1]).norm();
    b.AddConstraint(
        "d" + std::to_string(i), ConstraintKind::kDistanceEquality, "distance ==",
        EqualityResidual::Create(MakeCall(Function::kDistance, {P(i), P(i + 1)}, &why),
                                 MakeConstant(nominal, Quantity::Length()), b.Context()),
        {});
  }
  return std::move(b).Build();
}

TEST_CASE("sparse solver: a repeated constraint is left out, the answer unchanged", "[kernel]") {
  const ConstraintGraph g = Chain(12);
  std::mt19937 rng(4);
  Values truth;
  std::vector<Factor> factors = Measured(g, Rigid3d(), rng, &truth);
  CheckAgainstBatch(g, factors, truth);
  SparseEstimate once, twice;
  const SparseSummary a =
      SolveSparse(factors, g.blocks, g.nominal, PriorVariance(g.blocks, PriorScale{}), {}, &once);
  factors.push_back(factors.back());  // the last distance again
  const SparseSummary b =
      SolveSparse(factors, g.blocks, g.nominal, PriorVariance(g.blocks, PriorScale{}), {}, &twice);
  REQUIRE(a.converged);
  REQUIRE(b.converged);
  CHECK(a.dependent_rows == 0);
  CHECK(b.dependent_rows == 1);
  CHECK(LocalCoordinates(g.blocks, once.mean, twice.mean).lpNorm<Eigen::Infinity>() < 1e-12);
  for (int k = 0; k < 12; ++k) {
    CHECK((once.Covariance(k, k) - twice.Covariance(k, k)).cwiseAbs().maxCoeff() < 1e-15);
  }
  CHECK_FALSE(twice.HasCovariance(0, 1));
  CHECK_THROWS_AS(twice.Covariance(0, 1), InternalError);

  // Stopped once settled (the default) rather than at a step of 1e-13: the same answer far
  // inside the noise (1 mm).
  SparseOptions strict;
  strict.settled_fraction = 0;
  SparseEstimate reference;
  const SparseSummary c = SolveSparse(
      factors, g.blocks, g.nominal, PriorVariance(g.blocks, PriorScale{}), {}, &reference, strict);
  REQUIRE(c.converged);
  CHECK(b.iterations < c.iterations);
  CHECK(LocalCoordinates(g.blocks, reference.mean, twice.mean).lpNorm<Eigen::Infinity>() < 1e-7);
}

TEST_CASE("sparse solver: a measurement that is not finite fails the factorisation, said",
          "[kernel]") {
  const ConstraintGraph g = Chain(4);
  std::mt19937 rng(6);
  Values truth;
  std::vector<Factor> factors = Measured(g, Rigid3d(), rng, &truth);
  factors[1].residual = std::make_shared<Point3Residual>(Eigen::Vector3d(NAN, 0, 0));
  SparseEstimate estimate;
  const SparseSummary s = SolveSparse(factors, g.blocks, g.nominal,
                                      PriorVariance(g.blocks, PriorScale{}), {}, &estimate);
  CHECK_FALSE(s.factorized);
  CHECK_FALSE(s.converged);
  CHECK(s.iterations == 0);
  CHECK(estimate.mean.points[0] == g.nominal.points[0]);
  CHECK(estimate.Covariance(0, 0).size() == 0);
}

TEST_CASE("sparse solver: a chain's factor grows linearly with its length", "[kernel]") {
  std::mt19937 rng(5);
  long nonzeros[2] = {0, 0};
  int k = 0;
  for (int n : {1000, 2000}) {
    const ConstraintGraph g = Chain(n);
    Values truth;
    const std::vector<Factor> factors = Measured(g, Rigid3d(), rng, &truth);
    std::vector<std::pair<int, int>> neighbours;
    for (int i = 0; i + 1 < n; ++i) neighbours.emplace_back(i, i + 1);
    SparseEstimate estimate;
    const SparseSummary s = SolveSparse(
        factors, g.blocks, g.nominal, PriorVariance(g.blocks, PriorScale{}), neighbours, &estimate);
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
