// The kinematic forest (interp/src/kinematic_forest.h): which joints and constraints it holds
// under each rule, and its poses' derivative in the parameters against finite differences.
#include "kinematic_forest.h"

#include <catch2/catch.hpp>
#include <random>

#include "cfuse/dsl/model_loader.h"
#include "test_util.h"

namespace cfuse::internal {
namespace {

TEST_CASE("kinematic forest: the joints and constraints each rule holds", "[interp]") {
  const ConstraintGraph four_bar = LoadModel(testing::SourcePath("examples/four-bar.yaml"));
  Forest f;
  // The parametric form needs every constraint held: the loop's closing expression is not.
  CHECK_THAT(BuildForest(four_bar, ForestRules::kEveryConstraint, &f),
             Catch::Contains("constraint 'loop'") && Catch::Contains("cannot hold it"));
  REQUIRE(BuildForest(four_bar, ForestRules::kJointsFirst, &f).empty());
  CHECK(f.order.size() == 3);
  for (const Joint& j : four_bar.joints) {
    CHECK(f.held[j.constraint]);
    if (j.limit_constraint >= 0) CHECK_FALSE(f.held[j.limit_constraint]);
  }
  CHECK_FALSE(f.held[four_bar.FindConstraint("loop")]);
}

TEST_CASE("kinematic forest: the poses' derivative in the parameters, by finite differences",
          "[interp]") {
  for (const char* file : {"examples/folding-ruler.yaml", "examples/four-bar.yaml"}) {
    INFO(file);
    const ConstraintGraph g = LoadModel(testing::SourcePath(file));
    Forest f;
    REQUIRE(BuildForest(g, ForestRules::kJointsFirst, &f).empty());
    LayoutParameters(g, 1.0, 1.0, &f);
    const auto influence = Influences(g, f);
    std::mt19937 rng(7);
    std::normal_distribution<double> n(0, 0.5);
    Configuration x = FromPoses(g, f, g.nominal);
    Eigen::VectorXd d(f.size);
    for (int i = 0; i < f.size; ++i) d[i] = n(rng);
    Retract(g, f, d, &x);
    Values at = g.nominal, plus = g.nominal, minus = g.nominal;
    Eigen::MatrixXd G, unused;
    ComponentPoses(g, f, influence, x, &at, &G);
    REQUIRE(G.rows() == g.tangent_dim());
    REQUIRE(G.cols() == f.size);
    constexpr double h = 1e-6;
    double worst = 0;
    for (int k = 0; k < f.size; ++k) {
      Configuration xp = x, xm = x;
      Retract(g, f, h * Eigen::VectorXd::Unit(f.size, k), &xp);
      Retract(g, f, -h * Eigen::VectorXd::Unit(f.size, k), &xm);
      ComponentPoses(g, f, influence, xp, &plus, &unused);
      ComponentPoses(g, f, influence, xm, &minus, &unused);
      for (const Component& c : g.components) {
        const Block& b = g.blocks[c.block];
        Eigen::VectorXd dp(6), dm(6);
        LocalCoordinatesOfBlock(b, at, plus, dp.data());
        LocalCoordinatesOfBlock(b, at, minus, dm.data());
        const Eigen::VectorXd numeric = (dp - dm) / (2 * h);
        worst =
            std::max(worst, (numeric - G.block(b.tangent_offset, k, 6, 1)).cwiseAbs().maxCoeff());
      }
    }
    CHECK(worst < 1e-7);
  }
}

}  // namespace
}  // namespace cfuse::internal
