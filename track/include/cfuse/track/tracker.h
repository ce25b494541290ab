// Model-based tracking through an image sequence (Lowe 1992), on the constraint kernel: each
// frame, the model's visible edges are predicted from the last frames, the image is searched
// for them, candidate image lines are matched to them by a best-first search over match sets
// ordered by Lowe's probabilities, the model's pose (every component's, joints and limits
// holding exactly) is estimated from the matches by the kernel's estimator with the prediction
// as its prior, and the estimate is verified along the model's whole visible outline.
//
// One frame:
//  1. Prediction. Every block moves on by the velocity of the last two verified frames (per
//     frame, in values.h's chart), carried at most `max_extrapolation` frames past the last
//     verified one. Its prior reaches `search_pixels` in the image for a still object, and
//     `motion_share` of the last frame's motion more for a moving one (the velocity's error is
//     the acceleration, which grows with the speed); the model's constraints are fused into it,
//     so that the prior lives on the model's own configurations (7 DOF for the hinged box).
//  2. Edges. The model's visible pieces at the prediction, hidden lines removed
//     (cfuse/geometry/model_edges.h), each with the variance of where the image shows it,
//     S = A P Aᵀ (cfuse/track/edge_prediction.h).
//  3. Evidence. Candidate image lines for each edge with Lowe's probabilities
//     (cfuse/track/edge_evidence.h): by default searched along the predicted edges' normals, only
//     around the predicted outline; or segments detected in the window the edges can reach.
//  4. Search. Lowe's best-first search over match sets with the residual test
//     (cfuse/track/match_search.h); a set that passes is extended and verified.
//  5. Verification (cfuse/track/verification.h): a grey-level step at the remembered polarity along
//     the whole visible outline, far beyond what chance gives in this frame, on every part in
//     view. The best verified set is the frame's estimate.
//  6. Recovery. With no set verified, the search range doubles and the frame is tried again,
//     at most `max_doublings` times. A frame still not verified is lost: its estimate is the
//     prediction, and the next frame predicts from the last verified ones (or from a set that
//     passed every test of the outline but left the pose undetermined: motion blur; unless a
//     limit, not the image, held one of its joints). After a
//     loss, every following frame is also searched from places around the last verified pose,
//     in rings that grow with the frames lost (re-acquisition), until the object is verified
//     again. A frame found only by doubling or re-acquisition broke with the motion so far:
//     its step is not taken for a velocity.
//  7. Settling. The first frame verified, and the first after a loss, is tracked again from
//     other places and joint values (TrackerOptions::settle_places), after a loss from where the
//     object was last verified too: a decisively better pose replaces it, an equally good one
//     with a joint or a part elsewhere refuses it as ambiguous.
//
// With a range sensor's frame (Track(image, depth)), each set that passes is refined with the
// sensor's points on the faces as well (cfuse/track/depth_evidence.h): they fix the depth and
// tilt that edges leave loose, the outline is then judged beside the faces' agreement with the
// sensor, and a frame whose faces the sensor did not see where the estimate puts them is
// refused.
//
// The estimate's prior is the prediction; an estimate far outside it (a start far off, a knock)
// is solved again with the prior widened, so that a wrong prediction does not pull it along
// what the edges leave loose (the depth) nor make its covariance claim what they do not show.
#pragma once

#include <optional>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/geometry/model_edges.h"
#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/track/depth_evidence.h"
#include "cfuse/track/edge_evidence.h"
#include "cfuse/track/match_search.h"
#include "cfuse/track/verification.h"
#include "cfuse/vision/segments.h"

namespace cfuse {

// Where edge evidence comes from (cfuse/track/edge_evidence.h).
enum class EdgeEvidence { kNormalSearch, kSegments };

struct TrackerOptions {
  EdgeEvidence evidence = EdgeEvidence::kNormalSearch;
  // Match sets tried per search range, for each component in view: a model of several parts
  // gets the branches its parts need.
  int max_branches = 5;
  int max_doublings = 2;       // of the search range, before a frame is lost
  // At a track's second frame (no velocity yet), the doubled range is tried even when the first
  // verified, and kept when its outline's supported share is this many times the first's (0:
  // not tried).
  double unknown_motion_share = 1.05;
  int max_extrapolation = 4;   // frames the velocity is carried on past the last verified
  double max_lost_growth = 4;  // of the search range after lost frames (1 + frames lost)
  // The prediction's reach (3 standard deviations, in the image) for a still object, and its
  // standard deviation's share of the last frame-to-frame motion for a moving one.
  double search_pixels = 10;
  double motion_share = 0.5;
  // px: the model's and the camera's error across an edge, at least; each verified frame's
  // refined matches measure it (a real object's CAO model is often a pixel or two off), up to
  // `max_model_sigma`.
  double pixel_sigma = 0.5;
  double max_model_sigma = 3;
  // An estimate beyond this confidence region of its prior (chi-square, the model's DOF) is
  // solved again with the prior widened to reach it (1: never).
  double prior_confidence = 0.999;
  double min_edge_pixels = 12;  // predicted pieces shorter than this are not matched
  // A frame is verified only with at least this share of the agreement of its outline with the
  // image that the sequence's verified frames had (their best, decaying by `typical_decay` a
  // frame): a pose sliding off the object, one edge at a time, passes every absolute test.
  double min_share_of_typical = 0.8;
  double typical_decay = 0.99;
  // m: a verified frame's every visible edge has its ends known to this standard deviation
  // under the estimate's covariance: matches that leave what the image shows undetermined (a
  // few edges of one direction) do not verify a frame. (What is hidden or out of view is as
  // uncertain as its covariance says.)
  double max_position_sigma = 0.004;
  // ... and every component pinned down by the matches rather than the prediction: its
  // standard deviation after them at most this share of the prediction's, in every direction.
  double max_spread = 0.9;
  // ... and at least this share of the best support of a set the outline verified in the frame,
  // determined by its matches or not.
  double min_share_of_best = 0.95;
  // How a set that passed is refined (Tracker::Refine): by each edge's most probable line about
  // the set's estimate (the default), or by each sample's strongest step within `refine_reach`
  // px as ViSP's moving edges take them (StrongestStepCandidates). The second converges from
  // further off on a real close-up (castel) but follows strong lines beside an edge (a
  // rendered castle's stairs): docs/benchmarks.md.
  bool refine_strongest = false;
  double refine_reach = 8;
  // Places tried a frame while the object is lost, in rings 2 x search_pixels apart (6, 12, 18,
  // ... places) about the last pose carried: the last verified one, or an imprecise frame's
  // estimate after it (TrackedFrame::imprecise).
  int reacquisition_places = 12;
  // When that carried estimate has strayed more than search_pixels from the last verified pose,
  // the rings are searched about the verified pose as well, when they find nothing about the
  // carried one. Undetermined estimates of a blurred or half-hidden object can run off (a box
  // carried 30 cm nearer than it was, then predicted 2.5 m away), and rings about them never
  // reach the object, which is still about where it was last seen.
  bool reacquire_about_last_verified = true;
  // A frame verified with no verified frame just before it (the first, or one after a loss)
  // came from a prior that may be far off, or stale: a pose slid by one of the object's repeated
  // parts, or nearer and turned, and a lid found shut on the box's rim while it stands open, can
  // pass every test of the outline (Castle-simu's tower on its window's edges). So the frame is
  // tracked again from places about its estimate: `settle_places` on a ring, `settle_depths`
  // along the line of sight, at a track's first frame verified on less than
  // `settle_tilts_below_share` of its outline `settle_tilts` (at most 4) turned about the
  // image's axes (a castle tilted 11 degrees and moved 19 mm deeper lines up half its edges with
  // others; a tilted place's pose replaces the frame's only when it explains
  // `settle_tilts_decisive_share` times as much, and never makes it ambiguous), and each joint
  // at `settle_joint_values` values across its limits.
  // A pose verified there that explains `decisive_share` times as much of the image
  // (ExplainedEvidence, verification.h) replaces the frame's; one that explains about as much with
  // a joint far from the frame's makes the frame ambiguous, and it is refused.
  int settle_places = 4;
  int settle_depths = 2;
  int settle_tilts = 4;
  double settle_tilts_below_share = 0.75;
  double settle_tilts_decisive_share = 1.5;
  int settle_joint_values = 4;
  double decisive_share = 1.15;
  // A track's first frame verified on `settle_places_below_share` of its outline or more is
  // settled across its joints only: the wrong first frames seen (a castle slid by a window,
  // tilted, or pulled in depth) were supported on 50-66 % of theirs, Castle-simu's right one on
  // 93 %, and its six places cost the time of twenty frames.
  double settle_places_below_share = 0.85;
  // A place's pose that explains about as much with a rigid part more than `search_pixels` from
  // the frame's (its points' RMS shift, in px at its depth) makes the frame ambiguous too.
  bool refuse_ambiguous_places = true;
  // A frame verified after a loss is settled from the pose last verified as well, and from each
  // joint there at `settle_joint_values` values: the estimate found after a loss may hold a part
  // wrong and its parent moved to make up for it (a lid shut on the box's rim while it stands
  // open, the box 20 mm off so that the closed outline lines up with the open box's), and the
  // joint places about that estimate leave the parent where it is, where no other joint value
  // lines up.
  bool settle_from_last_seen = true;
  // A frame lost for its precision alone carries its estimate to the next frame's prediction
  // (TrackedFrame::imprecise), but not one with a joint pushed onto a limit that the prediction
  // held it more than `search_pixels` from: the limit, not the image, placed that part (the lid
  // shut on the rim), and the frames after would be searched from it. (true: carried all the
  // same.)
  bool carry_joints_at_limits = false;
  MatchSearchOptions search;
  EvidenceOptions evidence_options;
  VerificationOptions verification;
  // Which edges are matched (cfuse/geometry/model_edges.h): those of faces turned at least 80
  // degrees from edge-on and 6 px across or more, hidden lines removed. A thin plate's rim or a
  // face seen nearly edge-on puts its edges within a pixel or two of each other, and a line matched
  // to the wrong one of such twins bends the estimate.
  Visibility visibility{0.17, 6, true};
  SegmentOptions segments;  // for EdgeEvidence::kSegments
  // A range sensor's frame given with the image: how its points are sampled and weighed.
  DepthOptions depth;
};

// Milliseconds per stage of one frame.
struct FrameTimes {
  double segments = 0;  // edge evidence: normal search or segment detection
  double prediction = 0, search = 0, estimation = 0, verification = 0;
  double detection = 0;  // with no pose to track from (auto_tracker.h)
  double Total() const {
    return segments + prediction + search + estimation + verification + detection;
  }
  FrameTimes& operator+=(const FrameTimes& more) {
    segments += more.segments;
    prediction += more.prediction;
    search += more.search;
    estimation += more.estimation;
    verification += more.verification;
    detection += more.detection;
    return *this;
  }
};

// A predicted edge, for overlays: its ends and the standard deviation of where the image shows
// it, across the edge, at each end (px).
struct PredictedEdge {
  int edge = -1;  // index into ModelEdges()
  Eigen::Vector2d a, b;
  double sigma_a = 0, sigma_b = 0;
  bool matched = false;
  // The image line matched to it (when matched).
  Eigen::Vector2d segment_a = Eigen::Vector2d::Zero(), segment_b = Eigen::Vector2d::Zero();
};

struct TrackedFrame {
  bool verified = false;
  int doublings = 0;          // of the search range used
  int branches = 0;           // match sets tried
  int matches = 0;            // in the accepted (extended) set
  bool reacquired = false;    // found by re-acquisition, away from the prediction
  bool detected = false;      // found by detection with no pose given (auto_tracker.h)
  double residual_sigma = 0;  // px, RMS of the accepted matches' residuals
  // The accepted matches' whitened residuals at the estimate: chi-square over the rows the fit
  // leaves free (2 a match, less the model's DOF); 0 and 0 when lost.
  double chi2 = 0;
  int fit_dof = 0;
  double model_sigma = 0;     // px, their robust scale (MatchedSet::model_sigma)
  // A range sensor's samples fused into the estimate, and their robust scale (m); 0 and 0
  // without depth.
  int depth_points = 0;
  double depth_sigma = 0;
  // m: the largest standard deviation of a visible edge's end under the estimate's covariance.
  double position_sigma = 0;
  // The verification of the accepted set (or of the last set judged, when lost).
  Verification verification;
  GaussianState estimate;                // the frame's estimate (the prediction when lost)
  // Lost for its precision alone: the best set passed every test of the outline, but its
  // matches leave the pose undetermined (motion blur, an occluder). `estimate` is that set's,
  // not the prediction, and the next frame is predicted from it.
  bool imprecise = false;
  std::vector<PredictedEdge> predicted;  // at the search range that decided the frame
  FrameTimes times;
};

class Tracker {
 public:
  // `initial`: every component's pose in the camera frame at the first frame (a rough one: the
  // first frame searches from it). Throws InputError (its location left to the caller, who knows
  // the file) for a camera without a size.
  Tracker(const ConstraintGraph& graph, const Camera& camera, const Values& initial,
          TrackerOptions options = {});

  TrackedFrame Track(const GrayView& image);
  // The same with a range sensor's frame taken at the same time (its points in this camera's
  // frame): each set that passes is refined with its points on the faces as well as with the
  // edges. Throws InputError for a frame whose points are not width x height.
  TrackedFrame Track(const GrayView& image, const DepthFrame& depth);
  // A frame with no image (missing or unreadable): the object moved on all the same, and the
  // next frame predicts across the gap.
  void Skip() { ++frame_; }

  // The model's degrees of freedom (each matched segment constrains 2).
  int dof() const { return dof_; }

 private:
  Values Predicted() const;
  // The prior about `predicted`, `scale` times the usual reach.
  FramePrior Prior(const Values& predicted, double scale) const;
  bool TryFrom(const GrayView& image, const FramePrior& prior, TrackedFrame* out);
  // The largest ratio of a component's standard deviation after the matches to before, in any
  // direction (1: the matches taught nothing of it).
  double Spread(const GaussianState& before, const GaussianState& after) const;
  // m: the largest standard deviation of a visible piece's end under `state`'s covariance.
  double PositionSigma(const GaussianState& state, const std::vector<EdgeModel>& visible) const;
  // Re-acquisition: the frame tracked from places in rings about `centre` (a ring further out
  // each frame: `reacquisition_ring_`); keeps in `out` the best verified estimate (the most of
  // the outline supported) of the first ring that finds one. True when one was found.
  bool Reacquire(const GrayView& image, const Values& centre, TrackedFrame* out);
  // Re-acquisition about the last pose carried, then (reacquire_about_last_verified) about the
  // last verified one, from the same ring.
  bool ReacquireLost(const GrayView& image, TrackedFrame* out);
  // The root component's origin (camera frame), and px per metre across the line of sight at
  // `depth`.
  Eigen::Vector3d RootOrigin(const Values& values) const;
  double PixelsPerMetre(double depth) const;
  // `centre` moved across the line of sight, at the root component's depth, by `ring` x 2 x
  // search_pixels in the image in the direction `angle` (rad; 0 along the image's x).
  Values RingPlace(const Values& centre, int ring, double angle) const;
  // The frame tracked from `place` with twice the usual reach.
  TrackedFrame TryPlace(const GrayView& image, const Values& place);
  // Place k about `centre` along the line of sight through the root's origin: nearer, further,
  // twice as near, ... (steps that move the outline's points as far as a ring's).
  Values DepthPlace(const Values& centre, int k) const;
  // Place k about `centre` turned about the image's x or y axis through the root's origin
  // (k = 0..3: about x one way and the other, then about y), as far as a ring's step.
  Values TiltPlace(const Values& centre, int k) const;
  // `centre` with each joint (one at a time) at settle_joint_values values across its limits
  // (without limits, a revolute one turned round in as many steps), its child's subtree moved
  // with it.
  std::vector<Values> JointPlaces(const Values& centre) const;
  // Whether the settling varies `joint` (a variable, not a mimic, between two rigid parts).
  bool Settleable(const Joint& joint) const;
  // Whether a joint of `estimate` lies within a pixel of one of its limits while in `predicted`
  // it lies more than search_pixels from it.
  bool PushedToLimit(const Values& estimate, const Values& predicted) const;
  // The most any rigid component's points move between `a` and `b` (RMS, px at its depth in `a`).
  double Apart(const Values& a, const Values& b) const;
  // `joint`'s value in `values` (rad or m), and px in the image per unit of it (its child's
  // points at their RMS radius, or its shift, at the child's depth).
  double JointValue(const Joint& joint, const Values& values) const;
  double JointPixels(const Joint& joint, const Values& values) const;
  // A frame verified with nothing verified before it, replaced by a decisively better pose
  // verified from places about its estimate (TrackerOptions::settle_places).
  void Settle(const GrayView& image, TrackedFrame* out);
  // Every edge of a model of several parts where `values` projects it, hidden or not
  // (VerifyOutline's `model`); none for a single part.
  std::vector<ModelLine> ModelLines(const Values& values) const;
  // The squared Mahalanobis distance of `mean` from `prior` (over the whole tangent space).
  double PriorDistance(const GaussianState& prior, const Values& mean) const;
  std::vector<EdgeCandidate> Candidates(const GrayView& image,
                                        const std::vector<EdgeModel>& edges) const;
  // A set that passed, matched again from evidence searched around its own estimate: every
  // edge's most probable line, matches beyond three robust standard deviations dropped, the
  // rest solved with the noise their residuals show (at least the tracker's model sigma).
  void Refine(const GrayView& image, const FramePrior& prior, MatchedSet* set) const;

  const ConstraintGraph& graph_;
  Camera camera_;
  TrackerOptions options_;
  std::vector<ModelEdge> edges_;
  std::vector<DepthFace> depth_faces_;
  const DepthFrame* depth_ = nullptr;  // this frame's, while it is tracked
  std::vector<Factor> constraints_;
  std::vector<double> radius_;  // per block: its component's points' RMS distance from its origin
  int dof_ = 6;
  EdgeAppearance appearance_;
  // The last two verified frames' indices and configurations, newest last.
  std::vector<std::pair<int, Values>> history_;
  int last_verified_ = -1;  // frame index; -1 before the first
  Values last_seen_;        // the last verified frame's estimate
  int frame_ = 0;           // the index of the next frame
  // The best share of a set the outline verified in this frame, determined by its matches or not,
  // and the best-supported set refused for its precision alone, with its share.
  double best_outline_ = 0;
  std::optional<GaussianState> undetermined_;
  double undetermined_share_ = 0;
  int reacquisition_ring_ = 0;
  double model_sigma_ = 0;  // px, what the verified frames' matches showed (pixel_sigma first)
  // The best agreement of the outline with the image (Verification::agreement) the verified
  // frames have shown, decaying by `typical_decay` a frame; 0 before the first.
  double typical_agreement_ = 0;
  // The same of the supported share: a set as well supported as the sequence's best verified
  // frames ends the search; others are compared with every branch's.
  double typical_share_ = 0;
  int verified_frames_ = 0;
};

}  // namespace cfuse
