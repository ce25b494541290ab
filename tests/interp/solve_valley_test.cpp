// A long curved valley of the fit from one image (interp/src/solve_valley.cpp): named, its far
// end said, the covariance widened to cover it; and nothing changed where the fit is Gaussian.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <catch2/catch.hpp>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/interp/solve.h"
#include "test_util.h"

namespace cfuse {
namespace {

constexpr double kGate = 21.108;  // chi-square, 3 DOF, 0.9999: bench/answer_sweep's

// A rigid component's NEES against the truth, the larger of orientation (in the pose's chart,
// R <- R Exp(dθ)) and position.
double Nees(const ConstraintGraph& g, int component, const Values& truth, const Solution& s) {
  const Block& block = g.blocks[g.components[component].block];
  const Rigid3d& at = s.state.mean.poses[block.index];
  const Rigid3d& truly = truth.poses[block.index];
  const Eigen::AngleAxisd turn(truly.rotation.conjugate() * at.rotation);
  const Eigen::Vector3d rotation = turn.angle() * turn.axis();
  const Eigen::Vector3d position = at.translation - truly.translation;
  const int o = block.tangent_offset;
  return std::max(
      rotation.dot(s.state.covariance.block<3, 3>(o, o).ldlt().solve(rotation)),
      position.dot(s.state.covariance.block<3, 3>(o + 3, o + 3).ldlt().solve(position)));
}

Simulation SeenInOneImage(const ConstraintGraph& g, unsigned seed) {
  SimulateOptions so;
  so.seed = seed;
  so.sample_joints = true;
  so.labels = true;
  so.camera = testing::Pinhole();
  return Simulate(g, so);
}

// The Stewart platform seen in one image (bench/answer_sweep's seed 128): the top plate's fit
// has one minimum, 18 degrees of tilt from the truth, whose chi-square is only 16 above it. The
// local covariance is right to a few sigmas along each axis, but the valley curves on far beyond
// them: without the profile the truth lies far outside the reported covariance, a wrong answer
// said with confidence. With it, the valley is named and the covariance covers the truth.
TEST_CASE("solve valley: a plate's long curved valley of tilt is named and covered", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/stewart-platform.yaml"));
  const Simulation sim = SeenInOneImage(g, 128);
  const int top = 1;
  REQUIRE(g.components[top].name == "top");
  const Block& block = g.blocks[g.components[top].block];
  SolveOptions options;
  options.reject_outliers = true;
  SolveOptions local = options;
  local.profile_valleys = false;
  const Solution before = Solve(g, sim.measurements, local);
  REQUIRE(before.accepted());
  CHECK(before.valleys.empty());
  CHECK(Nees(g, top, sim.truth, before) > 2 * kGate);  // what the profile is for

  const Solution s = Solve(g, sim.measurements, options);
  REQUIRE(s.accepted());
  // The same answer, only its covariance widened.
  CHECK(s.state.mean.poses[block.index].translation.isApprox(
      before.state.mean.poses[block.index].translation, 1e-9));
  REQUIRE(s.valleys.size() == 1);
  CHECK(s.valleys[0].component == "top");
  // Inside the interval 6 or more sigmas of tilt away, where a Gaussian would put it at 36.
  const double sigma_max =
      std::sqrt(before.state.covariance.block<3, 3>(block.tangent_offset, block.tangent_offset)
                    .eigenvalues()
                    .real()
                    .maxCoeff());
  CHECK(std::max(s.valleys[0].towards_mirror, s.valleys[0].away) > 6 * sigma_max);
  CHECK(Nees(g, top, sim.truth, s) < kGate);
  // Every alternative fits, best first.
  for (size_t i = 0; i < s.alternatives.size(); ++i) {
    CHECK(s.alternatives[i].fit.p_value >= options.min_p_value);
    if (i > 0) CHECK(s.alternatives[i - 1].fit.chi2 <= s.alternatives[i].fit.chi2);
  }
  // Widened, never narrowed: what was added is positive semi-definite.
  const Eigen::MatrixXd added = s.state.covariance - before.state.covariance;
  CHECK(added.norm() > 0);
  CHECK(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(added).eigenvalues().minCoeff() >
        -1e-9 * added.norm());
}

// Where the fit is Gaussian along every tilt, nothing is named and nothing changes: the same
// platform in other poses, and the lamp, whose parts are far from planar.
TEST_CASE("solve valley: a Gaussian fit is left as it is", "[interp]") {
  for (const char* model : {"examples/stewart-platform.yaml", "examples/lamp.yaml"}) {
    const ConstraintGraph g = LoadModel(testing::SourcePath(model));
    for (const unsigned seed : {100u, 101u, 102u}) {
      CAPTURE(model, seed);
      const Simulation sim = SeenInOneImage(g, seed);
      SolveOptions options;
      SolveOptions local = options;
      local.profile_valleys = false;
      const Solution a = Solve(g, sim.measurements, local);
      const Solution b = Solve(g, sim.measurements, options);
      REQUIRE(b.accepted());
      CHECK(b.valleys.empty());
      CHECK(b.alternatives.size() == a.alternatives.size());
      CHECK(b.state.covariance.isApprox(a.state.covariance, 1e-12));
    }
  }
}

}  // namespace
}  // namespace cfuse
