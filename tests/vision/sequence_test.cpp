// The standard sequences (cfuse/vision/sequence.h) keep every constraint of the model, closed
// loops included, in every frame's pose.
#include "cfuse/vision/sequence.h"

#include <catch2/catch.hpp>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/kernel/evaluate.h"
#include "test_util.h"

namespace cfuse {
namespace {

TEST_CASE("sequence: a rendered sequence keeps the loop closed", "[vision]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/four-bar.yaml"));
  auto largest_equality = [&g](const Values& values) {
    double largest = 0;
    Eigen::VectorXd r;
    for (const Constraint& c : g.constraints) {
      EvaluateResidual(*c.residual, g.blocks, c.blocks, values, &r, nullptr);
      if (c.slack_block < 0) largest = std::max(largest, r.cwiseAbs().maxCoeff());
    }
    return largest;
  };
  const SequenceSpec spec = StandardSequence(g, "steady", 40);
  for (int i = 0; i < 40; i += 3) {
    CAPTURE(i);
    CHECK(largest_equality(SequencePose(g, spec, i)) < 1e-9);
  }
}

}  // namespace
}  // namespace cfuse
