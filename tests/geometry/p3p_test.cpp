// P3P (cfuse/geometry/p3p.h): the true pose among the solutions, every solution exact, and OpenCV's
// solveP3P as a reference for completeness.
#include "cfuse/geometry/p3p.h"

#include <catch2/catch.hpp>
#include <opencv2/calib3d.hpp>
#include <random>

namespace cfuse {
namespace {

Eigen::Quaterniond RandomRotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
}

// A random non-degenerate P3P instance: three object points within a 0.5 m cube, seen from a
// random pose 1-5 m away.
struct P3pCase {
  std::array<Eigen::Vector3d, 3> object, bearings;
  Rigid3d truth;
};

P3pCase RandomP3p(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.25, 0.25), depth(1, 5);
  P3pCase c;
  for (;;) {
    for (Eigen::Vector3d& p : c.object) p = Eigen::Vector3d(u(rng), u(rng), u(rng));
    const Eigen::Vector3d n = (c.object[1] - c.object[0]).cross(c.object[2] - c.object[0]);
    if (n.norm() > 1e-3) break;  // not nearly collinear
  }
  c.truth = Rigid3d(RandomRotation(rng), Eigen::Vector3d(u(rng), u(rng), depth(rng)));
  for (int i = 0; i < 3; ++i) c.bearings[i] = (c.truth * c.object[i]).normalized();
  return c;
}

double PoseDistance(const Rigid3d& a, const Rigid3d& b) {
  return a.rotation.angularDistance(b.rotation) + (a.translation - b.translation).norm();
}

TEST_CASE("p3p: finds the true pose, and every pose it returns fits", "[geometry]") {
  std::mt19937 rng(11);
  int found_truth = 0;
  const int trials = 5000;
  for (int trial = 0; trial < trials; ++trial) {
    const P3pCase c = RandomP3p(rng);
    std::array<Rigid3d, 4> poses;
    const int n = ThreePointPoses(c.bearings, c.object, &poses);
    INFO("trial " << trial);
    REQUIRE(n >= 0);
    REQUIRE(n <= 4);
    double best = 1e9;
    for (int k = 0; k < n; ++k) {
      best = std::min(best, PoseDistance(poses[k], c.truth));
      // Each pose puts every object point on its bearing, in front of the camera.
      for (int i = 0; i < 3; ++i) {
        const Eigen::Vector3d q = poses[k] * c.object[i];
        CHECK(q.dot(c.bearings[i]) > 0);
        CHECK(q.normalized().cross(c.bearings[i]).norm() < 1e-7);
      }
    }
    if (best < 1e-6) ++found_truth;
  }
  // Near-degenerate draws (a bearing almost on the danger cylinder) may lose precision; they
  // are rare.
  CHECK(found_truth >= trials - 5);
}

// OpenCV's solver (Gao et al.) is the reference for completeness; its poses are often off by
// 1e-3 rad or more (it does not polish its roots), so only those that fit their bearings are
// compared.
TEST_CASE("p3p: returns every pose OpenCV's solveP3P returns that fits", "[geometry]") {
  std::mt19937 rng(12);
  int checked = 0, matched = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    const P3pCase c = RandomP3p(rng);
    std::vector<cv::Point3d> object;
    std::vector<cv::Point2d> image;
    for (int i = 0; i < 3; ++i) {
      object.emplace_back(c.object[i].x(), c.object[i].y(), c.object[i].z());
      image.emplace_back(c.bearings[i].x() / c.bearings[i].z(),
                         c.bearings[i].y() / c.bearings[i].z());
    }
    std::vector<cv::Mat> rvecs, tvecs;
    cv::solveP3P(object, image, cv::Matx33d::eye(), cv::noArray(), rvecs, tvecs, cv::SOLVEPNP_P3P);
    std::array<Rigid3d, 4> poses;
    const int n = ThreePointPoses(c.bearings, c.object, &poses);
    for (size_t k = 0; k < rvecs.size(); ++k) {
      cv::Matx33d R;
      cv::Rodrigues(rvecs[k], R);
      Eigen::Matrix3d Re;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) Re(i, j) = R(i, j);
      const Rigid3d theirs(
          Eigen::Quaterniond(Re).normalized(),
          Eigen::Vector3d(tvecs[k].at<double>(0), tvecs[k].at<double>(1), tvecs[k].at<double>(2)));
      double misfit = 0;
      for (int i = 0; i < 3; ++i) {
        misfit += (theirs * c.object[i]).normalized().cross(c.bearings[i]).norm();
      }
      if (misfit > 1e-8) continue;
      ++checked;
      double best = 1e9;
      for (int j = 0; j < n; ++j) best = std::min(best, PoseDistance(poses[j], theirs));
      if (best < 1e-5) ++matched;
    }
  }
  REQUIRE(checked >= 200);
  CHECK(matched == checked);
}

TEST_CASE("p3p: refuses collinear and coincident points", "[geometry]") {
  std::array<Rigid3d, 4> poses;
  const std::array<Eigen::Vector3d, 3> bearings = {Eigen::Vector3d(0, 0, 1),
                                                   Eigen::Vector3d(0.1, 0, 1).normalized(),
                                                   Eigen::Vector3d(0, 0.1, 1).normalized()};
  CHECK(ThreePointPoses(bearings, {Eigen::Vector3d(0, 0, 0), {1, 0, 0}, {2, 0, 0}}, &poses) == 0);
  CHECK(ThreePointPoses(bearings, {Eigen::Vector3d(0, 0, 0), {0, 0, 0}, {0, 1, 0}}, &poses) == 0);
  // Three equal bearings: no pose puts a proper triangle on them.
  const std::array<Eigen::Vector3d, 3> same = {bearings[0], bearings[0], bearings[0]};
  CHECK(ThreePointPoses(same, {Eigen::Vector3d(0, 0, 0), {1, 0, 0}, {0, 1, 0}}, &poses) == 0);
}

TEST_CASE("p3p: poses from three pixels, with and without lens distortion", "[geometry]") {
  std::mt19937 rng(13);
  Camera camera;
  camera.fx = 800;
  camera.fy = 780;
  camera.cx = 320;
  camera.cy = 240;
  for (const bool distorted : {false, true}) {
    camera.distortion = {};
    if (distorted) camera.distortion = {-0.2, 0.05, 1e-3, -5e-4, 0.01};
    for (int trial = 0; trial < 200; ++trial) {
      const P3pCase c = RandomP3p(rng);
      std::array<Eigen::Vector2d, 3> pixels;
      for (int i = 0; i < 3; ++i) pixels[i] = camera.Project<double>(c.truth * c.object[i]);
      double best = 1e9;
      for (const Rigid3d& pose : PosesFromThreeProjections(camera, c.object, pixels)) {
        best = std::min(best, PoseDistance(pose, c.truth));
      }
      INFO("distorted " << distorted << ", trial " << trial);
      CHECK(best < 1e-5);
    }
  }
}

TEST_CASE("p3p: a pixel's bearing points back at the point it shows, for pinhole cameras only",
          "[geometry]") {
  Camera camera;
  camera.fx = 800;
  camera.fy = 780;
  camera.cx = 320;
  camera.cy = 240;
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-0.4, 0.4), depth(0.5, 4);
  for (const bool distorted : {false, true}) {
    camera.distortion = {};
    if (distorted) camera.distortion = {-0.2, 0.05, 1e-3, -5e-4, 0.01};
    for (int trial = 0; trial < 50; ++trial) {
      const Eigen::Vector3d x(u(rng), u(rng), depth(rng));
      Eigen::Vector3d bearing;
      REQUIRE(PixelBearing(camera, camera.Project<double>(x), &bearing));
      INFO("distorted " << distorted << ", trial " << trial);
      CHECK(bearing.norm() == Approx(1).epsilon(1e-12));
      // Undistortion is iterative: good to about 1e-7 rad.
      CHECK((bearing - x.normalized()).norm() < (distorted ? 1e-6 : 1e-12));
    }
  }
  camera.model = Camera::Model::kOrthographic;
  Eigen::Vector3d bearing;
  CHECK_FALSE(PixelBearing(camera, Eigen::Vector2d(10, 20), &bearing));
  const std::array<Eigen::Vector3d, 3> object = {
      Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.1, 0, 0), Eigen::Vector3d(0, 0.1, 0)};
  CHECK(PosesFromThreeProjections(
            camera, object, {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)})
            .empty());
}

}  // namespace
}  // namespace cfuse
