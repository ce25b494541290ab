#include "cfuse/vision/pnp.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace cfuse {

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

}  // namespace cfuse
