// Measurements as read from a file (formats: docs/formats.md): 3D points with covariance, 2D
// image points with the camera that saw them, each optionally labelled with the model point
// it measures. Plain data; readers (dsl/) fill it, estimators (interp/) use it.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "cfuse/kernel/error.h"
#include "cfuse/kernel/measurements/camera.h"

namespace cfuse {

struct MeasuredPoint {
  bool is_3d = true;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();   // 3D, viewer frame, metres
  Eigen::Matrix3d cov3 = Eigen::Matrix3d::Zero();  // 3D covariance, m²
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();    // 2D, pixels
  Eigen::Matrix2d cov2 = Eigen::Matrix2d::Zero();  // 2D covariance, px²
  std::string label;                               // model point, or empty
  SourceLocation where;                            // the entry in its file
};

struct MeasurementSet {
  std::string source;            // the file
  std::optional<Camera> camera;  // present when 2D points are
  std::vector<MeasuredPoint> points;
};

// Contract for a set built in code (the readers refuse such files as bad input): image points
// come with a camera, and every value and covariance is finite (InternalError if not).
void CheckMeasurementSet(const MeasurementSet& set);

}  // namespace cfuse
