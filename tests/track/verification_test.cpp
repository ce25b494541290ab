// VerifyOutline on single rendered frames of the hinged box: what a pose needs to be taken for
// the object, and what the other parts' edges take away from a part's support.
#include "cfuse/track/verification.h"

#include <catch2/catch.hpp>

#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/geometry/model_edges.h"
#include "cfuse/kernel/estimator.h"
#include "cfuse/vision/render.h"
#include "cfuse/vision/sequence.h"
#include "test_util.h"

namespace cfuse {
namespace {

// The hinged box where the steady sequence has it at frame 0, its lid at `hinge` (rad).
Values BoxWithLid(const ConstraintGraph& graph, double hinge) {
  const Values at = SequencePose(graph, StandardSequence(graph, "steady", 2), 0);
  Values v = ForwardKinematics(graph, {{"hinge", hinge}});
  const int box = graph.blocks[graph.components[0].block].index;
  const Rigid3d world_from_nominal = at.poses[box] * v.poses[box].Inverse();
  for (Rigid3d& pose : v.poses) pose = world_from_nominal * pose;
  return v;
}

std::vector<EdgeModel> Predicted(const ConstraintGraph& graph, const Values& values) {
  const GaussianState state = MakePrior(graph.blocks, values, PriorScale{1e-4, 1e-4, 1e-4});
  return PredictEdges(graph, ModelEdges(graph), state, StandardCamera(),
                      Visibility{0.17, 6, true}, 0.5, 12);
}

std::vector<ModelLine> Lines(const ConstraintGraph& graph, const Values& values) {
  const std::vector<ModelEdge> edges = ModelEdges(graph);
  std::vector<ModelLine> out;
  for (const ProjectedEdge& p :
       VisibleEdges(graph, edges, values, StandardCamera())) {
    out.push_back({graph.components[edges[p.edge].component].block, p.a, p.b});
  }
  return out;
}

TEST_CASE("verification: what a pose explains is its supported samples less chance's share",
          "[verification]") {
  Verification v;
  v.samples = 200;
  v.supported = 150;
  v.chance = 0.1;
  CHECK(ExplainedEvidence(v) == Approx(130));
  // As many samples supported as chance gives: nothing explained.
  v.supported = 20;
  CHECK(ExplainedEvidence(v) == Approx(0).margin(1e-12));
}

TEST_CASE("verification: a lid shut on the rim is not seen on its own", "[verification]") {
  const ConstraintGraph graph =
      LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  const Values open = BoxWithLid(graph, 60 * M_PI / 180);
  const Rendering r = Render(graph, open, StandardCamera());
  const GrayView image{r.pixels.data(), r.width, r.height, r.width};
  const NormalSearchOptions search;
  const VerificationOptions options;
  // The truth is verified, the other part's edges along its own or not.
  const Verification truth =
      VerifyOutline(image, Predicted(graph, open), search, options, Lines(graph, open));
  CHECK(truth.verified);
  CHECK(truth.least_component > 0.5);
  const Values shut = BoxWithLid(graph, 0);
  const Verification alone = VerifyOutline(image, Predicted(graph, shut), search, options);
  const Verification seen =
      VerifyOutline(image, Predicted(graph, shut), search, options, Lines(graph, shut));
  // The lid shut on the box, in an image where it stands open at 60 degrees: the box's rim
  // gives its outline the support the whole outline needs, ...
  CHECK(alone.verified);
  CHECK(alone.share > 0.7);
  // ... but none of it is the lid's own: the box's edges lie along it.
  CHECK_FALSE(seen.verified);
  CHECK(seen.refusal == Refusal::kComponent);
  CHECK(seen.least_component < 0.1);
}

}  // namespace
}  // namespace cfuse
