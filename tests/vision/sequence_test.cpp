// The standard sequences (cfuse/vision/sequence.h) keep every constraint of the model, closed
// loops included, in every frame's pose.
#include "cfuse/vision/sequence.h"

#include <catch2/catch.hpp>

#include "cfuse/dsl/model_loader.h"
#include "constraints/largest_equality.h"
#include "test_util.h"

namespace cfuse {
namespace {

TEST_CASE("sequence: a rendered sequence keeps the loop closed", "[vision]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/four-bar.yaml"));
  const SequenceSpec spec = StandardSequence(g, "steady", 40);
  for (int i = 0; i < 40; i += 3) {
    CAPTURE(i);
    CHECK(testing::LargestEquality(g, SequencePose(g, spec, i)) < 1e-9);
  }
}

}  // namespace
}  // namespace cfuse
