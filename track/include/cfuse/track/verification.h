// Whether an estimate is the object: agreement along the whole visible outline, which a wrong
// pose cannot fake. A few matched edges fit a wrong pose as well as the right one (textured
// faces, a cluttered background and the model's own parallel edges offer lines wherever one
// looks), but a wrong pose rarely finds the strongest step around each of its edges on the edge
// itself. (The steps' signs are not asked for here: a face turning in the light changes them
// from one frame to the next; the evidence uses them where they have settled, edge_evidence.h.)
//
// At the estimate, every visible piece (hidden parts removed) is sampled every `step` px and
// searched along its normal as far as `wide_reach` px. A sample is
//  - supported when a step lies within its reach: 2.5 standard deviations of the estimate's edge
//  with the model's error, between
//    `min_reach` and `max_reach` px;
//  - dominated by its edge when the strongest such step within the wide reach lies within the
//    reach: texture and clutter put steps everywhere, but seldom the strongest one.
// Chance is measured, not assumed: the same support test at a place off the edge (just beyond
// the reach, either side in turn), in this frame's texture and clutter. The pose is verified
// when
//  - at least `min_share` of the samples are supported, and more than chance by `z` binomial
//    standard deviations (the difference of two counts);
//  - at least `min_dominant` of them are dominated by their edge;
//  - every component in view (`min_component_samples` or more) has at least
//    `min_component_share` of its samples supported, and more than the chance beside its own
//    edges by `component_z` standard deviations, not counting samples another part's edge
//    would explain: a lid whose edges find nothing, no more than the clutter it lies over, or
//    only its box's rim, is not seen, however well the box fits;
//  - the supported samples do not all lie on parallel edges (at most `max_parallel_share` within
//    20 degrees of one direction): a pose slid along a set of parallel edges keeps their support.
#pragma once

#include <string>
#include <vector>

#include "cfuse/track/edge_evidence.h"
#include "cfuse/track/edge_prediction.h"

namespace cfuse {

struct VerificationOptions {
  double step = 4;         // px between samples
  double min_reach = 1.5;  // px either side of the edge, at least
  double max_reach = 4;    // and at most
  double wide_reach = 12;  // px: where a sample's strongest step is looked for
  double min_share = 0.5;
  double min_dominant = 0.4;
  double z = 5;  // binomial standard deviations above chance
  double min_component_share = 0.3;
  int min_component_samples = 10;
  double component_z = 3;  // a part's support above the chance beside its edges, as `z`
  double max_parallel_share = 0.85;
};

// The test a refused estimate failed first.
enum class Refusal {
  kNone,
  kNoMatches,     // no set of matches passed the residual test (too few edges matched)
  kNoEdges,       // nothing of the model in view
  kShare,         // too little of the outline supported
  kChance,        // no more support on the edges than off them
  kDominance,     // the strongest steps lie off the edges
  kComponent,     // a part in view without support
  kParallel,      // the support on parallel edges only
  kTypical,       // far less agreement than the sequence's verified frames (tracker.h)
  kUndetermined,  // the visible edges' ends not known to max_position_sigma (tracker.h)
  kSpread,        // a part no better known than predicted in some direction (tracker.h)
  kOutdone,       // a better-supported pose left undetermined by its matches (tracker.h)
  kAmbiguous,     // another joint value or place explains the outline as well (tracker.h)
  kDepth,         // the faces' depth disagrees with a range sensor's (tracker.h)
};
const char* RefusalName(Refusal refusal);

struct Verification {
  bool verified = false;
  Refusal refusal = Refusal::kNone;
  int samples = 0, supported = 0;
  double share = 0;           // supported / samples
  double chance = 0;          // the share of the places off the edges supported
  double dominant_share = 0;  // samples dominated by their edge
  // Supported over supported and displaced samples (no step within the reach, but one within the
  // wide reach): what an occluder or a face without contrast takes away leaves it as it is, a
  // pose sliding off the object lowers it.
  double agreement = 0;
  // The least share of a component in view supported on its own (no other part's edge along).
  double least_component = 1;
  double parallel_share = 0;
  double mean_distance = 0;  // px, of the supporting steps from the estimate's edges
  // Their mean distance over their sample's reach: about 0.31 when the edges lie where the image
  // shows them (a Gaussian cut at 2.5 standard deviations), 0.5 when the steps fall anywhere in
  // the reach, as texture and clutter do.
  double spread = 0;
  // With a range sensor's frame: its samples on the faces in view, and the share of them within
  // DepthOptions::inlier_distance of their face (0 and 0 without one).
  int depth_samples = 0;
  double depth_share = 0;
  std::string why;  // when not verified: the test that failed
  // The step nearest each supported sample's edge, for EdgeAppearance::Record once the frame
  // is verified.
  struct Step {
    int edge;
    double t;
    float contrast;
  };
  std::vector<Step> steps;
};

// A model edge where the estimate projects it, hidden or not, with its component's block.
struct ModelLine {
  int block = -1;
  Eigen::Vector2d a, b;
};

// Verifies `edges` (predicted at the estimate, with its variances). `model`: every edge of the
// model at the estimate, hidden ones too; a part's support where another part's edge lies along
// its own (within the reach, within 15 degrees) is not the part's own: a lid shut on its box's
// rim finds all its steps on the rim, a lid standing open only its hinge's.
Verification VerifyOutline(const GrayView& image, const std::vector<EdgeModel>& edges,
                           const NormalSearchOptions& search,
                           const VerificationOptions& options,
                           const std::vector<ModelLine>& model = {});

// What a verified pose explains of the image: its outline's samples supported beyond what chance
// gives beside its edges. A lid found shut on the box's rim has as large a share of its outline
// supported as the lid standing open behind it, but explains less of the image; a pose slid by one
// of a model's repeated parts explains less than the right one.
double ExplainedEvidence(const Verification& verification);

// Records a verified frame's steps in `appearance` and commits them.
void Remember(const Verification& verification, EdgeAppearance* appearance);

}  // namespace cfuse
