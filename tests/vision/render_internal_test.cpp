// What the renderer's styles share (vision/src/render_internal.h): the cameras it refuses,
// polygons filled by pixel centres, rays and depths, the faces turned to the camera, the
// background clutter, the hand, and the truth read against depth and face buffers.
#include "render_internal.h"

#include <catch2/catch.hpp>
#include <cmath>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/kernel/error.h"
#include "test_util.h"

namespace cfuse {
namespace {

using namespace internal;

// A 100 mm cube with its six faces, outward by the right-hand rule.
ConstraintGraph Cube() {
  return LoadModelFromString(R"(name: cube
units: {length: mm}
components:
  cube:
    points: {p000: [0, 0, 0], p100: [100, 0, 0], p110: [100, 100, 0], p010: [0, 100, 0],
             p001: [0, 0, 100], p101: [100, 0, 100], p111: [100, 100, 100], p011: [0, 100, 100]}
    faces:
      bottom: [p000, p010, p110, p100]
      top: [p001, p101, p111, p011]
      front: [p000, p100, p101, p001]
      back: [p110, p010, p011, p111]
      left: [p010, p000, p001, p011]
      right: [p100, p110, p111, p101]
)",
                             "cube.yaml", ".");
}

// The cube at 1 m, turned so that its corner p000 faces the camera: three faces in view.
Values CornerOn(const ConstraintGraph& g) {
  Values v = g.nominal;
  const Eigen::Vector3d diagonal = Eigen::Vector3d(1, 1, 1).normalized();
  const Eigen::Quaterniond turn =
      Eigen::Quaterniond::FromTwoVectors(diagonal, Eigen::Vector3d::UnitZ());
  v.poses[0] = Rigid3d(turn, Eigen::Vector3d(0, 0, 1) - turn * Eigen::Vector3d(0.05, 0.05, 0.05));
  return v;
}

int Count(const cv::Mat1b& mask) { return cv::countNonZero(mask); }

TEST_CASE("render internal: cameras the renderer cannot draw are refused", "[vision]") {
  Camera camera = testing::Pinhole();
  CHECK_NOTHROW(CheckRenderable(camera));
  camera.width = 0;
  CHECK_THROWS_WITH(CheckRenderable(camera),
                    Catch::EndsWith("error: the camera has no image size (width and height)"));
  camera.width = 1 << 15;
  camera.height = (1 << 13) + 1;
  CHECK_THROWS_WITH(CheckRenderable(camera),
                    Catch::Contains("32768 x 8193 pixels, is larger than the renderer's limit of "
                                    "2^28 pixels"));
  camera.height = 1 << 13;  // 2^28 exactly
  CHECK_NOTHROW(CheckRenderable(camera));
  camera = testing::Pinhole();
  camera.distortion[4] = 1e-3;
  CHECK_THROWS_AS(CheckRenderable(camera), InputError);
  CHECK_THROWS_WITH(CheckRenderable(camera), Catch::Contains("undistorted"));
  camera.model = Camera::Model::kOrthographic;  // its distortion is not used
  CHECK_NOTHROW(CheckRenderable(camera));
}

TEST_CASE("render internal: a polygon fills the pixels whose centres it holds", "[vision]") {
  cv::Mat1b mask(10, 10, std::uint8_t(0));
  FillPixelCentres({{0.5, 0.5}, {3.5, 0.5}, {3.5, 3.5}, {0.5, 3.5}}, mask);
  CHECK(Count(mask) == 9);
  CHECK(Count(mask(cv::Rect(1, 1, 3, 3))) == 9);
  // Two squares sharing the side x = 5, through pixel centres: each centre goes to one of them.
  cv::Mat1b left(10, 10, std::uint8_t(0)), right(10, 10, std::uint8_t(0));
  FillPixelCentres({{2, 2}, {5, 2}, {5, 7}, {2, 7}}, left);
  FillPixelCentres({{5, 2}, {8, 2}, {8, 7}, {5, 7}}, right);
  CHECK(Count(left) == 15);  // columns 2-4, rows 2-6
  CHECK(Count(right) == 15);
  CHECK(Count(left & right) == 0);
  // A triangle of area 2700 px²: as many centres, to within its perimeter.
  cv::Mat1b big(100, 100, std::uint8_t(0));
  FillPixelCentres({{10, 10}, {90, 20}, {30, 80}}, big);
  CHECK(std::abs(Count(big) - 2700) < 100);
  // Partly outside the image: the part inside; without corners: nothing.
  cv::Mat1b clipped(10, 10, std::uint8_t(0));
  FillPixelCentres({{-5, -5}, {4.5, -5}, {4.5, 4.5}, {-5, 4.5}}, clipped);
  CHECK(Count(clipped) == 25);
  cv::Mat1b none(10, 10, std::uint8_t(0));
  FillPixelCentres({}, none);
  CHECK(Count(none) == 0);
}

TEST_CASE("render internal: a pixel's ray meets a plane at the depth of its point", "[vision]") {
  const Camera pinhole = testing::Pinhole();
  const RayCaster rays{pinhole};
  const Eigen::Vector3d n = Eigen::Vector3d(0.2, -0.3, 1).normalized(), p(0.1, 0.05, 2);
  for (const Eigen::Vector2d& uv : {Eigen::Vector2d(320, 240), Eigen::Vector2d(17.5, 400)}) {
    const double depth = rays.DepthOnPlane(uv.x(), uv.y(), n, p);
    const Eigen::Vector3d x = depth * rays.Ray(uv.x(), uv.y());
    CHECK(n.dot(x - p) == Approx(0).margin(1e-12));
    CHECK((pinhole.Project<double>(x) - uv).norm() < 1e-9);
  }
  // A plane along the ray has no depth there.
  CHECK(std::isnan(rays.DepthOnPlane(320, 240, Eigen::Vector3d::UnitX(), p)));
  Camera ortho;
  ortho.model = Camera::Model::kOrthographic;
  ortho.scale = 1000;
  ortho.cx = 320;
  ortho.cy = 240;
  const RayCaster parallel{ortho};
  const double depth = parallel.DepthOnPlane(420, 140, n, p);
  const Eigen::Vector3d x = parallel.Ray(420, 140) + Eigen::Vector3d(0, 0, depth);
  CHECK(n.dot(x - p) == Approx(0).margin(1e-12));
  CHECK((ortho.Project<double>(x) - Eigen::Vector2d(420, 140)).norm() < 1e-9);
  CHECK(std::isnan(parallel.DepthOnPlane(420, 140, Eigen::Vector3d::UnitY(), p)));
}

TEST_CASE("render internal: the faces turned to the camera, none crossing its plane", "[vision]") {
  const ConstraintGraph g = Cube();
  const Camera camera = testing::Pinhole();
  const Values v = CornerOn(g);
  const std::vector<ViewedFace> faces = FrontFaces(g, v, camera);
  // p000 towards the camera: bottom, front and left.
  REQUIRE(faces.size() == 3);
  for (const ViewedFace& f : faces) {
    CAPTURE(f.face);
    CHECK((f.face == 0 || f.face == 2 || f.face == 4));
    CHECK(f.normal.norm() == Approx(1));
    CHECK(f.normal.dot(-f.corners[0]) > 0);  // towards the camera
    REQUIRE(f.polygon.size() == 4);
    for (size_t k = 0; k < 4; ++k) {
      CHECK((f.polygon[k] - camera.Project<double>(f.corners[k])).norm() < 1e-9);
    }
  }
  // Half of the cube behind the camera's plane: faces with a corner there are left out.
  Values across = v;
  across.poses[0].translation.z() -= 0.98;
  for (const ViewedFace& f : FrontFaces(g, across, camera)) {
    for (const Eigen::Vector3d& c : f.corners) CHECK(c.z() >= kNearPlane);
  }
}

TEST_CASE("render internal: clutter is dark and a function of its seed", "[vision]") {
  auto draw = [](unsigned seed, int lines, int blobs) {
    cv::Mat1b image(120, 160, std::uint8_t(255));
    std::mt19937 rng(seed);
    DrawClutter(image, lines, blobs, rng);
    return image;
  };
  const cv::Mat1b a = draw(4, 10, 5), b = draw(4, 10, 5), c = draw(5, 10, 5);
  CHECK(cv::countNonZero(a != b) == 0);
  CHECK(cv::countNonZero(a != c) > 0);
  double lowest = 0;
  cv::minMaxLoc(a, &lowest);
  CHECK(lowest >= 20);
  CHECK(lowest <= 110);
  CHECK(cv::countNonZero(draw(4, 0, 0) != 255) == 0);
}

TEST_CASE("render internal: the hand covers its palm, inside the image only", "[vision]") {
  HandOccluder hand;
  hand.palm = Eigen::Vector2d(100, 80);
  hand.arm_angle = M_PI / 2;  // the forearm runs down and out of the image
  hand.width = 60;
  int painted = 0;
  float palm_coverage = 0;
  bool inside = true, in_range = true;
  ForEachHandPixel(hand, 200, 160, [&](int u, int v, float coverage, float shade) {
    ++painted;
    inside = inside && u >= 0 && v >= 0 && u < 200 && v < 160;
    in_range = in_range && coverage > 0 && coverage <= 1 && shade > 0.2f && shade < 1.3f;
    if (u == 100 && v == 80) palm_coverage = coverage;
  });
  CHECK(inside);
  CHECK(in_range);
  CHECK(palm_coverage == 1);
  // More than the palm's disc, less than the image.
  CHECK(painted > M_PI * 30 * 30);
  CHECK(painted < 200 * 160 / 2);
  // No width, or no place: nothing.
  int none = 0;
  hand.width = 0;
  ForEachHandPixel(hand, 200, 160, [&](int, int, float, float) { ++none; });
  hand.width = 60;
  hand.palm.x() = std::nan("");
  ForEachHandPixel(hand, 200, 160, [&](int, int, float, float) { ++none; });
  CHECK(none == 0);
}

TEST_CASE("render internal: the truth is what neither depth nor a flat image hides", "[vision]") {
  const ConstraintGraph g = Cube();
  const Camera camera = testing::Pinhole();
  const Values v = CornerOn(g);
  cv::Mat1f far(camera.height, camera.width, std::numeric_limits<float>::infinity());
  cv::Mat1i background(camera.height, camera.width, -1);
  auto never = [](const Eigen::Vector2d&, const Eigen::Vector2d&) { return false; };
  // Nothing in front: each visible edge whole (the three faces' nine sides).
  const std::vector<ProjectedEdge> edges = VisibleEdges(g, ModelEdges(g), v, camera);
  const std::vector<TruthSegment> all = VisibleTruth(g, v, camera, far, background, never);
  REQUIRE(all.size() == edges.size());
  CHECK(all.size() == 9);
  for (size_t i = 0; i < all.size(); ++i) {
    CHECK(all[i].edge == edges[i].edge);
    CHECK((all[i].a - edges[i].a).norm() < 1e-9);
    CHECK((all[i].b - edges[i].b).norm() < 1e-9);
  }
  // An image without contrast shows nothing.
  auto flat = [](const Eigen::Vector2d&, const Eigen::Vector2d&) { return true; };
  CHECK(VisibleTruth(g, v, camera, far, background, flat).empty());
  // An occluder 10 cm from the camera over the left half hides what lies there.
  cv::Mat1f near = far.clone();
  cv::Mat1i occluded = background.clone();
  near(cv::Rect(0, 0, 320, camera.height)) = 0.1f;
  occluded(cv::Rect(0, 0, 320, camera.height)) = kOccluder;
  const std::vector<TruthSegment> right = VisibleTruth(g, v, camera, near, occluded, never);
  CHECK_FALSE(right.empty());
  double whole = 0, shown = 0;
  for (const TruthSegment& t : all) whole += (t.b - t.a).norm();
  for (const TruthSegment& t : right) {
    CHECK(t.a.x() >= 319.5);
    CHECK(t.b.x() >= 319.5);
    shown += (t.b - t.a).norm();
  }
  CHECK(shown < 0.8 * whole);
}

}  // namespace
}  // namespace cfuse
