// PnP (cfuse/geometry/pnp.h): exact on exact data, the least-squares pose OpenCV's SQPnP finds
// on noisy data, undisturbed by gross outliers that pull SQPnP away, and refusals for what
// cannot give a pose.
#include "cfuse/geometry/pnp.h"

#include <catch2/catch.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <random>

#include "test_util.h"

namespace cfuse {
namespace {

struct Scene {
  std::vector<Eigen::Vector3d> object;
  std::vector<Eigen::Vector2d> image;
  Rigid3d truth;
};

// n points within a 0.4 m cube (flat when `planar`), seen from a random pose 1-3 m away,
// pixels with Gaussian noise of `noise` px.
Scene RandomScene(std::mt19937& rng, const Camera& camera, int n, bool planar, double noise) {
  std::uniform_real_distribution<double> u(-0.2, 0.2), depth(1, 3);
  std::normal_distribution<double> g(0, 1), pixel(0, noise);
  Scene s;
  s.truth = Rigid3d(Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized(),
                    Eigen::Vector3d(u(rng), u(rng), depth(rng)));
  while (static_cast<int>(s.object.size()) < n) {
    const Eigen::Vector3d p(u(rng), u(rng), planar ? 0.0 : u(rng));
    const Eigen::Vector3d in_camera = s.truth * p;
    if (in_camera.z() < 0.3) continue;  // keep every point well in front
    s.object.push_back(p);
    s.image.push_back(camera.Project<double>(in_camera) + Eigen::Vector2d(pixel(rng), pixel(rng)));
  }
  return s;
}

double RmsError(const Camera& camera, const Scene& s, const Rigid3d& pose) {
  double sum = 0;
  for (size_t i = 0; i < s.object.size(); ++i) {
    sum += (camera.Project<double>(pose * s.object[i]) - s.image[i]).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(s.object.size()));
}

double Turn(const Rigid3d& a, const Rigid3d& b) { return a.rotation.angularDistance(b.rotation); }

// OpenCV's SQPnP refined by Levenberg-Marquardt on all points: the reference least-squares pose.
Rigid3d OpenCvPose(const Camera& camera, const Scene& s) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (size_t i = 0; i < s.object.size(); ++i) {
    object.emplace_back(s.object[i].x(), s.object[i].y(), s.object[i].z());
    image.emplace_back(s.image[i].x(), s.image[i].y());
  }
  const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const std::vector<double> dist(camera.distortion.begin(), camera.distortion.begin() + 8);
  cv::Vec3d rvec, tvec;
  REQUIRE(cv::solvePnP(object, image, K, dist, rvec, tvec, false, cv::SOLVEPNP_SQPNP));
  cv::solvePnPRefineLM(object, image, K, dist, rvec, tvec);
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d rotation;
  cv::cv2eigen(cv::Mat(R), rotation);
  return Rigid3d(rotation, Eigen::Vector3d(tvec[0], tvec[1], tvec[2]));
}

TEST_CASE("pnp: exact data give the exact pose, planar or not, with lens distortion",
          "[geometry]") {
  std::mt19937 rng(5);
  Camera camera = testing::Pinhole();
  camera.distortion[0] = -0.08;
  camera.distortion[1] = 0.02;
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 4 + trial % 9;
    const Scene s = RandomScene(rng, camera, n, trial % 2 == 0, 0);
    PnpResult r;
    INFO("trial " << trial << ", " << n << " points");
    REQUIRE(PoseFromProjections(camera, s.object, s.image, &r));
    CHECK(Turn(r.camera_from_object, s.truth) < 1e-6);
    CHECK((r.camera_from_object.translation - s.truth.translation).norm() < 1e-6);
    CHECK(static_cast<int>(r.inliers.size()) == n);
  }
}

TEST_CASE("pnp: on noisy data, the least-squares pose that OpenCV's SQPnP finds", "[geometry]") {
  // SQPnP is globally optimal for the squared error; the refined pose here must fit as well.
  std::mt19937 rng(7);
  const Camera camera = testing::Pinhole();
  int as_good = 0;
  const int trials = 60;
  for (int trial = 0; trial < trials; ++trial) {
    const Scene s = RandomScene(rng, camera, 6 + trial % 20, trial % 3 == 0, 0.5);
    PnpResult r;
    REQUIRE(PoseFromProjections(camera, s.object, s.image, &r));
    const double ours = RmsError(camera, s, r.camera_from_object);
    const double reference = RmsError(camera, s, OpenCvPose(camera, s));
    INFO("trial " << trial << ": rms " << ours << " px against " << reference);
    CHECK(r.rms_error == Approx(ours).epsilon(0.02));  // the same points, nothing dropped
    as_good += ours <= reference * 1.001 + 1e-9;
  }
  CHECK(as_good == trials);
}

TEST_CASE("pnp: a gross outlier is left out, where SQPnP is pulled away", "[geometry]") {
  // The pose must be the least-squares pose of the other points; SQPnP, fitting all of them,
  // is pulled away from it.
  std::mt19937 rng(9);
  const Camera camera = testing::Pinhole();
  int as_good = 0, sqpnp_pulled = 0;
  const int trials = 30;
  for (int trial = 0; trial < trials; ++trial) {
    Scene s = RandomScene(rng, camera, 5 + trial % 6, trial % 2 == 0, 0.5);
    const size_t bad = static_cast<size_t>(trial) % s.image.size();
    Scene clean = s;
    clean.object.erase(clean.object.begin() + static_cast<std::ptrdiff_t>(bad));
    clean.image.erase(clean.image.begin() + static_cast<std::ptrdiff_t>(bad));
    // Anywhere in the image at least 100 px from where it belongs.
    std::uniform_real_distribution<double> u(0, camera.width), v(0, camera.height);
    Eigen::Vector2d elsewhere;
    do {
      elsewhere = Eigen::Vector2d(u(rng), v(rng));
    } while ((elsewhere - s.image[bad]).norm() < 100);
    s.image[bad] = elsewhere;
    PnpResult r;
    REQUIRE(PoseFromProjections(camera, s.object, s.image, &r));
    INFO("trial " << trial);
    CHECK(std::find(r.inliers.begin(), r.inliers.end(), static_cast<int>(bad)) == r.inliers.end());
    CHECK(static_cast<int>(r.inliers.size()) == static_cast<int>(s.image.size()) - 1);
    const Rigid3d reference = OpenCvPose(camera, clean);
    as_good += RmsError(camera, clean, r.camera_from_object) <=
               RmsError(camera, clean, reference) * 1.001 + 1e-9;
    sqpnp_pulled += Turn(OpenCvPose(camera, s), reference) > 5 * M_PI / 180;
  }
  CHECK(as_good == trials);
  CHECK(sqpnp_pulled >= 2 * trials / 3);  // why the start of a solve does not use it
}

TEST_CASE("pnp: many points: hypotheses from a fixed draw of triples, reproducible", "[geometry]") {
  std::mt19937 rng(3);
  const Camera camera = testing::Pinhole();
  Scene s = RandomScene(rng, camera, 80, false, 0.3);
  for (size_t i = 0; i < 20; ++i) s.image[i * 4] += Eigen::Vector2d(40.0 + i, -35.0);
  PnpResult first, second;
  REQUIRE(PoseFromProjections(camera, s.object, s.image, &first));
  REQUIRE(PoseFromProjections(camera, s.object, s.image, &second));
  CHECK(first.camera_from_object.translation == second.camera_from_object.translation);
  CHECK(first.inliers == second.inliers);
  CHECK(first.inliers.size() == 60);
  CHECK(Turn(first.camera_from_object, s.truth) < 0.5 * M_PI / 180);
  CHECK(first.rms_error < 1.0);
}

TEST_CASE("pnp: refuses what gives no pose", "[geometry]") {
  std::mt19937 rng(1);
  const Camera camera = testing::Pinhole();
  const Scene s = RandomScene(rng, camera, 6, false, 0);
  PnpResult r;
  r.rms_error = -1;
  const std::vector<Eigen::Vector3d> three(s.object.begin(), s.object.begin() + 3);
  const std::vector<Eigen::Vector2d> three_px(s.image.begin(), s.image.begin() + 3);
  CHECK_FALSE(PoseFromProjections(camera, three, three_px, &r));
  CHECK_FALSE(PoseFromProjections(camera, s.object, three_px, &r));  // sizes differ
  Camera orthographic = camera;
  orthographic.model = Camera::Model::kOrthographic;
  CHECK_FALSE(PoseFromProjections(orthographic, s.object, s.image, &r));
  std::vector<Eigen::Vector2d> nan_px = s.image;
  nan_px[2].x() = std::nan("");
  CHECK_FALSE(PoseFromProjections(camera, s.object, nan_px, &r));
  // All object points on one line: no triple fixes a rotation about it.
  std::vector<Eigen::Vector3d> line;
  std::vector<Eigen::Vector2d> line_px;
  for (int i = 0; i < 6; ++i) {
    line.emplace_back(0.1 * i, 0, 0);
    line_px.push_back(camera.Project<double>(s.truth * line.back()));
  }
  CHECK_FALSE(PoseFromProjections(camera, line, line_px, &r));
  CHECK(r.rms_error == -1);  // nothing written on refusal
}

}  // namespace
}  // namespace cfuse
