// Model-based tracking through an image sequence (Lowe 1992), on the constraint kernel: each
// frame, the model's visible edges are predicted from the last frames, matched to image line
// segments by a best-first search over match sets ordered by Lowe's probabilities, and the
// model's pose (every component's, joints and limits holding exactly) is estimated from the
// matches by the kernel's estimator with the prediction as its prior.
//
// One frame:
//  1. Prediction. Every block moves on by the velocity of the last two verified frames (per
//     frame, in values.h's chart), carried at most `max_extrapolation` frames past the last
//     verified one, with a prior of `rotation_range` (a part on a joint: `joint_rotation_range`)
//     and `translation_range` on each component (the search range), into which the model's
//     constraints are fused: the prior then lives on the model's own configurations (7 DOF
//     for the hinged box). After lost frames the range starts wider, (1 + frames lost) times,
//     at most `max_lost_growth`.
//  2. Features. The model's visible edges at the prediction (vision/model_edges.h), and for each
//     the variance of where the image shows it, S = A P Aᵀ (Lowe's equation 2), from the
//     kernel's prediction of its segment residual (kernel/measurements/image_segment.h): the
//     perpendicular position at each end, hence of the midpoint and of the orientation. Image
//     segments are detected only in the window the predicted edges can reach
//     (vision/segments.h), and indexed (vision/segment_index.h).
//  3. Candidates. For each edge, the segments near it at about its orientation; each scored by
//     Lowe's p/(p+q) (equation 3): p a Gaussian in the midpoint's perpendicular distance and the
//     angle, q = N (m - s) / (π w h) the uniform background for N segments in the window of
//     w x h pixels, m the edge's length extended by its uncertainty, s the segment's.
//  4. Search, best first. A match set takes the most probable matches (one per edge and per
//     segment) until they constrain the model's DOF (2 per segment), and more while the product
//     of their probabilities stays above 0.9. Lowe scores every candidate against the
//     prediction alone; here (`conditional_sets`) each match taken is fused into the prior
//     before the next is chosen, and the rest re-scored against the tightened prediction, as
//     one path down Hel-Or & Werman's interpretation tree: after one edge of a box knocked 40
//     px sideways is matched, its parallel neighbours no longer look like the next edge's
//     image. The set is solved from the prior with the model's constraints, and passes when
//     its residual passes a chi-square test at the pixel noise (Lowe's σ² = |Jx - e|² /
//     (m - n)). A rejected set lowers each of its matches' probability by the factor
//     (1 - 1/n) and is never tried again, nor any set containing it; at most `max_branches`
//     sets a range. A set that passes is extended with every match the tightened prediction
//     supports (probability above one half), and solved again.
//  5. Verification. A set verifies the frame when its matches cover `verify_share` of the
//     visible edges' predicted length and `verify_component_share` of each component's in
//     view, pin every component down (`max_spread`: a lid whose only matched edge is its
//     hinge is not seen), and number at least `spare_matches` beyond the DOF's (a set that
//     barely constrains the model fits a wrong pose as well as the right one). A set that
//     explains `confident_share` of the model ends the search; one that explains less may be a
//     wrong pose that fits a few edges, so the other branches are tried too and the best
//     verified set wins.
//  6. Recovery. With too few candidates, or no set verified, the search range is doubled and
//     the frame tried again, at most `max_doublings` times. A frame still not verified is lost:
//     its estimate is the prediction, and the next frame predicts from the last verified ones,
//     so that a lost frame never corrupts the next. A frame found only by doubling broke with
//     the motion so far (a knock): its step is not taken for a velocity.
#pragma once

#include <optional>
#include <vector>

#include "constraints/graph.h"
#include "kernel/estimator.h"
#include "kernel/measurements/camera.h"
#include "vision/model_edges.h"
#include "vision/segments.h"

namespace cfuse::track {

struct TrackerOptions {
  int max_branches = 5;                // match sets tried per search range
  int max_doublings = 2;               // of the search range, before a frame is lost
  int max_extrapolation = 4;           // frames the velocity is carried on past the last verified
  double max_lost_growth = 4;          // of the search range after lost frames (1 + frames lost)
  double pixel_sigma = 0.5;            // px: a segment end's error across its line
  double rotation_range = 0.05;        // rad: each component's prior about the prediction
  double translation_range = 0.02;     // m
  double joint_rotation_range = 0.05;  // rad: a component placed by a joint
  double verify_share = 0.3;           // of the visible predicted edge length, matched
  double confident_share = 0.6;        // a verified set this good ends the search at once
  // ... and of each component's in view (predicted edges of `min_component_pixels` or more):
  // a part whose pose comes from the prior alone, or from a few stray matches, is not verified.
  double verify_component_share = 0.2;
  double min_component_pixels = 40;
  // ... and every component pinned down by the matches: its posterior standard deviation at
  // most this share of the prediction's in every direction.
  double max_spread = 0.9;
  int spare_matches = 2;          // matches beyond the DOF's (DOF / 2) a verified frame has
  double min_probability = 0.02;  // a candidate below is no candidate
  // Match sets built one match at a time, each fused before the next is chosen (tracker.cpp).
  bool conditional_sets = true;
  double accept_confidence = 0.999;  // of the residual's chi-square test
  double min_edge_pixels = 12;       // predicted edges shorter than this are not matched
  bool region_of_interest = true;    // detect segments only where the edges can be
  // Which edges are matched (vision/model_edges.h): those of faces turned at least 80 degrees
  // from edge-on and 6 px across or more, that no other part hides. A thin plate's rim or a
  // face seen nearly edge-on puts its edges within a pixel or two of each other, and a segment
  // matched to the wrong one of such twins bends the estimate.
  vision::Visibility visibility{0.17, 6, true};
  vision::SegmentOptions segments;
};

// Milliseconds per stage of one frame.
struct FrameTimes {
  double segments = 0, prediction = 0, search = 0, estimation = 0, verification = 0;
  double Total() const { return segments + prediction + search + estimation + verification; }
};

// A predicted edge, for overlays: its ends and the standard deviation of where the image shows
// it, across the edge, at each end (px).
struct PredictedEdge {
  int edge = -1;  // index into vision::ModelEdges()
  Eigen::Vector2d a, b;
  double sigma_a = 0, sigma_b = 0;
  bool matched = false;
  Eigen::Vector2d segment_a = Eigen::Vector2d::Zero(),
                  segment_b =
                      Eigen::Vector2d::Zero();  // the image segment matched to it (when matched)
};

struct TrackedFrame {
  bool verified = false;
  int doublings = 0;  // of the search range used
  int branches = 0;   // match sets tried
  int matches = 0;    // in the accepted (extended) set
  double matched_share = 0;
  double residual_sigma = 0;  // px, RMS of the accepted matches' residuals
  // Of the last match set that passed the residual test: the largest ratio of a component's
  // posterior standard deviation to the prediction's (1: some direction not observed), and the
  // least matched share of a component's visible edges.
  double spread = 1;
  double component_share = 0;
  GaussianState estimate;                // the frame's estimate (the prediction when lost)
  std::vector<PredictedEdge> predicted;  // at the search range that decided the frame
  FrameTimes times;
};

class Tracker {
 public:
  // `initial`: every component's pose in the camera frame at the first frame (a rough one: the
  // first frame searches from it). Throws std::invalid_argument for a camera without a size.
  Tracker(const ConstraintGraph& graph, const Camera& camera, const Values& initial,
          TrackerOptions options = {});

  TrackedFrame Track(const vision::GrayView& image);
  // A frame with no image (missing or unreadable): the object moved on all the same, and the
  // next frame predicts across the gap.
  void Skip() { ++frame_; }

  // The model's degrees of freedom (each matched segment constrains 2).
  int dof() const { return dof_; }

 private:
  struct Candidate {
    int edge = -1, segment = -1;  // indices into predicted and the frame's segments
    double probability = 0;
  };

  Values Predicted() const;
  bool TryRange(const vision::GrayView& image, double base, int doublings, const Values& predicted,
                TrackedFrame* out);

  const ConstraintGraph& graph_;
  Camera camera_;
  TrackerOptions options_;
  std::vector<vision::ModelEdge> edges_;
  std::vector<Factor> constraints_;
  int dof_ = 6;
  // The last two verified frames' indices and configurations, newest last.
  std::vector<std::pair<int, Values>> history_;
  int frame_ = 0;  // the index of the next frame
};

}  // namespace cfuse::track
