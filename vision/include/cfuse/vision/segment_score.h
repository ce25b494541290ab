// How well detected segments cover true edges: the measure of the detector's tests and
// benchmark. A point of a true segment is covered when a detected segment within `max_angle`
// of its orientation passes within `max_distance` of it, between its ends (extended by
// `max_distance`). Recall is the covered share of the true segments' total length, a stretch
// that two true segments share (two model edges at one place: a hinge) counted once; a
// detected segment is clutter when its midpoint is covered by no true segment in the same
// sense.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/vision/segments.h"

namespace cfuse {

struct CoverageOptions {
  double max_distance = 1.5;          // px
  double max_angle = 3 * M_PI / 180;  // rad
  double min_truth_length = 0;        // px: shorter true segments are not counted
};

struct Coverage {
  double truth_length = 0, covered_length = 0;
  int detected = 0, clutter = 0;
  double Recall() const { return truth_length > 0 ? covered_length / truth_length : 1; }
};

Coverage CoverTruth(const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>& truth,
                    const std::vector<ImageSegment>& detected, const CoverageOptions& options = {});

}  // namespace cfuse
