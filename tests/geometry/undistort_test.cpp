// Undistortion (cfuse/geometry/undistort.h): OpenCV's undistortPoints, bit for bit, so that the
// interpretation's P3P seeds are what they were when OpenCV computed their bearings.
#include "cfuse/geometry/undistort.h"

#include <catch2/catch.hpp>
#include <cstring>
#include <opencv2/calib3d.hpp>
#include <random>
#include <vector>

namespace cfuse {
namespace {

// How many of `pixels` cfuse and OpenCV undistort to different doubles (compared bit for bit).
int CountDifferent(const Camera& camera, const std::vector<cv::Point2d>& pixels) {
  const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const std::vector<double> dist(camera.distortion.begin(), camera.distortion.end());
  std::vector<cv::Point2d> theirs;
  cv::undistortPoints(pixels, theirs, K, dist);
  int different = 0;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const Eigen::Vector2d ours = UndistortPoint(camera, {pixels[i].x, pixels[i].y});
    different += std::memcmp(&ours.x(), &theirs[i].x, sizeof(double)) != 0 ||
                 std::memcmp(&ours.y(), &theirs[i].y, sizeof(double)) != 0;
  }
  return different;
}

TEST_CASE("undistort: the same doubles as OpenCV's undistortPoints", "[geometry]") {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(-1, 1);
  for (const int coefficients : {4, 5, 8, 12}) {
    for (int trial = 0; trial < 200; ++trial) {
      Camera camera;
      camera.fx = 800 + 300 * u(rng);
      camera.fy = 800 + 300 * u(rng);
      camera.cx = 320 + 40 * u(rng);
      camera.cy = 240 + 40 * u(rng);
      // Radial terms (k1 k2 k3, k4 k5 k6) up to 0.5, tangential and thin-prism ones to 0.01.
      for (int i = 0; i < coefficients; ++i) {
        const bool radial = i < 2 || (i >= 4 && i < 8);
        camera.distortion[i] = (radial ? 0.5 : 0.01) * u(rng);
      }
      std::vector<cv::Point2d> pixels = {{camera.cx, camera.cy}};
      for (int i = 0; i < 20; ++i) pixels.emplace_back(320 + 400 * u(rng), 240 + 300 * u(rng));
      INFO(coefficients << " coefficients, trial " << trial);
      CHECK(CountDifferent(camera, pixels) == 0);
    }
  }
}

TEST_CASE("undistort: where the model folds back, the distorted point, as OpenCV", "[geometry]") {
  Camera camera;
  camera.fx = camera.fy = 100;
  camera.distortion[0] = -0.5;  // 1 + k1 r² < 0 beyond r = 1.41
  const Eigen::Vector2d far = UndistortPoint(camera, {200, 0});
  CHECK(far.x() == 2);
  CHECK(far.y() == 0);
  CHECK(CountDifferent(camera, {{200, 0}, {150, -120}, {90, 10}}) == 0);
}

}  // namespace
}  // namespace cfuse
