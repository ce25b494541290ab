// Depth evidence for the tracker: a range sensor's points, each taken as a point on the model
// face its line of sight meets (the nearest front face at the estimate), measured by its
// distance from that face's plane (cfuse/kernel/measurements/point_on_plane.h). Edges leave a
// pose loose along the line of sight and in its tilt; a face's depth pins exactly those.
//
// Frames: the points are in the grey camera's frame (the caller moves a depth camera's points
// there by its extrinsics); each face's plane is in its component's frame.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/factor.h"
#include "cfuse/kernel/values.h"
#include "cfuse/vision/depth_file.h"

namespace cfuse {

struct DepthOptions {
  int stride = 12;  // px of the depth image between the samples looked at
  // Samples kept on the faces, at most (spread evenly over those found): each is a measurement
  // the estimator fuses, and a few dozen pin the faces' depth as well as hundreds (below).
  int max_points = 80;
  // m: a point further than this from the face its line of sight meets is not of that face (an
  // occluder, a hand, the background through a gap, a part of the model that is not modelled).
  double max_distance = 0.02;
  double min_sigma = 0.001;  // m: a sensor's noise, at least (the fit's robust scale above it)
  // The samples' weight, as this many independent points at most: a range sensor's errors are
  // correlated across its image (its calibration, its smoothing), and 400 samples of one face
  // know its depth no better than a few dozen would.
  double effective_points = 40;
  // A frame with `min_samples` or more on the faces in view (an occluder's left out) is verified
  // only when at least `min_inlier_share` of them lie within `inlier_distance` of their face: a
  // pose off in depth, turned or slid puts its faces, and the gaps between them, where the
  // sensor saw something else (castel's right frames: 97-99 %; its frames 10 mm off: 60-86 %).
  // With at least `min_inlier_share_weak_outline` of them agreeing, the outline of an estimate
  // the samples were fused into needs `min_outline_share` of its samples supported and
  // `min_outline_dominant` dominated by their edge, not VerificationOptions::min_share and
  // min_dominant: a model a few pixels off the real object has its edges that far from their
  // steps at the pose its faces fix (castel's castle: 43-59 % supported, 35-40 % dominated, its
  // faces 97-99 % agreeing). Castle-simu's castle from starts 30-60 mm off was verified 42-46 mm
  // off with those bars alone: 40-45 % of the outline supported, 91-93 % of the faces agreeing.
  double inlier_distance = 0.006;
  int min_samples = 20;  // on the faces in view, for the frame to be judged by its depth
  double min_inlier_share = 0.9;
  double min_inlier_share_weak_outline = 0.95;
  double min_outline_share = 0.35;
  double min_outline_dominant = 0.3;
};

// A rigid component's face as a plane: unit normal and offset in the component's frame (n · x =
// offset on it), and its outline in two coordinates along the plane.
struct DepthFace {
  int component = -1;
  Eigen::Vector3d normal, u, v;
  double offset = 0;
  std::vector<Eigen::Vector2d> outline;
};

// Every face of every rigid component with at least three points.
std::vector<DepthFace> DepthFaces(const ConstraintGraph& graph);

// A sample on a face: the measured point (grey camera's frame) and the face it lies on.
struct DepthMatch {
  int face = -1;  // index into the DepthFaces
  int block = -1;
  Eigen::Vector3d point;
  double distance = 0;  // m, signed, from the face's plane at the values it was matched at
};

// The frame's samples (every `stride`-th pixel of every `stride`-th row) whose line of sight
// meets a front face at `values` within `max_distance` of the point, at most `max_points` of them.
std::vector<DepthMatch> MatchDepth(const ConstraintGraph& graph,
                                   const std::vector<DepthFace>& faces, const Values& values,
                                   const DepthFrame& frame, const DepthOptions& options);

// How well the faces in view at `values` agree with the frame: the samples whose line of sight
// meets a face (every `stride`-th pixel, with a depth) and that lie no further in front of it
// than `max_distance` (an occluder's), and the share of them within `inlier_distance` of it.
struct DepthAgreement {
  int samples = 0;
  double share = 0;
};
DepthAgreement AgreeDepth(const ConstraintGraph& graph, const std::vector<DepthFace>& faces,
                          const Values& values, const DepthFrame& frame,
                          const DepthOptions& options);

// The factor of a match with its standard deviation `sigma` (m).
Factor DepthFactor(const std::vector<DepthFace>& faces, const DepthMatch& match, double sigma);

}  // namespace cfuse
