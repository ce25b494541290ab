// Closed chains everywhere a configuration is made: forward kinematics closing a loop with the
// given joints held, sampling on the constraint surface, and joints not given at the model's own
// `position` (rendered sequences: tests/vision/sequence_test.cpp).
#include <catch2/catch.hpp>
#include <cmath>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/interp/solve.h"
#include "constraints/largest_equality.h"
#include "test_util.h"

namespace cfuse {
namespace {

using testing::LargestEquality;

ConstraintGraph FourBar() { return LoadModel(testing::SourcePath("examples/four-bar.yaml")); }

TEST_CASE("closed chains: forward kinematics leaves the loop open, CloseLoops closes it",
          "[interp]") {
  const ConstraintGraph g = FourBar();
  const std::map<std::string, double> q = CompleteJointValues(g, {{"crank_pivot", 2.0, {}}});
  Values values = ForwardKinematics(g, q);
  CHECK(LargestEquality(g, values) > 1e-3);  // the coupler and rocker at their nominal angles
  REQUIRE(CloseLoops(g, {{"crank_pivot", 2.0}}, ModelExtent(g), false, &values));
  CHECK(LargestEquality(g, values) < 1e-10);
  CHECK(JointValues(g, values)[g.FindJoint("crank_pivot")] == Approx(2.0).margin(1e-9));  // held
  // Two joints of a one-DOF loop held at values that do not agree: no configuration, and the
  // values are left as they were.
  Values open = ForwardKinematics(g, q);
  const Values before = open;
  CHECK_FALSE(CloseLoops(g, {{"crank_pivot", 2.0}, {"rocker_pivot", 0.0}}, ModelExtent(g), false,
                         &open));
  CHECK(open.poses[2].translation == before.poses[2].translation);
}

TEST_CASE("closed chains: joints not given are at the model's position", "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  const std::map<std::string, double> q = CompleteJointValues(g, {});
  CHECK(q.at("hinge") == Approx(35 * M_PI / 180));
}

TEST_CASE("closed chains: joint samples of a closed linkage meet every constraint", "[interp]") {
  for (const char* file : {"examples/four-bar.yaml", "examples/folding-ruler.yaml"}) {
    CAPTURE(file);
    const ConstraintGraph g = LoadModel(testing::SourcePath(file));
    for (unsigned seed = 1; seed <= 30; ++seed) {
      CAPTURE(seed);
      SimulateOptions options;
      options.seed = seed;
      options.sample_joints = true;
      options.labels = true;
      const Simulation sim = Simulate(g, options);
      Eigen::VectorXd r;
      EvaluateConstraints(g, sim.truth, &r, nullptr);
      CHECK(r.cwiseAbs().maxCoeff() < 1e-9);
    }
  }
}

// A Stewart platform's freedom is in its legs' ranges, not in joints: "sample the joints" still
// moves its top plate relative to the base, inside every range.
TEST_CASE("closed chains: a model without joint variables is sampled off its nominal geometry",
          "[interp]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/stewart-platform.yaml"));
  const int base = g.FindComponent("base"), top = g.FindComponent("top");
  for (unsigned seed = 1; seed <= 5; ++seed) {
    CAPTURE(seed);
    SimulateOptions options;
    options.seed = seed;
    options.sample_joints = true;
    const Simulation sim = Simulate(g, options);
    const Rigid3d& world_from_base = sim.truth.poses[g.blocks[g.components[base].block].index];
    const Rigid3d& world_from_top = sim.truth.poses[g.blocks[g.components[top].block].index];
    // At the nominal geometry the two frames coincide.
    CHECK((world_from_base.Inverse() * world_from_top).translation.norm() > 1e-3);
    Eigen::VectorXd r;
    EvaluateConstraints(g, sim.truth, &r, nullptr);
    CHECK(r.cwiseAbs().maxCoeff() < 1e-9);
  }
}

}  // namespace
}  // namespace cfuse
