// The consistency checks every camera reader applies (docs/formats.md "Cameras"): cfuse's own
// camera object, OpenCV calibration files (cfuse/vision/camera_file.h) and ROS camera_info files
// (cfuse/dsl/measurement_reader.h) refuse the same things with the same words.
//
// A pinhole camera matrix must be
//       [fx  0 cx]
//   K = [ 0 fy cy]      fx, fy > 0, every entry finite,
//       [ 0  0  1]
// and the skew K[0][1] must be 0: cfuse's camera (cfuse/kernel/measurements/camera.h) has no skew
// term. OpenCV's calibrateCamera never estimates one; a file with one was made by another tool, and
// silently dropping it would move every projected point by skew * y'.
//
// Distortion: OpenCV's 0, 4, 5, 8, 12 or 14 coefficients, the tilted-sensor pair tau_x, tau_y
// (13th, 14th) zero: cfuse's camera has no tilt.
//
// The principal point is refused only when it lies outside [-width, 2 width] x [-height,
// 2 height]. A principal point somewhat outside the image is legitimate (a crop, a shifted
// lens), and the camera readers have no channel for warnings; one a whole image away is a camera
// matrix for another image size or a wrong unit.
//
// Each check returns what is wrong, and which entry, for the reader to locate in its file.
#pragma once

#include <optional>
#include <span>
#include <string>

#include "cfuse/kernel/measurements/camera.h"

namespace cfuse {

// An entry of a checked list and what is wrong with it.
struct CameraProblem {
  int index = -1;  // position in the list (row-major for a matrix); -1 = the list as a whole
  std::string message;
};

// K: 9 values, row-major.
std::optional<CameraProblem> CameraMatrixProblem(std::span<const double> K);

// OpenCV's distortion coefficients k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [tau_x tau_y]]]]: how
// many, finite, no tilt. A message starts with what follows the list's name ("has 3
// coefficients; ...", "coefficient 3 (p1) must be finite, ...").
std::optional<CameraProblem> DistortionProblem(std::span<const double> coefficients);

// The principal point (index 0 = cx, 1 = cy) against the image size (both >= 1).
std::optional<CameraProblem> PrincipalPointProblem(double cx, double cy, int width, int height);

// A width or height in pixels: a whole number in [1, 10^6].
bool IsImageSide(double pixels);

// The name of distortion coefficient i (0-based): "k1", ..., "tau_y".
const char* DistortionName(int i);

// The pinhole camera of a checked K, coefficients and image size (CFUSE_CHECK that the checks
// above pass).
Camera PinholeCamera(std::span<const double> K, std::span<const double> coefficients, int width,
                     int height);

}  // namespace cfuse
