// The P3P problem for a calibrated camera: the poses that put three object points on three
// bearings (up to four), by Persson & Nordberg's Lambda Twist (ECCV 2018). The two
// homogeneous quadrics in the depths meet a degenerate conic of their pencil (a root of a
// cubic), which splits into two planes through the origin; each plane meets the quadrics in
// at most two depth triples, polished by Newton's method.
//
// Why not OpenCV's solveP3P: the interpretation's image seeds make up to 2e5 calls a trial,
// and OpenCV's per-call matrix allocations took most of its time; its poses are also often
// 1e-3 rad off, since it does not polish its roots (tests/interp/closed_form_pose_test.cpp).
// No OpenCV here: the interpretation (interp/) calls it directly for its image seeds.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse {

// camera_from_object poses with λ_i bearing_i = R object_i + t and every depth λ_i > 0, for
// unit bearings in the camera frame: the number written to *poses (0 to 4). None for
// collinear or coincident object points or a degenerate view.
int ThreePointPoses(const std::array<Eigen::Vector3d, 3>& bearings,
                    const std::array<Eigen::Vector3d, 3>& object_points,
                    std::array<Rigid3d, 4>* poses);

// The unit bearing (camera frame) of a pixel of a pinhole camera, undistorted when the camera
// has distortion (undistort.h); false for any other camera model.
bool PixelBearing(const Camera& camera, const Eigen::Vector2d& pixel, Eigen::Vector3d* bearing);

// The same from three pixels of a pinhole camera, their bearings by PixelBearing.
// Empty for an orthographic camera or a degenerate triple.
std::vector<Rigid3d> PosesFromThreeProjections(const Camera& camera,
                                               const std::array<Eigen::Vector3d, 3>& object_points,
                                               const std::array<Eigen::Vector2d, 3>& image_points);

}  // namespace cfuse
