// Closed-form poses: exact on noise-free data at poses all over SO(3), the least-squares pose
// with noise, and refusing what they cannot solve.
#include "cfuse/interp/closed_form_pose.h"

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <random>

namespace cfuse {
namespace {

Eigen::Quaterniond RandomRotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
}

Camera Orthographic() {
  Camera c;
  c.model = Camera::Model::kOrthographic;
  c.scale = 1000;
  c.cx = 320;
  c.cy = 240;
  return c;
}

// The corners of a 30 x 25 x 20 cm box, off-centre.
std::vector<Eigen::Vector3d> Box() {
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < 8; ++i) {
    p.emplace_back(0.3 * (i & 1) + 0.05, 0.25 * ((i >> 1) & 1) - 0.1, 0.2 * ((i >> 2) & 1));
  }
  return p;
}

TEST_CASE("closed form: absolute orientation recovers poses all over SO(3)", "[interp]") {
  std::mt19937 rng(5);
  const std::vector<Eigen::Vector3d> from = Box();
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid3d truth(RandomRotation(rng), Eigen::Vector3d(0.3, -0.2, 1.5));
    std::vector<Eigen::Vector3d> to;
    for (const Eigen::Vector3d& p : from) to.push_back(truth * p);
    Rigid3d found;
    REQUIRE(AbsoluteOrientation(from, to, &found));
    CHECK(found.rotation.angularDistance(truth.rotation) < 1e-9);
    CHECK((found.translation - truth.translation).norm() < 1e-9);
  }
  // With noise: the least-squares pose, Eigen::umeyama's (without scale).
  std::normal_distribution<double> noise(0, 0.01);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid3d truth(RandomRotation(rng), Eigen::Vector3d(0.3, -0.2, 1.5));
    std::vector<Eigen::Vector3d> to;
    Eigen::Matrix3Xd a(3, from.size()), b(3, from.size());
    for (size_t i = 0; i < from.size(); ++i) {
      to.push_back(truth * from[i] + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
      a.col(i) = from[i];
      b.col(i) = to.back();
    }
    const Eigen::Matrix4d reference = Eigen::umeyama(a, b, false);
    Rigid3d found;
    REQUIRE(AbsoluteOrientation(from, to, &found));
    CHECK((found.rotation.toRotationMatrix() - reference.topLeftCorner<3, 3>()).norm() < 1e-12);
    CHECK((found.translation - reference.topRightCorner<3, 1>()).norm() < 1e-12);
  }
  Rigid3d untouched;
  CHECK_FALSE(AbsoluteOrientation({from[0], from[1]}, {from[0], from[1]}, &untouched));
  const std::vector<Eigen::Vector3d> line = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  CHECK_FALSE(AbsoluteOrientation(line, line, &untouched));
  // Nearly collinear, far from the origin: a point a ten-thousandth of the line's length off
  // it still fixes the turn about the line (the second spread is a millionth of the first at
  // the limit); a hundred-millionth does not.
  for (const auto& [h, solvable] : {std::pair{1e-4, true}, std::pair{1e-8, false}}) {
    const Eigen::Vector3d far(100, -50, 30);
    std::vector<Eigen::Vector3d> thin = {far, far + Eigen::Vector3d(1, 0, 0),
                                         far + Eigen::Vector3d(2, 0, 0),
                                         far + Eigen::Vector3d(1, h, 0)};
    INFO("offset " << h);
    CHECK(AbsoluteOrientation(thin, thin, &untouched) == solvable);
  }
}

TEST_CASE("closed form: orthographic pose of a solid recovers rotation and image position",
          "[interp]") {
  std::mt19937 rng(6);
  const Camera camera = Orthographic();
  const std::vector<Eigen::Vector3d> object = Box();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : object) centroid += p / 8.0;
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid3d truth(RandomRotation(rng), Eigen::Vector3d(0.1, -0.05, 2.0));
    std::vector<Eigen::Vector2d> image;
    for (const Eigen::Vector3d& p : object) image.push_back(camera.Project<double>(truth * p));
    Rigid3d found;
    REQUIRE(OrthographicPose(camera, object, image, 3.0, &found));
    INFO("trial " << trial);
    CHECK(found.rotation.angularDistance(truth.rotation) < 1e-9);
    // x and y are seen; depth is not: the centroid sits at the requested depth.
    CHECK(std::abs(found.translation.x() - truth.translation.x()) < 1e-9);
    CHECK(std::abs(found.translation.y() - truth.translation.y()) < 1e-9);
    CHECK((found * centroid).z() == Approx(3.0).margin(1e-9));
  }
}

TEST_CASE("closed form: orthographic pose of a plane is one of its two mirror images", "[interp]") {
  std::mt19937 rng(7);
  const Camera camera = Orthographic();
  const std::vector<Eigen::Vector3d> square = {
      {0, 0, 0}, {0.2, 0, 0}, {0.2, 0.15, 0}, {0, 0.15, 0}, {0.1, 0.05, 0}};
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid3d truth(RandomRotation(rng), Eigen::Vector3d(0.1, -0.05, 2.0));
    std::vector<Eigen::Vector2d> image;
    for (const Eigen::Vector3d& p : square) image.push_back(camera.Project<double>(truth * p));
    Rigid3d found;
    REQUIRE(OrthographicPose(camera, square, image, 2.0, &found));
    INFO("trial " << trial);
    // It reprojects exactly, and its rotation is the truth or the truth mirrored about the
    // image plane (z -> -z), which the camera cannot tell apart.
    for (size_t i = 0; i < square.size(); ++i) {
      CHECK((camera.Project<double>(found * square[i]) - image[i]).norm() < 1e-6);
    }
    const Eigen::Matrix3d F = Eigen::Vector3d(1, 1, -1).asDiagonal();
    const Eigen::Matrix3d R = found.rotation.toRotationMatrix();
    const Eigen::Matrix3d T = truth.rotation.toRotationMatrix();
    // On the plane (its x and y axes) the mirror is F T; off the plane the normal follows.
    const double direct = (R.leftCols<2>() - T.leftCols<2>()).norm();
    const double mirrored = (R.leftCols<2>() - (F * T).leftCols<2>()).norm();
    CHECK(std::min(direct, mirrored) < 1e-6);
  }
}

TEST_CASE("closed form: orthographic pose refuses what it cannot solve", "[interp]") {
  const std::vector<Eigen::Vector3d> box = Box();
  std::vector<Eigen::Vector2d> image(8, Eigen::Vector2d(320, 240));
  Rigid3d untouched;
  Camera pinhole;  // the default model
  CHECK_FALSE(OrthographicPose(pinhole, box, image, 1.0, &untouched));
  const std::vector<Eigen::Vector3d> line = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  CHECK_FALSE(
      OrthographicPose(Orthographic(), line, {image.begin(), image.begin() + 4}, 1.0, &untouched));
  CHECK_FALSE(
      OrthographicPose(Orthographic(), {box[0], box[1]}, {image[0], image[1]}, 1.0, &untouched));
  CHECK_FALSE(OrthographicPose(Orthographic(), box, {image[0]}, 1.0, &untouched));
}

}  // namespace
}  // namespace cfuse
