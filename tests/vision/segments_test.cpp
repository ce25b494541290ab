// The image front end: segment detectors on known edges and on rendered scenes with their
// ground truth, Lowe's subdivision, the region of interest, and bad input.
#include "cfuse/vision/segments.h"

#include <catch2/catch.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/error.h"
#include "cfuse/vision/render.h"
#include "cfuse/vision/segment_score.h"
#include "test_util.h"

namespace cfuse {
namespace {

GrayView View(const cv::Mat& image) {
  return {image.data, image.cols, image.rows, static_cast<int>(image.step)};
}

const SegmentDetector kAll[] = {SegmentDetector::kLowe, SegmentDetector::kCanny,
                                SegmentDetector::kLsd};

TEST_CASE("segments: a step edge is found where it is", "[vision]") {
  // Dark columns 0-99, bright 100-199: the edge lies at x = 99.5.
  cv::Mat image(100, 200, CV_8U, cv::Scalar(50));
  image.colRange(100, 200).setTo(200);
  for (SegmentDetector d : kAll) {
    INFO(DetectorName(d));
    SegmentOptions o;
    o.detector = d;
    const std::vector<ImageSegment> s = DetectSegments(View(image), o);
    REQUIRE(s.size() == 1);
    // Lowe's crossings are sub-pixel; Canny's edge pixels whole (the edge falls between two).
    const double tolerance = d == SegmentDetector::kLowe ? 0.01 : 0.7;
    CHECK(std::abs(s[0].a.x() - 99.5) < tolerance);
    CHECK(std::abs(s[0].b.x() - 99.5) < tolerance);
    CHECK(s[0].Length() > 90);
    CHECK(std::abs(s[0].Orientation() - M_PI / 2) < 1e-3);
  }
}

TEST_CASE("segments: slanted edges keep their orientation and place", "[vision]") {
  // An anti-aliased polygon with edges at several angles, blurred: every side is found within
  // 1 px and 0.5 degree by Lowe's detector (OpenCV draws an anti-aliased polygon about 0.7 px
  // larger than its vertices say: the step edge above shows the detector itself exact).
  cv::Mat image(400, 400, CV_8U, cv::Scalar(60));
  const std::vector<cv::Point2d> corners = {{80.3, 90.7}, {310.6, 60.2}, {340.1, 300.4},
                                            {120.8, 330.9}};
  std::vector<cv::Point> fixed;
  for (const cv::Point2d& p : corners) {
    fixed.emplace_back(static_cast<int>(std::lround(p.x * 16)), static_cast<int>(std::lround(p.y * 16)));
  }
  cv::fillConvexPoly(image, fixed, cv::Scalar(190), cv::LINE_AA, 4);
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.7);
  SegmentOptions o;
  const std::vector<ImageSegment> found = DetectSegments(View(image), o);
  for (size_t k = 0; k < corners.size(); ++k) {
    const Eigen::Vector2d a(corners[k].x, corners[k].y);
    const Eigen::Vector2d b(corners[(k + 1) % 4].x, corners[(k + 1) % 4].y);
    const Eigen::Vector2d dir = (b - a).normalized(), normal(-dir.y(), dir.x());
    bool seen = false;
    for (const ImageSegment& s : found) {
      const Eigen::Vector2d sa = s.a.cast<double>(), sb = s.b.cast<double>();
      const double angle = std::acos(std::min(1.0, std::abs((sb - sa).normalized().dot(dir))));
      if (angle < 0.5 * M_PI / 180 && std::abs(normal.dot(sa - a)) < 1 &&
          std::abs(normal.dot(sb - a)) < 1 && s.Length() > 0.8 * (b - a).norm()) {
        seen = true;
      }
    }
    INFO("side " << k);
    CHECK(seen);
  }
}

TEST_CASE("segments: Lowe's subdivision keeps the most significant level", "[vision]") {
  // An L: two straight arms meeting at a corner become two segments, corner to ends.
  std::vector<Eigen::Vector2f> chain;
  for (int i = 0; i <= 40; ++i) chain.emplace_back(10.f + i, 10.f);
  for (int i = 1; i <= 30; ++i) chain.emplace_back(50.f, 10.f + i);
  std::vector<ImageSegment> s = SubdivideChain(chain, 0.75, 4);
  REQUIRE(s.size() == 2);
  CHECK((s[0].a - Eigen::Vector2f(10, 10)).norm() < 0.5);
  CHECK((s[0].b - Eigen::Vector2f(50, 10)).norm() < 0.6);
  CHECK((s[1].b - Eigen::Vector2f(50, 40)).norm() < 0.5);
  // A straight line with half-pixel jitter stays one segment: its halves are less significant.
  chain.clear();
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> jitter(-0.4f, 0.4f);
  for (int i = 0; i <= 80; ++i) chain.emplace_back(5.f + i, 20.f + 0.25f * i + jitter(rng));
  s = SubdivideChain(chain, 0.75, 4);
  REQUIRE(s.size() == 1);
  CHECK(s[0].Length() > 80);
  // A circle of radius 40 becomes a polygon: each piece within a pixel of the arc.
  chain.clear();
  for (int i = 0; i < 250; ++i) {
    const float t = static_cast<float>(i) / 250 * 2 * static_cast<float>(M_PI);
    chain.emplace_back(100 + 40 * std::cos(t), 100 + 40 * std::sin(t));
  }
  s = SubdivideChain(chain, 0.75, 4);
  CHECK(s.size() >= 8);
  for (const ImageSegment& piece : s) {
    const Eigen::Vector2f mid = 0.5f * (piece.a + piece.b) - Eigen::Vector2f(100, 100);
    CHECK(std::abs(mid.norm() - 40) < 1.5f);
  }
}

// Rendered hinged boxes (random opening, random pose, 30 clutter lines and 12 blobs), filling
// most of a 640 x 480 image, against their visible edges.
struct SceneScore {
  Coverage total;
  double worst_recall = 1;
};

SceneScore ScoreScenes(SegmentDetector detector, int scenes, bool clutter, double noise) {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  Camera camera = testing::Pinhole();
  SceneScore out;
  for (int t = 0; t < scenes; ++t) {
    SimulateOptions so;
    so.seed = 300 + t;
    so.camera = camera;
    so.sample_joints = true;
    const Simulation sim = Simulate(g, so);
    // The simulation frames the box at 40 % of the image with f = 800; f = 2000 fills it.
    Camera close = camera;
    close.fx = close.fy = 2000;
    RenderOptions ro;
    ro.seed = t;
    ro.noise = noise;
    if (!clutter) ro.clutter_lines = ro.clutter_blobs = 0;
    const Rendering r = Render(g, sim.truth, close, ro);
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> truth;
    for (const TruthSegment& s : r.truth) truth.emplace_back(s.a, s.b);
    SegmentOptions o;
    o.detector = detector;
    const std::vector<ImageSegment> found =
        DetectSegments({r.pixels.data(), r.width, r.height, r.width}, o);
    CoverageOptions co;
    co.min_truth_length = 15;
    const Coverage c = CoverTruth(truth, found, co);
    out.total.truth_length += c.truth_length;
    out.total.covered_length += c.covered_length;
    out.total.detected += c.detected;
    out.total.clutter += c.clutter;
    out.worst_recall = std::min(out.worst_recall, c.Recall());
  }
  return out;
}

TEST_CASE("segments: the detectors cover the visible edges of rendered scenes", "[vision]") {
  // >= 90 % of the edge length within 1.5 px and 3 degrees over 20 cluttered scenes, for each
  // detector, and no scene below 75 %.
  for (SegmentDetector d : kAll) {
    const SceneScore s = ScoreScenes(d, 20, true, 2.0);
    INFO(DetectorName(d) << ": recall " << s.total.Recall() << ", worst " << s.worst_recall
                         << ", " << s.total.detected << " segments, " << s.total.clutter
                         << " not on the box");
    CHECK(s.total.Recall() >= 0.90);
    CHECK(s.worst_recall >= 0.75);
  }
}

TEST_CASE("segments: few segments where there is no edge", "[vision]") {
  // Without background clutter every segment should be on the box: noise of 2 and 4 grey
  // levels makes at most a handful per scene (corners, the lid's double edges).
  for (double noise : {2.0, 4.0}) {
    const SceneScore s = ScoreScenes(SegmentDetector::kLowe, 20, false, noise);
    INFO("noise " << noise << ": " << s.total.clutter << " of " << s.total.detected
                  << " segments not on the box in 20 scenes");
    CHECK(s.total.Recall() >= 0.90);
    CHECK(s.total.clutter <= 12 * 20);
  }
}

TEST_CASE("segments: a region of interest is processed alone, in image coordinates", "[vision]") {
  cv::Mat image(240, 320, CV_8U, cv::Scalar(40));
  cv::rectangle(image, cv::Rect(40, 30, 100, 80), cv::Scalar(200), cv::FILLED);
  cv::rectangle(image, cv::Rect(200, 120, 80, 90), cv::Scalar(180), cv::FILLED);
  SegmentOptions o;
  o.roi = PixelRect{180, 100, 130, 130};
  const std::vector<ImageSegment> inside = DetectSegments(View(image), o);
  REQUIRE(inside.size() == 4);  // the second rectangle's sides, nothing of the first
  for (const ImageSegment& s : inside) {
    for (const Eigen::Vector2f& p : {s.a, s.b}) {
      CHECK(p.x() >= 180);
      CHECK(p.y() >= 100);
    }
  }
  // Each side matches the whole image's detection to 0.1 px.
  o.roi.reset();
  const std::vector<ImageSegment> all = DetectSegments(View(image), o);
  for (const ImageSegment& s : inside) {
    const bool same = std::any_of(all.begin(), all.end(), [&](const ImageSegment& t) {
      return (t.a - s.a).norm() + (t.b - s.b).norm() < 0.2f ||
             (t.a - s.b).norm() + (t.b - s.a).norm() < 0.2f;
    });
    CHECK(same);
  }
}

TEST_CASE("segments: bad input is refused, not crashed on", "[vision]") {
  cv::Mat image(50, 60, CV_8U, cv::Scalar(0));
  SegmentOptions o;
  CHECK_THROWS_AS(DetectSegments(GrayView{}, o), InputError);
  for (const PixelRect& roi : {PixelRect{-1, 0, 10, 10}, PixelRect{55, 0, 10, 10},
                               PixelRect{0, 45, 10, 10}, PixelRect{0, 0, 0, 10}}) {
    o.roi = roi;
    CHECK_THROWS_WITH(DetectSegments(View(image), o),
                      Catch::Matchers::Contains("is not inside the 60 x 50 image"));
  }
  o.roi.reset();
  // Parameters out of range are the caller's mistake, not the data's: a contract.
  o.low_contrast = 30;
  o.high_contrast = 10;
  CHECK_THROWS_AS(DetectSegments(View(image), o), InternalError);
  // A blank image and one of noise alone give nothing worth a segment.
  o = SegmentOptions{};
  CHECK(DetectSegments(View(image), o).empty());
  cv::Mat noise(200, 200, CV_8U);
  cv::randn(noise, 128, 2);
  CHECK(DetectSegments(View(noise), o).size() <= 2);
}

}  // namespace
}  // namespace cfuse
