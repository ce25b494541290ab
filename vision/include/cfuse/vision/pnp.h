// Pose from 2D-3D correspondences with OpenCV's SQPnP solver (globally optimal for n >= 3,
// planar or not), refined by Levenberg-Marquardt: the closed-form start of a rigid component
// seen only in an image (Hel-Or & Werman §7). Fits interp::PoseFromProjections.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse::vision {

// camera_from_object, or false for fewer than 4 points, an orthographic camera, or a failure.
bool PoseFromProjections(const Camera& camera, const std::vector<Eigen::Vector3d>& object_points,
                         const std::vector<Eigen::Vector2d>& image_points,
                         Rigid3d* camera_from_object);

// Up to four poses camera_from_object from exactly three correspondences (cfuse/vision/p3p.h, on
// bearings undistorted by OpenCV): the seed hypotheses of the interpretation tree for image data.
// Empty for an orthographic camera or a degenerate triple. Fits PosesFromThreeProjections
// (cfuse/interp/interpretation.h).
std::vector<Rigid3d> PosesFromThreeProjections(const Camera& camera,
                                               const std::array<Eigen::Vector3d, 3>& object_points,
                                               const std::array<Eigen::Vector2d, 3>& image_points);

}  // namespace cfuse::vision
