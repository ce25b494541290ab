#include "cfuse/vision/pnp.h"

#include <algorithm>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "cfuse/vision/p3p.h"

namespace cfuse::vision {

bool PoseFromProjections(const Camera& camera, const std::vector<Eigen::Vector3d>& object_points,
                         const std::vector<Eigen::Vector2d>& image_points,
                         Rigid3d* camera_from_object) {
  if (camera.model != Camera::Model::kPinhole || object_points.size() < 4 ||
      object_points.size() != image_points.size()) {
    return false;
  }
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (size_t i = 0; i < object_points.size(); ++i) {
    object.emplace_back(object_points[i].x(), object_points[i].y(), object_points[i].z());
    image.emplace_back(image_points[i].x(), image_points[i].y());
  }
  const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const std::vector<double> dist(camera.distortion.begin(), camera.distortion.end());
  cv::Vec3d rvec, tvec;
  try {
    if (!cv::solvePnP(object, image, K, dist, rvec, tvec, false, cv::SOLVEPNP_SQPNP)) return false;
    cv::solvePnPRefineLM(object, image, K, dist, rvec, tvec);
  } catch (const cv::Exception&) {
    return false;  // degenerate input (e.g. all points on a line)
  }
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  cv::cv2eigen(cv::Mat(R), Re);
  *camera_from_object = Rigid3d(Re, Eigen::Vector3d(tvec[0], tvec[1], tvec[2]));
  return Re.allFinite() && camera_from_object->translation.allFinite();
}

std::vector<Rigid3d> PosesFromThreeProjections(const Camera& camera,
                                               const std::array<Eigen::Vector3d, 3>& object_points,
                                               const std::array<Eigen::Vector2d, 3>& image_points) {
  std::vector<Rigid3d> poses;
  if (camera.model != Camera::Model::kPinhole) return poses;
  // Bearings: the normalised image coordinates, undistorted by OpenCV when the camera has
  // distortion (its iterative inverse of the model in cfuse/kernel/measurements/camera.h).
  std::array<Eigen::Vector2d, 3> xy;
  if (std::all_of(camera.distortion.begin(), camera.distortion.end(),
                  [](double d) { return d == 0; })) {
    for (int i = 0; i < 3; ++i) {
      xy[i] = {(image_points[i].x() - camera.cx) / camera.fx,
               (image_points[i].y() - camera.cy) / camera.fy};
    }
  } else {
    std::vector<cv::Point2d> image, normalised;
    for (const Eigen::Vector2d& p : image_points) image.emplace_back(p.x(), p.y());
    const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    const std::vector<double> dist(camera.distortion.begin(), camera.distortion.end());
    cv::undistortPoints(image, normalised, K, dist);
    for (int i = 0; i < 3; ++i) xy[i] = {normalised[i].x, normalised[i].y};
  }
  std::array<Eigen::Vector3d, 3> bearings;
  for (int i = 0; i < 3; ++i) bearings[i] = Eigen::Vector3d(xy[i].x(), xy[i].y(), 1).normalized();
  std::array<Rigid3d, 4> found;
  const int n = ThreePointPoses(bearings, object_points, &found);
  poses.assign(found.begin(), found.begin() + n);
  return poses;
}

}  // namespace cfuse::vision
