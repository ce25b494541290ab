// The constraint-fusion estimator: agreement with the batch solver, redundancy and
// contradiction, covariance health over many updates, statistical consistency (NEES).
#include "cfuse/kernel/estimator.h"

#include <Eigen/Eigenvalues>
#include <catch2/catch.hpp>
#include <random>

#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/constraints/model_builder.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/kernel/batch_solver.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/measurements/point3.h"
#include "test_util.h"

namespace cfuse {
namespace {

std::vector<Factor> ConstraintFactors(const ConstraintGraph& g) {
  std::vector<Factor> factors;
  for (const Constraint& c : g.constraints) factors.push_back({c.residual, c.blocks, {}, c.name});
  return factors;
}

Factor PointMeasurement(const ConstraintGraph& g, int component, const Eigen::Vector3d& z,
                        const Eigen::Matrix3d& cov) {
  const Component& c = g.components[component];
  return {std::make_shared<Point3Residual>(z), {c.block}, cov, "measurement of " + c.name};
}

Eigen::Matrix3d RandomCovariance(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0, 1);
  Eigen::Matrix3d A;
  for (int i = 0; i < 9; ++i) A(i / 3, i % 3) = n(rng);
  return sigma * sigma * (A * A.transpose() / 3 + 0.1 * Eigen::Matrix3d::Identity());
}

Rigid3d RandomPose(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  return Rigid3d(Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized(),
                 Eigen::Vector3d(n(rng), n(rng), 2 + n(rng)));
}

// Points a, b, c, d under linear constraints, one of them redundant.
struct LinearProblem {
  LinearProblem() : builder("linear", "test") {
    for (const char* name : {"a", "b", "c", "d"})
      builder.AddPointComponent(name, Eigen::Vector3d::Zero(), {});
    std::string why;
    auto P = [&](const char* name) {
      return MakePointRef(builder.graph().components[builder.FindComponent(name)].block);
    };
    auto add = [&](const char* name, ExprPtr lhs, ExprPtr rhs) {
      builder.AddConstraint(name, ConstraintKind::kExpression, "test",
                            EqualityResidual::Create(lhs, rhs, builder.Context()), {});
    };
    const ExprPtr ab = MakeBinary(Expr::Op::kSub, P("a"), P("b"), &why);
    add("ab", ab, MakeVectorConstant({0.1, 0.02, -0.03}, Quantity::Length()));
    add("c_height",
        MakeCall(
            Function::kDot,
            {MakeBinary(Expr::Op::kSub, P("c"), P("a"), &why), MakeVectorConstant({0, 0, 1}, {})},
            &why),
        MakeConstant(0.05, Quantity::Length()));
    add("ab_x", MakeCall(Function::kDot, {ab, MakeVectorConstant({1, 0, 0}, {})}, &why),
        MakeConstant(0.1, Quantity::Length()));
    add("d_mid",
        MakeBinary(Expr::Op::kSub, MakeBinary(Expr::Op::kMul, MakeConstant(2, {}), P("d"), &why),
                   MakeBinary(Expr::Op::kAdd, P("b"), P("c"), &why), &why),
        MakeVectorConstant({0, 0, 0.01}, Quantity::Length()));
  }
  ModelBuilder builder;
};

TEST_CASE("estimator: on linear problems the fused result equals the batch solver to 1e-9",
          "[kernel]") {
  LinearProblem problem;
  const ConstraintGraph& g = problem.builder.graph();
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0, 0.3);
  std::vector<Factor> factors;
  for (int k = 0; k < 6; ++k) {
    const int comp = k % 4;
    factors.push_back(PointMeasurement(g, comp, Eigen::Vector3d(n(rng), n(rng), n(rng)),
                                       RandomCovariance(rng, 0.01)));
  }
  for (const Factor& f : ConstraintFactors(g)) factors.push_back(f);
  // Interleave: a measurement after the constraints too.
  factors.push_back(
      PointMeasurement(g, 2, Eigen::Vector3d(0.1, 0.2, 0.3), RandomCovariance(rng, 0.02)));

  GaussianState fused = MakePrior(g.blocks, g.nominal, PriorScale{});
  GaussianState batch = fused;
  const SequenceSummary s = FuseSequence(factors, &fused);
  // The first pass is exact here; a Gauss-Newton pass confirms that its step is nil (the
  // expression residuals do not declare themselves affine).
  CHECK(s.passes <= 2);
  CHECK(s.converged);
  CHECK(s.max_constraint_residual < 1e-12);
  // "ab_x" repeats a row of "ab": skipped, not inverted.
  CHECK(s.fusions[8].status == FusionSummary::Status::kRedundant);
  CHECK(s.fusions[6].status == FusionSummary::Status::kFused);

  const BatchSummary b = SolveBatch(factors, &batch);
  REQUIRE(b.converged);
  CHECK(b.max_constraint_residual < 1e-12);
  for (int i = 0; i < 4; ++i) {
    CHECK((fused.mean.points[i] - batch.mean.points[i]).norm() < 1e-9);
  }
  CHECK((fused.covariance - batch.covariance).cwiseAbs().maxCoeff() <
        1e-9 * batch.covariance.cwiseAbs().maxCoeff());
}

TEST_CASE("estimator: contradictory constraints are refused; the state is left as it was",
          "[kernel]") {
  ModelBuilder b("m", "test");
  const int a = b.AddPointComponent("a", {0, 0, 0}, {});
  const int c = b.AddPointComponent("c", {1, 0, 0}, {});
  std::string why;
  const ExprPtr diff = MakeBinary(Expr::Op::kSub, MakePointRef(b.graph().components[a].block),
                                  MakePointRef(b.graph().components[c].block), &why);
  b.AddConstraint("gap", ConstraintKind::kExpression, "test",
                  EqualityResidual::Create(
                      diff, MakeVectorConstant({0.1, 0, 0}, Quantity::Length()), b.Context()),
                  {});
  b.AddConstraint("other_gap", ConstraintKind::kExpression, "test",
                  EqualityResidual::Create(
                      diff, MakeVectorConstant({0.1, 0.001, 0}, Quantity::Length()), b.Context()),
                  {});
  const ConstraintGraph& g = b.graph();
  GaussianState state = MakePrior(g.blocks, g.nominal, PriorScale{});
  const std::vector<Factor> factors = ConstraintFactors(g);
  CHECK(Fuse(factors[0], &state).status == FusionSummary::Status::kFused);
  const GaussianState before = state;
  const FusionSummary s = Fuse(factors[1], &state);
  CHECK(s.status == FusionSummary::Status::kContradiction);
  CHECK(s.contradiction > 1e-5);
  CHECK(state.covariance == before.covariance);
  CHECK(state.mean.points[0] == before.mean.points[0]);
}

ConstraintGraph Lamp() { return LoadModel(testing::SourcePath("examples/lamp.yaml")); }

// The lamp at a random pose, measured with isotropic noise; `measured` gets the measured
// points as a Values.
std::vector<Factor> LampMeasurements(const ConstraintGraph& g, std::mt19937& rng, double sigma,
                                     Values* truth, Values* measured = nullptr) {
  const Rigid3d pose = RandomPose(rng);
  *truth = g.nominal;
  Values z_values = g.nominal;
  std::normal_distribution<double> n(0, sigma);
  std::vector<Factor> factors;
  for (size_t i = 0; i < g.components.size(); ++i) {
    const int index = g.blocks[g.components[i].block].index;
    Eigen::Vector3d& p = truth->points[index];
    p = pose * p;
    z_values.points[index] = p + Eigen::Vector3d(n(rng), n(rng), n(rng));
    factors.push_back(PointMeasurement(g, static_cast<int>(i), z_values.points[index],
                                       sigma * sigma * Eigen::Matrix3d::Identity()));
  }
  if (measured) *measured = z_values;
  return factors;
}

TEST_CASE(
    "estimator: the lamp's sequential fusion meets every constraint and matches the batch solver",
    "[kernel]") {
  const ConstraintGraph g = Lamp();
  std::mt19937 rng(11);
  Values truth, measured;
  std::vector<Factor> factors = LampMeasurements(g, rng, 0.002, &truth, &measured);
  for (const Factor& f : ConstraintFactors(g)) factors.push_back(f);
  GaussianState fused = MakePrior(g.blocks, g.nominal, PriorScale{});
  GaussianState batch = fused;
  const SequenceSummary s = FuseSequence(factors, &fused);
  CHECK(s.converged);
  CHECK(s.max_constraint_residual <= 1e-10);
  for (const FusionSummary& f : s.fusions) CHECK(f.status != FusionSummary::Status::kContradiction);
  // Gauss-Newton from the nominal geometry at the origin can fall into another configuration of
  // the linkage; start it where a batch solver would, at the measured points.
  const BatchSummary b = SolveBatch(factors, &batch, {}, &measured);
  REQUIRE(b.converged);
  CHECK(b.max_constraint_residual <= 1e-10);
  double worst = 0;
  for (size_t i = 0; i < fused.mean.points.size(); ++i) {
    worst = std::max(worst, (fused.mean.points[i] - batch.mean.points[i]).norm());
  }
  CHECK(worst < 1e-8);
  CHECK((fused.covariance - batch.covariance).cwiseAbs().maxCoeff() <
        1e-6 * batch.covariance.cwiseAbs().maxCoeff());
}

TEST_CASE("estimator: the covariance stays symmetric positive semidefinite over 5000 updates",
          "[kernel]") {
  const ConstraintGraph g = Lamp();
  std::mt19937 rng(5);
  Values truth;
  std::vector<Factor> factors = LampMeasurements(g, rng, 0.002, &truth);
  GaussianState state = MakePrior(g.blocks, g.nominal, PriorScale{});
  for (const Factor& f : factors) Fuse(f, &state);
  for (const Factor& f : ConstraintFactors(g))
    REQUIRE(Fuse(f, &state).status != FusionSummary::Status::kContradiction);
  std::uniform_int_distribution<int> pick(0, static_cast<int>(g.components.size()) - 1);
  std::normal_distribution<double> n(0, 0.002);
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  double first_worst = -1;
  for (int update = 1; update <= 5000; ++update) {
    const int i = pick(rng);
    const Eigen::Vector3d z = truth.points[g.blocks[g.components[i].block].index] +
                              Eigen::Vector3d(n(rng), n(rng), n(rng));
    Fuse(PointMeasurement(g, i, z, RandomCovariance(rng, 0.002)), &state);
    if (update % 500 == 0) {
      const Eigen::MatrixXd& P = state.covariance;
      CHECK((P - P.transpose()).cwiseAbs().maxCoeff() == 0.0);
      const Eigen::VectorXd eig = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P).eigenvalues();
      // Roundoff is relative to the largest variance the filter ever held, the prior's.
      INFO("eigenvalues in [" << eig.minCoeff() << ", " << eig.maxCoeff() << "]");
      CHECK(eig.minCoeff() >= -1e-16 * state.prior_variance.maxCoeff());
      // The constrained directions keep (numerically) zero variance.
      double worst = 0;
      for (const Constraint& c : g.constraints) {
        EvaluateResidual(*c.residual, g.blocks, c.blocks, state.mean, &r, &J);
        Eigen::MatrixXd Jfull = Eigen::MatrixXd::Zero(r.size(), state.dim());
        int col = 0;
        for (int b : c.blocks) {
          Jfull.middleCols(g.blocks[b].tangent_offset, 3) = J.middleCols(col, 3);
          col += 3;
        }
        worst = std::max(worst, (Jfull * P * Jfull.transpose()).cwiseAbs().maxCoeff());
      }
      // Along the constraints' normals at the current mean (not exactly those at which they were
      // fused, hence not zero) the variance stays small and does not grow.
      INFO("largest variance along a constraint's normal " << worst);
      CHECK(worst < 1e-2 * eig.maxCoeff());
      if (first_worst < 0) first_worst = worst;
      CHECK(worst <= first_worst);
    }
  }
  // Predictions from that state (the gates of interpretation and tracking) are exactly
  // symmetric too.
  for (const Factor& f : ConstraintFactors(g)) {
    const Prediction p = Predict(f, state);
    REQUIRE(p.valid);
    CHECK((p.covariance - p.covariance.transpose()).cwiseAbs().maxCoeff() == 0.0);
  }
}

TEST_CASE(
    "estimator: NEES of the lamp's points lies in its 99% chi-square interval over 200 trials",
    "[kernel]") {
  const ConstraintGraph g = Lamp();
  const std::vector<Factor> constraints = ConstraintFactors(g);
  double total = 0;
  int dof = 0;
  int better_than_measurements = 0;
  const int trials = 200;
  for (int trial = 0; trial < trials; ++trial) {
    std::mt19937 rng(1000 + trial);
    Values truth, measured;
    std::vector<Factor> factors = LampMeasurements(g, rng, 0.002, &truth, &measured);
    const double measurement_error = LocalCoordinates(g.blocks, truth, measured).squaredNorm();
    factors.insert(factors.end(), constraints.begin(), constraints.end());
    GaussianState state = MakePrior(g.blocks, g.nominal, PriorScale{});
    const SequenceSummary ss = FuseSequence(factors, &state);
    REQUIRE(ss.converged);
    const Eigen::VectorXd e = LocalCoordinates(g.blocks, truth, state.mean);
    // The covariance has rank 11 (the lamp's DOF): NEES on its range.
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(state.covariance);
    const Eigen::VectorXd& l = eigen.eigenvalues();
    double nees = 0;
    int rank = 0;
    for (int i = 0; i < l.size(); ++i) {
      if (l[i] <= 1e-9 * l.maxCoeff()) continue;
      const double proj = eigen.eigenvectors().col(i).dot(e);
      nees += proj * proj / l[i];
      ++rank;
    }
    CHECK(rank == 11);
    total += nees;
    dof += rank;
    better_than_measurements += e.squaredNorm() < measurement_error ? 1 : 0;
  }
  // Sum of NEES ~ chi-square with 200 x 11 = 2200 DOF: 99% interval by the Wilson-Hilferty
  // approximation, [2031.9, 2373.9].
  const double k = dof, z = 2.5758;
  const double lo = k * std::pow(1 - 2 / (9 * k) - z * std::sqrt(2 / (9 * k)), 3);
  const double hi = k * std::pow(1 - 2 / (9 * k) + z * std::sqrt(2 / (9 * k)), 3);
  INFO("total NEES " << total << " over " << dof << " DOF, interval [" << lo << ", " << hi << "]");
  CHECK(total > lo);
  CHECK(total < hi);
  // The constraints only add information: the estimate beats the raw measurements.
  CHECK(better_than_measurements == trials);
}

}  // namespace
}  // namespace cfuse
