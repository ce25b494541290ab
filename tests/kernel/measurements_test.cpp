// Measurement residuals: the camera model against OpenCV's projectPoints, every Jacobian
// against central differences, and a rigid component's pose fused from image points alone.
#include <catch2/catch.hpp>
#include <opencv2/calib3d.hpp>
#include <random>

#include "cfuse/kernel/estimator.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/measurements/image_point.h"
#include "cfuse/kernel/measurements/image_segment.h"
#include "cfuse/kernel/measurements/point3.h"
#include "cfuse/kernel/measurements/point_on_plane.h"
#include "kernel/jacobian_checker.h"

namespace cfuse {
namespace {

Camera TestCamera(int coefficients) {
  Camera c;
  c.fx = 810;
  c.fy = 790;
  c.cx = 321.5;
  c.cy = 238.25;
  c.width = 640;
  c.height = 480;
  const double d[12] = {-0.21,  0.08,  0.0012, -0.0008, -0.015, 0.01,
                        -0.004, 0.002, 0.001,  -0.0005, 0.0007, 0.0003};
  for (int i = 0; i < coefficients; ++i) c.distortion[i] = d[i];
  return c;
}

TEST_CASE("camera: projection equals OpenCV's projectPoints for 0, 4, 5, 8 and 12 coefficients",
          "[kernel]") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> xy(-0.4, 0.4), z(0.5, 3.0);
  for (int coefficients : {0, 4, 5, 8, 12}) {
    const Camera camera = TestCamera(coefficients);
    const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    std::vector<double> dist(camera.distortion.begin(),
                             camera.distortion.begin() + std::max(coefficients, 4));
    std::vector<cv::Point3d> points;
    for (int i = 0; i < 50; ++i) {
      const double depth = z(rng);
      points.emplace_back(xy(rng) * depth, xy(rng) * depth, depth);
    }
    std::vector<cv::Point2d> expected;
    cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, expected);
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d uv =
          camera.Project<double>(Eigen::Vector3d(points[i].x, points[i].y, points[i].z));
      CHECK(std::abs(uv.x() - expected[i].x) < 1e-9);
      CHECK(std::abs(uv.y() - expected[i].y) < 1e-9);
    }
  }
}

TEST_CASE("camera: without distortion, the general formula's values and derivatives exactly",
          "[kernel]") {
  // A last coefficient of 1e-300 sends Project through the distortion polynomial, and adds
  // nothing a double can hold to these points' pixels: the short path must give the same bits.
  const Camera plain = TestCamera(0);
  Camera general = plain;
  general.distortion[11] = 1e-300;
  REQUIRE_FALSE(plain.Distorted());
  REQUIRE(general.Distorted());
  using Dual = Eigen::AutoDiffScalar<Eigen::Vector3d>;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> xy(-0.6, 0.6), z(0.2, 4.0);
  for (int i = 0; i < 2000; ++i) {
    const double depth = z(rng);
    const Eigen::Vector3d p(xy(rng) * depth, xy(rng) * depth, depth);
    const Eigen::Vector2d a = plain.Project<double>(p), b = general.Project<double>(p);
    REQUIRE(a.x() == b.x());
    REQUIRE(a.y() == b.y());
    Vector3<Dual> q;
    for (int k = 0; k < 3; ++k) q[k] = Dual(p[k], 3, k);
    const Eigen::Matrix<Dual, 2, 1> da = plain.Project<Dual>(q), db = general.Project<Dual>(q);
    for (int r = 0; r < 2; ++r) {
      REQUIRE(da[r].value() == db[r].value());
      // (The coefficient's own derivative terms, of order 1e-297, are the only difference.)
      REQUIRE((da[r].derivatives() - db[r].derivatives()).cwiseAbs().maxCoeff() < 1e-290);
    }
  }
}

TEST_CASE("camera: a point at or behind the centre projects to NaN", "[kernel]") {
  const Camera camera = TestCamera(5);
  CHECK(std::isnan(camera.Project<double>(Eigen::Vector3d(0.1, 0, 0)).x()));
  CHECK(std::isnan(camera.Project<double>(Eigen::Vector3d(0.1, 0, -1)).y()));
}

// One pose block and one point block, for the measurement Jacobians.
struct TwoBlocks {
  TwoBlocks() {
    blocks = {Block{BlockKind::kPose, 0, 0, "box"}, Block{BlockKind::kPoint, 0, 6, "p"}};
    values.poses = {Rigid3d(Eigen::Quaterniond(0.3, -0.5, 0.7, 0.2).normalized(),
                            Eigen::Vector3d(0.1, -0.05, 1.8))};
    values.points = {Eigen::Vector3d(0.2, 0.1, 1.2)};
  }
  std::vector<Block> blocks;
  Values values;
};

TEST_CASE("measurements: every residual's Jacobian matches central differences", "[kernel]") {
  const TwoBlocks s;
  const Eigen::Vector3d local(0.05, -0.12, 0.3);
  testing::CheckJacobian(s.blocks, Point3Residual(local, Eigen::Vector3d(0.3, 0.2, 1.9)), {0},
                         s.values);
  testing::CheckJacobian(s.blocks, Point3Residual(Eigen::Vector3d(0.3, 0.2, 1.9)), {1}, s.values);
  testing::CheckJacobian(
      s.blocks,
      PointOnPlaneResidual(Eigen::Vector3d(0.2, -0.4, 0.9), 0.07, Eigen::Vector3d(0.3, 0.2, 1.9)),
      {0}, s.values);
  for (int coefficients : {0, 5, 12}) {
    const Camera camera = TestCamera(coefficients);
    testing::CheckJacobian(s.blocks, ImagePointResidual(camera, local, Eigen::Vector2d(300, 200)),
                           {0}, s.values);
    testing::CheckJacobian(s.blocks, ImagePointResidual(camera, Eigen::Vector2d(300, 200)), {1},
                           s.values);
  }
  Camera ortho;
  ortho.model = Camera::Model::kOrthographic;
  ortho.scale = 500;
  ortho.cx = 320;
  ortho.cy = 240;
  testing::CheckJacobian(s.blocks, ImagePointResidual(ortho, local, Eigen::Vector2d(300, 200)), {0},
                         s.values);
  // A model edge against a measured image segment: pinhole with and without distortion, and
  // orthographic.
  const Eigen::Vector3d other(-0.1, 0.2, 0.05);
  for (int coefficients : {0, 5, 12}) {
    testing::CheckJacobian(s.blocks,
                           ImageSegmentResidual(TestCamera(coefficients), local, other,
                                                Eigen::Vector2d(280, 190), Eigen::Vector2d(350, 230)),
                           {0}, s.values);
  }
  testing::CheckJacobian(s.blocks,
                         ImageSegmentResidual(ortho, local, other, Eigen::Vector2d(280, 190),
                                              Eigen::Vector2d(350, 230)),
                         {0}, s.values);
}

TEST_CASE("measurements: a 3D point on a plane measures its signed distance along the normal",
          "[kernel]") {
  // The component's plane z = 0.1 (normal +z) with the component turned 90 degrees about x and
  // moved to (0, 0, 2): in the world the plane is y = -0.1, its normal -y.
  std::vector<Block> blocks = {{BlockKind::kPose, 0, 0, "box"}};
  Values values;
  values.poses = {Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX())),
                          Eigen::Vector3d(0, 0, 2))};
  const std::vector<int> slot = {0};
  Eigen::VectorXd r;
  // On the plane anywhere across it, then 5 mm off it on either side; a normal given unscaled.
  for (const auto& [measured, expected] : {std::pair{Eigen::Vector3d(0.3, -0.1, 2.4), 0.0},
                                           {Eigen::Vector3d(-1, -0.1, 1.5), 0.0},
                                           {Eigen::Vector3d(0, -0.105, 2), 0.005},
                                           {Eigen::Vector3d(0.2, -0.095, 2.1), -0.005}}) {
    EvaluateResidual(PointOnPlaneResidual(Eigen::Vector3d(0, 0, 3), 0.1, measured), blocks, slot,
                     values, &r, nullptr);
    REQUIRE(r.size() == 1);
    CHECK(r[0] == Approx(expected).margin(1e-12));
  }
}

TEST_CASE("measurements: an image segment measures the distance of its ends from the edge's line",
          "[kernel]") {
  // The model edge from (0, 0, 2) to (0.2, 0, 2) in front of the camera projects along the row
  // v = cy; a measured segment 3 px below it, shifted and shorter, is 3 px off at both ends, in
  // either direction of the edge.
  Camera camera = TestCamera(0);
  std::vector<Block> blocks = {Block{BlockKind::kPose, 0, 0, "edge"}};
  Values values;
  values.poses = {Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 2))};
  const Eigen::Vector2d a(camera.cx + 10, camera.cy + 3), b(camera.cx + 40, camera.cy + 3);
  for (const auto& [p, q] : {std::pair{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.2, 0, 0)},
                             std::pair{Eigen::Vector3d(0.2, 0, 0), Eigen::Vector3d(0, 0, 0)}}) {
    const ImageSegmentResidual f(camera, p, q, a, b);
    Eigen::VectorXd r;
    EvaluateResidual(f, blocks, std::vector<int>{0}, values, &r, nullptr);
    CHECK(std::abs(std::abs(r[0]) - 3) < 1e-9);
    CHECK(std::abs(r[0] - r[1]) < 1e-9);
  }
}

TEST_CASE("measurements: a rigid component's pose from image points alone (§7)", "[kernel]") {
  // A box's 8 corners seen by a pinhole camera; the prior is 0.2 rad and 5 cm off.
  const std::vector<Eigen::Vector3d> corners = {{0, 0, 0},        {0.3, 0, 0},   {0.3, 0.25, 0},
                                                {0, 0.25, 0},     {0, 0, 0.2},   {0.3, 0, 0.2},
                                                {0.3, 0.25, 0.2}, {0, 0.25, 0.2}};
  const Camera camera = TestCamera(5);
  std::mt19937 rng(9);
  std::normal_distribution<double> pixel(0, 0.5);
  const Rigid3d truth(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -1).normalized())),
      Eigen::Vector3d(-0.1, 0.05, 1.5));
  std::vector<Block> blocks = {Block{BlockKind::kPose, 0, 0, "box"}};
  Values guess;
  guess.poses = {
      Rigid3d(truth.rotation * Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ())),
              truth.translation + Eigen::Vector3d(0.05, -0.03, 0.04))};
  GaussianState state = MakePrior(blocks, guess, PriorScale{1.0, 1.0, 1.0});
  for (const Eigen::Vector3d& c : corners) {
    const Eigen::Vector2d uv =
        camera.Project<double>(truth * c) + Eigen::Vector2d(pixel(rng), pixel(rng));
    const Factor f{std::make_shared<ImagePointResidual>(camera, c, uv),
                   {0},
                   0.25 * Eigen::Matrix2d::Identity(),
                   "corner"};
    REQUIRE(Fuse(f, &state).status == FusionSummary::Status::kFused);
  }
  const Rigid3d& estimate = state.mean.poses[0];
  const double rotation_error = estimate.rotation.angularDistance(truth.rotation);
  const double translation_error = (estimate.translation - truth.translation).norm();
  // Half-pixel noise on a 300 mm box at 1.5 m: errors of a few milliradians and millimetres,
  // and within 4 standard deviations of the estimate's own covariance.
  CHECK(rotation_error < 0.01);
  CHECK(translation_error < 0.01);
  Values truth_values;
  truth_values.poses = {truth};
  const Eigen::VectorXd e = LocalCoordinates(blocks, truth_values, state.mean);
  CHECK(std::sqrt(e.dot(state.covariance.ldlt().solve(e))) < 4 * std::sqrt(6.0));
}

}  // namespace
}  // namespace cfuse
