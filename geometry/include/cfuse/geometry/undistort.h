// A pixel of a pinhole camera back to the normalised image plane (x/z, y/z), its lens distortion
// (cfuse/kernel/measurements/camera.h) undone.
//
// The distortion has no closed-form inverse. This is OpenCV's cv::undistortPoints with its
// default criteria, step for step: from the distorted point, five fixed-point iterations
//   x ← (x_d − Δx(x, y)) (1 + k4 r² + k5 r⁴ + k6 r⁶) / (1 + k1 r² + k2 r⁴ + k3 r⁶),
// y likewise, stopped (and the distorted point returned) where that ratio turns negative. The
// same arithmetic as OpenCV's, so that the interpretation's P3P seeds, whose bearings OpenCV
// undistorted before, are the same to the bit (tests/geometry/undistort_test.cpp).
#pragma once

#include <Eigen/Core>

#include "cfuse/kernel/measurements/camera.h"

namespace cfuse {

// The normalised image coordinates of `pixel` (finite) for a pinhole camera.
Eigen::Vector2d UndistortPoint(const Camera& camera, const Eigen::Vector2d& pixel);

}  // namespace cfuse
