// The solver with the forest's joints eliminated (interp/src/reduced_solver.h) against the
// sparse solver on the example models with joints: the same objective, so the same answer and
// covariance; a loop's closing constraint and the limits solved as rows, a redundant row left
// out; and what it refuses.
#include "reduced_solver.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <random>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/fit_analysis.h"
#include "cfuse/kernel/measurements/stacked.h"
#include "cfuse/kernel/sparse_solver.h"
#include "measured_model.h"
#include "test_util.h"

namespace cfuse::internal {
namespace {

const Rigid3d kMotion(
    Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized())),
    Eigen::Vector3d(0.2, -0.1, 1.4));

// Both solved from `start`, each to its own step tolerance; the means and every covariance
// entry compared (slacks by magnitude: ±λ are the same solution).
ReducedSummary CheckAgainstSparse(const ConstraintGraph& g, const std::vector<Factor>& factors,
                                  const Values& start) {
  const Eigen::VectorXd prior_variance = PriorVariance(g.blocks, PriorScale{});
  SparseOptions strict;
  strict.settled_fraction = 0;
  strict.full_covariance = true;
  SparseEstimate sparse;
  const SparseSummary s =
      SolveSparse(factors, g.blocks, g.nominal, prior_variance, {}, &sparse, strict, &start);
  REQUIRE(s.converged);
  ReducedOptions reduced_strict;
  reduced_strict.settled_fraction = 0;
  ReducedEstimate reduced;
  const ReducedSummary r =
      SolveReduced(g, factors, g.nominal, prior_variance, &reduced, reduced_strict, &start);
  INFO("reduced: " << r.iterations << " iterations, " << r.parameters << " parameters, "
                   << r.constraint_rows << " rows, constraints to " << r.max_constraint_residual);
  REQUIRE(r.converged);
  CHECK(r.factorized);
  CHECK(r.parameters == ReducedParameters(g));  // counted as they are laid out
  CHECK(r.max_constraint_residual < 1e-10);
  const Eigen::MatrixXd& reference = sparse.full_covariance();
  REQUIRE(reduced.covariance.rows() == reference.rows());
  double worst_mean = 0, worst = 0;
  const double scale = reference.cwiseAbs().maxCoeff();
  for (const Block& a : g.blocks) {
    if (a.kind == BlockKind::kSlack) {
      worst_mean = std::max(worst_mean, std::abs(std::abs(reduced.mean.slacks[a.index]) -
                                                 std::abs(sparse.mean.slacks[a.index])));
      continue;
    }
    Eigen::VectorXd d(TangentDim(a.kind));
    LocalCoordinatesOfBlock(a, sparse.mean, reduced.mean, d.data());
    worst_mean = std::max(worst_mean, d.lpNorm<Eigen::Infinity>());
    for (const Block& b : g.blocks) {
      if (b.kind == BlockKind::kSlack) continue;
      const auto block = [&](const Eigen::MatrixXd& P) {
        return P.block(a.tangent_offset, b.tangent_offset, TangentDim(a.kind), TangentDim(b.kind));
      };
      worst = std::max(worst, (block(reduced.covariance) - block(reference)).cwiseAbs().maxCoeff());
    }
  }
  INFO(g.name << ": means " << worst_mean << " apart, covariances " << worst << " of " << scale);
  CHECK(worst_mean < 1e-9);
  CHECK(worst < 1e-7 * scale);
  return r;
}

TEST_CASE("reduced solver: the sparse solver's answer and covariance on the models with joints",
          "[interp]") {
  std::mt19937 rng(21);
  // The planar arm too: Gauss-Newton on its joint angles converges where on its poses it
  // creeps, so the sparse solver, strict, is checked at its own (slow) convergence.
  for (const char* file : {"examples/hinged-box.yaml", "examples/cabinet.yaml",
                           "examples/folding-ruler.yaml", "examples/scissors.yaml"}) {
    const ConstraintGraph g = LoadModel(testing::SourcePath(file));
    INFO(file);
    REQUIRE(ReducedUnsupported(g, {}).empty());
    Values truth;
    const std::vector<Factor> factors = testing::MeasureEveryPoint(g, kMotion, rng, &truth);
    const ReducedSummary r = CheckAgainstSparse(g, factors, truth);
    // A pose and five joint rows per link against one angle: fewer parameters than the state.
    CHECK(r.parameters < g.tangent_dim());
  }
}

// Each component's markers stacked in twos, as Solve stacks them, with noise correlated
// within each marker and, in `coupled`, between the two: the whitening follows the noise's
// blocks (treating coupled markers as independent would move the answer).
TEST_CASE("reduced solver: stacked measurements whitened by their noise's blocks", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/cabinet.yaml"));
  for (const bool coupled : {false, true}) {
    INFO((coupled ? "coupled" : "independent") << " markers");
    std::mt19937 rng(4);
    Values truth;
    const std::vector<Factor> single = testing::MeasureEveryPoint(g, kMotion, rng, &truth);
    Eigen::Matrix3d within;
    within << 1.0, 0.3, -0.2, 0.3, 2.0, 0.1, -0.2, 0.1, 0.5;
    std::vector<Factor> factors;
    for (size_t i = 0; i < single.size(); ++i) {
      const Factor& f = single[i];
      const bool pair = !f.is_constraint() && i + 1 < single.size() &&
                        !single[i + 1].is_constraint() && single[i + 1].blocks == f.blocks;
      if (!pair) {
        factors.push_back(f);
        continue;
      }
      Eigen::MatrixXd noise = Eigen::MatrixXd::Zero(6, 6);
      noise.topLeftCorner<3, 3>() = 1e-6 * within;
      noise.bottomRightCorner<3, 3>() = 2e-6 * within;
      if (coupled) {
        noise.topRightCorner<3, 3>() = 0.2e-6 * Eigen::Matrix3d::Identity();
        noise.bottomLeftCorner<3, 3>() = 0.2e-6 * Eigen::Matrix3d::Identity();
      }
      factors.push_back(
          {std::make_shared<StackedResidual>(std::vector<std::shared_ptr<const ResidualFunction>>{
               single[i].residual, single[i + 1].residual}),
           f.blocks, noise, f.name});
      ++i;
    }
    CheckAgainstSparse(g, factors, truth);
  }
}

TEST_CASE("reduced solver: a loop's closing constraint is solved as rows, a repeated one left out",
          "[interp]") {
  // The four-bar's joints form a tree; `coupler.end == rocker.pin` closes the loop (two rows:
  // the model keeps the two its joints do not imply); the crank's limit goes with its slack.
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/four-bar.yaml"));
  std::mt19937 rng(3);
  Values truth;
  std::vector<Factor> factors = testing::MeasureEveryPoint(g, kMotion, rng, &truth);
  const ReducedSummary r = CheckAgainstSparse(g, factors, truth);
  CHECK(r.constraint_rows == 2);
  CHECK(r.eliminated_slacks == 1);
  CHECK(r.dependent_rows == 0);
  // The loop given twice: the copy's rows are combinations of the original's.
  const Constraint& loop = g.constraints[g.FindConstraint("loop")];
  factors.push_back({loop.residual, loop.blocks, {}, "loop again"});
  const ReducedSummary twice = CheckAgainstSparse(g, factors, truth);
  CHECK(twice.constraint_rows == 2 + 2);
  CHECK(twice.dependent_rows == 2);
}

// After each step an inequality's slack is put back on its row by Newton's method on λ alone,
// so no iteration is spent only to close it: from the truth, one step to the noisy answer and
// one that finds it settled, with the limits' rows held to a thousandth of the tolerance
// (the step's linearisation alone leaves them off by the square of λ's step, above it).
TEST_CASE("reduced solver: a limit's slack costs no iteration of its own", "[interp]") {
  std::mt19937 rng(17);
  for (const char* file : {"examples/hinged-box.yaml", "examples/cabinet.yaml"}) {
    const ConstraintGraph g = LoadModel(testing::SourcePath(file));
    INFO(file);
    for (int trial = 0; trial < 10; ++trial) {
      Values truth;
      const std::vector<Factor> factors = testing::MeasureEveryPoint(g, kMotion, rng, &truth);
      ReducedEstimate estimate;
      const ReducedOptions options;
      const ReducedSummary r = SolveReduced(
          g, factors, g.nominal, PriorVariance(g.blocks, PriorScale{}), &estimate, options, &truth);
      INFO("trial " << trial << ": " << r.iterations << " iterations, constraints to "
                    << r.max_constraint_residual);
      REQUIRE(r.converged);
      CHECK(r.eliminated_slacks > 0);
      CHECK(r.iterations == 2);
      CHECK(r.max_constraint_residual <= 1e-3 * options.constraint_tolerance);
    }
  }
}

TEST_CASE("reduced solver: what it does not take", "[interp]") {
  const ConstraintGraph lamp = LoadModel(testing::SourcePath("examples/lamp.yaml"));
  CHECK(ReducedUnsupported(lamp, {}) == "the model has no joints");
  CHECK(ReducedParameters(lamp) == 0);
  const ConstraintGraph box = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  CHECK(ReducedParameters(box) == 6 + 1);  // the box's pose and the hinge
  // A measurement whose noise is not positive definite: no factorisation, no covariance.
  std::mt19937 rng(5);
  Values truth;
  std::vector<Factor> factors = testing::MeasureEveryPoint(box, kMotion, rng, &truth);
  factors.front().noise.setZero();
  ReducedEstimate estimate;
  const ReducedSummary s = SolveReduced(
      box, factors, box.nominal, PriorVariance(box.blocks, PriorScale{}), &estimate, {}, &truth);
  CHECK_FALSE(s.factorized);
  CHECK_FALSE(s.converged);
  CHECK(estimate.covariance.size() == 0);
  // What it does not take, it says, and leaves the estimate as it was: a model without joints,
  // and a forest of more parameters than it is allowed.
  ReducedEstimate untouched;
  untouched.analysed = true;
  const ReducedSummary no_joints =
      SolveReduced(lamp, {}, lamp.nominal, PriorVariance(lamp.blocks, PriorScale{}), &untouched);
  CHECK(no_joints.unsupported == "the model has no joints");
  CHECK_FALSE(no_joints.converged);
  factors = testing::MeasureEveryPoint(box, kMotion, rng, &truth);
  ReducedOptions small;
  small.max_parameters = 6;
  const ReducedSummary too_many =
      SolveReduced(box, factors, box.nominal, PriorVariance(box.blocks, PriorScale{}), &untouched,
                   small, &truth);
  CHECK(too_many.unsupported == "7 parameters, more than 6");
  CHECK(too_many.iterations == 0);
  CHECK(untouched.analysed);
  CHECK(untouched.mean.poses.empty());
  small.max_parameters = 7;
  CHECK(SolveReduced(box, factors, box.nominal, PriorVariance(box.blocks, PriorScale{}), &untouched,
                     small, &truth)
            .unsupported.empty());
}

// The fit and the counts on the parameters are AnalyseFit's on the whole state, at the reduced
// answer; where the measurements leave a direction free, AnalyseFit answers (it names them).
TEST_CASE("reduced solver: the fit analysis on the parameters is the whole state's", "[interp]") {
  std::mt19937 rng(9);
  int freed = 0;
  for (const char* file :
       {"examples/hinged-box.yaml", "examples/cabinet.yaml", "examples/folding-ruler.yaml",
        "examples/four-bar.yaml", "examples/planar-arm.yaml"}) {
    const ConstraintGraph g = LoadModel(testing::SourcePath(file));
    INFO(file);
    Values truth;
    std::vector<Factor> factors = testing::MeasureEveryPoint(g, kMotion, rng, &truth);
    ReducedEstimate estimate;
    const double extent = 0.5;
    ReducedOptions analysed;
    analysed.fit_extent = extent;
    REQUIRE(SolveReduced(g, factors, g.nominal, PriorVariance(g.blocks, PriorScale{}), &estimate,
                         analysed, &truth)
                .converged);
    const FitAnalysis whole = AnalyseFit(factors, g.blocks, estimate.mean, extent);
    FitAnalysis reduced;
    REQUIRE(AnalyseReducedFit(g, factors, estimate.mean, extent, &reduced));
    CHECK(whole.free_directions.cols() == 0);
    CHECK(reduced.state_dim == whole.state_dim);
    CHECK(reduced.model_dof == whole.model_dof);
    CHECK(reduced.determined == whole.determined);
    CHECK(reduced.fit.residuals == whole.fit.residuals);
    CHECK(reduced.fit.dof == whole.fit.dof);
    CHECK(reduced.fit.chi2 == Approx(whole.fit.chi2).epsilon(1e-12));
    CHECK(reduced.fit.p_value == Approx(whole.fit.p_value).epsilon(1e-9));
    CHECK(reduced.analysed);
    // The solve's own analysis, on its last forward kinematics, is the same.
    REQUIRE(estimate.analysed);
    CHECK(estimate.analysis.determined == reduced.determined);
    CHECK(estimate.analysis.model_dof == reduced.model_dof);
    CHECK(estimate.analysis.fit.dof == reduced.fit.dof);
    CHECK(estimate.analysis.fit.chi2 == Approx(reduced.fit.chi2).epsilon(1e-12));

    // The last component's measurements left out: where that frees its joint, AnalyseFit answers.
    const int last = g.components.back().block;
    factors.erase(
        std::remove_if(factors.begin(), factors.end(),
                       [&](const Factor& f) { return !f.is_constraint() && f.blocks[0] == last; }),
        factors.end());
    // (Where a loop or the other links still determine it, both say so.)
    const FitAnalysis partial = AnalyseFit(factors, g.blocks, estimate.mean, extent);
    FitAnalysis counted;
    const bool answered = AnalyseReducedFit(g, factors, estimate.mean, extent, &counted);
    CHECK(answered == (partial.determined == partial.model_dof));
    if (answered) {
      CHECK(counted.determined == partial.determined);
      CHECK(counted.fit.dof == partial.fit.dof);
    }
    freed += !answered;
  }
  CHECK(freed >= 3);
}

}  // namespace
}  // namespace cfuse::internal
