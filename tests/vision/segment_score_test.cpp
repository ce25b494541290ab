// How detected segments cover true ones (cfuse/vision/segment_score.h), on segments whose
// coverage is worked out by hand: the distance and angle tolerances, ends extended by the
// distance, a stretch two true segments share counted once, and clutter.
#include "cfuse/vision/segment_score.h"

#include <catch2/catch.hpp>

namespace cfuse {
namespace {

using Truth = std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>;

ImageSegment Detected(float ax, float ay, float bx, float by) {
  ImageSegment s;
  s.a = Eigen::Vector2f(ax, ay);
  s.b = Eigen::Vector2f(bx, by);
  return s;
}

// A true segment from (0, 0) to (100, 0), sampled every half pixel: 201 samples.
const Truth kTruth = {{Eigen::Vector2d(0, 0), Eigen::Vector2d(100, 0)}};

TEST_CASE("segment score: a parallel segment 1 px off covers its extent and 1.5 px beyond",
          "[vision]") {
  // From x = 10 to 60 at y = 1: the samples at x = 8.5 .. 61.5 are covered, 107 of 201.
  const Coverage c = CoverTruth(kTruth, {Detected(10, 1, 60, 1)});
  CHECK(c.truth_length == Approx(100));
  CHECK(c.covered_length == Approx(100.0 * 107 / 201));
  CHECK(c.Recall() == Approx(107.0 / 201));
  CHECK(c.detected == 1);
  CHECK(c.clutter == 0);
  // Either direction covers alike.
  CHECK(CoverTruth(kTruth, {Detected(60, 1, 10, 1)}).covered_length == Approx(c.covered_length));
}

TEST_CASE("segment score: too far, too turned, or nowhere near is clutter", "[vision]") {
  const float tilt = std::tan(static_cast<float>(4 * M_PI / 180));
  const Coverage c = CoverTruth(kTruth, {Detected(10, 2, 60, 2),          // 2 px off
                                         Detected(10, 0, 60, 50 * tilt),  // turned 4 degrees
                                         Detected(200, 200, 250, 200),    // elsewhere
                                         Detected(50, 0, 50, 0)});        // no length
  CHECK(c.covered_length == 0);
  CHECK(c.detected == 4);
  CHECK(c.clutter == 3);  // the empty one is not judged
  // Tolerances of 2.5 px and 5 degrees take the first two in.
  CoverageOptions loose;
  loose.max_distance = 2.5;
  loose.max_angle = 5 * M_PI / 180;
  CHECK(
      CoverTruth(kTruth, {Detected(10, 2, 60, 2), Detected(10, 0, 60, 50 * tilt)}, loose).clutter ==
      0);
}

TEST_CASE("segment score: a stretch two true segments share counts once; short ones not at all",
          "[vision]") {
  // A hinge: two model edges at one place, and a detected segment along the whole of it.
  const Truth twice = {kTruth[0], {Eigen::Vector2d(100, 0), Eigen::Vector2d(0, 0)}};
  const Coverage c = CoverTruth(twice, {Detected(0, 0, 100, 0)});
  CHECK(c.truth_length == Approx(100));
  CHECK(c.Recall() == Approx(1));
  // A true segment shorter than min_truth_length, or without length, is not counted.
  Truth with_short = kTruth;
  with_short.push_back({Eigen::Vector2d(0, 50), Eigen::Vector2d(5, 50)});
  with_short.push_back({Eigen::Vector2d(7, 7), Eigen::Vector2d(7, 7)});
  CoverageOptions options;
  options.min_truth_length = 10;
  CHECK(CoverTruth(with_short, {}, options).truth_length == Approx(100));
  CHECK(CoverTruth(with_short, {}).truth_length == Approx(105));
  // No truth: nothing to miss.
  CHECK(CoverTruth({}, {Detected(0, 0, 10, 0)}).Recall() == 1);
}

}  // namespace
}  // namespace cfuse
