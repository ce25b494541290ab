// Finding a model in one image with no pose given: recognition integrated with tracking (Lowe
// 1992's next step), by hypotheses from image corners, ranked by cheap evidence, each tracked
// and verified as the tracker verifies a frame.
//
//  1. Features. Segments (Lowe's detector, segments.h), and the junctions where two of them end
//     at a common corner, no segment going on through it (junctions.h): a junction and the far
//     ends of its two arms (or the corners of junctions further along them) are three image
//     points. An arm whose segment broke on texture or a highlight is traced on along the image's
//     steps of its orientation to where its edge ends (TracedEnd, `arm_trace_gap`), unless the
//     segment ends at another junction's corner, a vertex.
//  2. Hypotheses. Each junction is matched to each vertex of each rigid component where two of
//     its edges meet, the arms to those edges (both ways round): Lambda Twist P3P (p3p.h) on the
//     vertex and its two neighbours gives up to four poses of that component, and the model's
//     other components follow at their nominal joint values. An arm may stop short of the
//     neighbouring vertex or run past it (occlusion, a broken or merged segment): such a pose is
//     rough, which the tracking in step 4 forgives, or wrong, which the ranking in step 3 and
//     the verification in step 4 refuse.
//  3. Ranking. Each pose is scored by what its component's edges, hidden faces culled, explain of
//     the image: samples along them with a step of about their orientation nearby, less what
//     chance gives at that orientation (edge_orientations.h). The best, spread apart (no two
//     whose points' images lie within `spread_pixels` of each other's), are the candidates, each
//     with its joints at the values across their ranges whose edges explain the most
//     (`joint_values`).
//  4. Verification. Each candidate starts a tracker (tracker.h) on this image: its edges matched
//     by Lowe's best-first search, the pose and the joints estimated by the kernel, the outline
//     verified (the search range doubled once at most, and only for a model with joints).
//     Verified candidates that reach the same pose, or draw the same outline (a symmetric
//     model), are one answer. The best (the most of the image explained, ExplainedEvidence) is
//     refused as ambiguous when another plain pose over the same part of the image explains
//     nearly as much (TrackerOptions::decisive_share), and when it shows the object less plainly
//     than a pose found with no prior must (`min_margin`, `min_dominant`, `min_matches`); else it
//     is settled as the tracker settles a first frame: tracked again from places about it, a lid
//     across its range.
//
// The search is bounded: at most `max_junctions` junctions, `max_poses` scored poses and
// `max_candidates` tracked; Detection says when a bound cut it short.
#pragma once

#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/track/tracker.h"
#include "cfuse/vision/edge_orientations.h"
#include "cfuse/vision/junctions.h"
#include "cfuse/vision/segments.h"

namespace cfuse {

struct DetectorOptions {
  SegmentOptions segments;
  JunctionOptions junctions;
  EdgeOrientationOptions orientations;
  int max_junctions = 120;   // the strongest junctions seed hypotheses
  // Where an arm may end: its segment's far end and at most this many more, the corners of
  // junctions further along its line (ArmEnds).
  int max_arm_ends = 3;
  // ... the segment's far end moved on along the image's steps of the arm's orientation, across
  // gaps of at most this many px (TracedEnd), unless it ends at another junction's corner; 0:
  // where the segment ends.
  double arm_trace_gap = 12;
  long max_poses = 400000;   // P3P poses scored at most
  int max_candidates = 12;   // the best poses, spread apart, tracked and verified
  int max_results = 1;       // objects reported
  // A candidate's joints between rigid parts, one at a time, at this many values across their
  // limits (round the circle without): the configuration whose edges explain the most is tracked.
  int joint_values = 8;
  double sample_step = 4;    // px between the ranking's samples along an edge
  double min_samples = 12;   // a pose showing fewer samples in the image is not ranked
  double min_depth = 0.02;   // m: every point of the seeded component in front of the camera
  // Candidates differ by more than this (px) somewhere in their outlines: the model's points
  // where one projects them, against the nearest the other projects (a symmetric model's poses
  // that draw the same outline are one candidate).
  double spread_pixels = 10;
  // A found pose, searched for among thousands with no prior to hold it, must show the object
  // more plainly than a tracked frame: its outline supported beyond chance's share by at least
  // `min_margin`, at least `min_dominant` of it dominated by its edges (verification.h), and its
  // pose resting on at least `min_matches` matched edges. On a textured scene a pose among
  // thousands fits the texture as well as a tracked frame's tests ask, and a printed square on a
  // face (four edges) fits a box's outline there.
  double min_margin = 0.5;
  double min_dominant = 0.6;
  int min_matches = 6;
  TrackerOptions tracker;
};

// One pose of the ranking: the whole model placed by the seeded component's pose.
struct DetectionCandidate {
  Values values;
  int component = -1;      // seeded
  int vertex = -1;         // its point matched to the junction's corner
  int junction = -1;       // index into Detection::junctions
  double evidence = 0;     // samples supported beyond chance
  TrackedFrame frame;      // tracked from `values`
};

struct DetectionStats {
  int segments = 0, junctions = 0, vertices = 0;
  long poses = 0;        // scored
  int candidates = 0;    // tracked
  bool junctions_cut = false, poses_cut = false;  // a bound left seeds out
  // ms
  double segment_ms = 0, orientation_ms = 0, ranking_ms = 0, tracking_ms = 0;
  double Total() const { return segment_ms + orientation_ms + ranking_ms + tracking_ms; }
};

struct Detection {
  // Verified objects, the most of the image explained first (at most max_results).
  std::vector<TrackedFrame> found;
  // Per object found: the other poses verified that draw the same outline (each model point's
  // image within 2 px of one of the other's) from elsewhere, the model's symmetry (a box turned
  // half round): the image cannot tell them from the one reported.
  std::vector<std::vector<Values>> twins;
  // The candidates tracked, in ranking order: what was tried and why it was refused.
  std::vector<DetectionCandidate> candidates;
  std::vector<ImageSegment> segments;
  std::vector<Junction> junctions;
  DetectionStats stats;
  // When nothing is found: why, in a sentence.
  std::string why;
};

// Throws InputError (its location left to the caller) for a camera without a size or one of
// another size than the image, a model without edges, or an empty image. `segments`: the image's
// segments from a detector of the caller's, instead of DetectSegments with options.segments.
Detection Detect(const ConstraintGraph& graph, const Camera& camera, const GrayView& image,
                 const DetectorOptions& options = {},
                 const std::vector<ImageSegment>* segments = nullptr);

// Step 4 alone, for poses from elsewhere (a baseline's pose grid): each of `poses`, best first,
// tracked on `image` and decided among as Detect decides. The same input errors as Detect.
Detection DetectFrom(const ConstraintGraph& graph, const Camera& camera, const GrayView& image,
                     const std::vector<Values>& poses, const DetectorOptions& options = {});

// Where `values` projects every rigid component's points (pixels): what the detector compares
// poses by, symmetric twins included.
std::vector<Eigen::Vector2d> ProjectedPoints(const ConstraintGraph& graph, const Camera& camera,
                                            const Values& values);

}  // namespace cfuse
