// The picture of points and a fitted model (cfuse/vision/point_picture.h), decoded: its size,
// the two panels' frames, the model's centre at each panel's centre and its farthest points at
// the scale that fits them, each marker in its colour, and the legend.
#include "cfuse/vision/point_picture.h"

#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>

namespace cfuse {
namespace {

cv::Mat Decode(const std::string& png) {
  const std::vector<unsigned char> bytes(png.begin(), png.end());
  return cv::imdecode(bytes, cv::IMREAD_COLOR);
}

bool Is(const cv::Mat& image, int x, int y, const cv::Vec3b& bgr, int tolerance = 30) {
  const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
  for (int c = 0; c < 3; ++c) {
    if (std::abs(p[c] - bgr[c]) > tolerance) return false;
  }
  return true;
}

const cv::Vec3b kWhite(255, 255, 255), kFrame(210, 210, 210), kRed(40, 40, 220),
    kOrange(0, 140, 255);

TEST_CASE("point picture: two views of the model, markers where its principal axes put them",
          "[vision]") {
  // Model points in the plane z = 1.5, spread 0.2 m along x and 0.1 m along y about (0, 0,
  // 1.5); a wrong match drawn last at that centre, clutter farther out.
  const Eigen::Vector3d centre(0, 0, 1.5);
  std::vector<PictureMarker> markers;
  for (const Eigen::Vector3d& d : {Eigen::Vector3d(0.1, 0, 0), Eigen::Vector3d(-0.1, 0, 0),
                                   Eigen::Vector3d(0, 0.05, 0), Eigen::Vector3d(0, -0.05, 0)}) {
    markers.push_back({centre + d, PictureMarker::Kind::kModelPoint, "p"});
  }
  markers.push_back(
      {centre + Eigen::Vector3d(0.05, 0.05, 0.01), PictureMarker::Kind::kClutter, ""});
  markers.push_back({centre, PictureMarker::Kind::kWrong, ""});
  const cv::Mat image = Decode(PointPicturePng(markers, {}, "a title"));
  REQUIRE(image.cols == 1200);
  REQUIRE(image.rows == 640);
  CHECK(Is(image, 0, 0, kWhite, 0));
  CHECK(Is(image, 1199, 639, kWhite, 0));
  // Panels 555 x 530 px from (30, 50) and (615, 50); one scale, 0.48 x 530 px for the farthest
  // point (0.1 m along the first axis).
  CHECK(Is(image, 30, 50, kFrame, 0));
  CHECK(Is(image, 615 + 554, 50 + 529, kFrame, 0));
  for (const int origin_x : {30 + 277, 615 + 277}) {
    CAPTURE(origin_x);
    CHECK(Is(image, origin_x, 50 + 265, kRed));
    // The first axis runs across both panels: the two far model points at ±254 px.
    CHECK(Is(image, origin_x + 254, 315, kOrange));
    CHECK(Is(image, origin_x - 254, 315, kOrange));
  }
  // The first panel looks onto the plane, where the second axis shows; the side view does not.
  CHECK((Is(image, 307, 315 - 127, kOrange) && Is(image, 307, 315 + 127, kOrange)));
  CHECK(Is(image, 892, 315 - 127, kWhite, 0));
  // The title's text on top, the legend's red cross below the panels.
  int title = 0, legend_red = 0;
  for (int y = 0; y < 50; ++y)
    for (int x = 0; x < 600; ++x) title += Is(image, x, y, kWhite, 0) ? 0 : 1;
  for (int y = 580; y < 640; ++y)
    for (int x = 0; x < 1200; ++x) legend_red += Is(image, x, y, kRed) ? 1 : 0;
  CHECK(title > 50);
  CHECK(legend_red > 10);
}

TEST_CASE("point picture: any size, and a picture of nothing", "[vision]") {
  const cv::Mat small = Decode(PointPicturePng({}, {}, "", 600, 400));
  REQUIRE(small.cols == 600);
  REQUIRE(small.rows == 400);
  CHECK(Is(small, 30, 50, kFrame, 0));  // the panels, empty
  // One segment of the fitted model, its ends the only points.
  const std::vector<PictureSegment> line = {{Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 1)}};
  const cv::Mat drawn =
      Decode(PointPicturePng({{Eigen::Vector3d(0, 0, 1), PictureMarker::Kind::kOccluded, ""},
                              {Eigen::Vector3d(1, 0, 1), PictureMarker::Kind::kMatched, ""}},
                             line, "", 600, 400));
  REQUIRE(!drawn.empty());
  // Panels 255 x 290 px; the segment through the first panel's centre (157, 195), orange.
  CHECK(Is(drawn, 157, 195, kOrange, 60));
}

}  // namespace
}  // namespace cfuse
