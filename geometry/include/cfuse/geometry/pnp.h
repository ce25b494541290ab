// The pose of a rigid object from n >= 4 of its points seen in one calibrated image (PnP): the
// closed-form start of a component measured only in an image (Hel-Or & Werman §7).
//
// Hypotheses come from P3P (p3p.h) on triples of the correspondences: every triple up to
// kMaxTriples of them, else that many drawn with a fixed seed. Each hypothesis is scored by the
// median of its squared reprojection errors (least median of squares, Rousseeuw 1984): no noise
// level needs to be known, and up to half of the points may be gross outliers or behind the
// camera (those count as infinitely far). The best is refined by Levenberg–Marquardt on the
// points within 2.5 robust standard deviations of it, the inliers found again once.
//
// Why not OpenCV's SQPnP: it minimises the squared error over all points, so one gross outlier
// pulls the start; the start of a solve must survive outliers, which the solve then rejects
// (SolveOptions::reject_outliers). And the interpretation needs no OpenCV.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse {

struct PnpResult {
  Rigid3d camera_from_object;
  std::vector<int> inliers;  // indices of the correspondences the pose was refined on
  double rms_error = 0;      // of the inliers' reprojection errors, pixels (fx, fy scaled)
};

// camera_from_object for a pinhole camera (its distortion undone), or false for fewer than 4
// correspondences, an orthographic camera, points that are not finite, or no non-degenerate
// triple (all object points on one line). object_points and image_points pair by index.
bool PoseFromProjections(const Camera& camera, const std::vector<Eigen::Vector3d>& object_points,
                         const std::vector<Eigen::Vector2d>& image_points, PnpResult* result);

}  // namespace cfuse
