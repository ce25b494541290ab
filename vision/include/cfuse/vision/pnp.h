// Pose from 2D-3D correspondences with OpenCV's SQPnP solver (globally optimal for n >= 3,
// planar or not), refined by Levenberg-Marquardt: the closed-form start of a rigid component
// seen only in an image (Hel-Or & Werman §7), for SolveOptions::pose_from_projections.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse {

// camera_from_object, or false for fewer than 4 points, an orthographic camera, or a failure.
bool PoseFromProjections(const Camera& camera, const std::vector<Eigen::Vector3d>& object_points,
                         const std::vector<Eigen::Vector2d>& image_points,
                         Rigid3d* camera_from_object);

}  // namespace cfuse
