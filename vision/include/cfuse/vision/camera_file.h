// Cameras from OpenCV calibration files: what OpenCV's calibration sample and tutorial write, or
// any program that writes
//
//   cv::FileStorage fs("camera.yml", cv::FileStorage::WRITE);
//   fs << "image_width" << 640 << "image_height" << 480
//      << "camera_matrix" << K << "distortion_coefficients" << D;
//
// in YAML (`%YAML:1.0`, matrices tagged `!!opencv-matrix`), XML (`<opencv_storage>`) or JSON
// (matrices with `"type_id": "opencv-matrix"`). Read with cv::FileStorage; the nodes used:
//
//   camera_matrix              3x3, [fx 0 cx; 0 fy cy; 0 0 1]
//   distortion_coefficients    1xN or Nx1 (or a plain list), N in {4, 5, 8, 12, 14}, OpenCV's
//                              order k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [tau_x tau_y]]]]
//   image_width, image_height  whole pixels
//   fisheye_model              (the tutorial's flag) must be 0 when present: a fisheye
//                              calibration's coefficients are another model
//
// every other node is ignored. The checks of cfuse/kernel/measurements/camera_checks.h apply: no
// skew, no tilt (tau_x = tau_y = 0), a principal point within a whole image of the image. Every
// problem is an InputError at the file and the node, e.g. `cam.yml: camera_matrix: error:
// missing` (cv::FileStorage keeps no line numbers for nodes); a syntax error carries the line
// OpenCV reports. Text whose structure is incomplete or not well formed (an unclosed tag,
// string or bracket, an unquoted XML attribute), on which OpenCV's parsers may crash, is refused
// at its line and column before OpenCV sees it (vision/src/file_storage_screen.h).
#pragma once

#include <string>
#include <string_view>

#include "cfuse/kernel/measurements/camera.h"

namespace cfuse {

// Whether the file begins like one of cv::FileStorage's formats: `%YAML:1.` (OpenCV's own
// spelling of the directive, which standard YAML writes `%YAML 1.x`), an XML document whose root
// is `<opencv_storage>`, or JSON naming an `opencv-matrix` in its first 4 KiB. False for a file
// that cannot be read (the reader of the other formats then says why).
bool IsOpenCvStorage(const std::string& path);

// The pinhole camera of an OpenCV calibration file.
Camera ReadOpenCvCamera(const std::string& path);

// The same from text in memory (any of the three formats); `display_name` stands for the file in
// messages. Any text is safe: what OpenCV cannot read is an InputError, never a crash.
Camera ReadOpenCvCameraFromString(std::string_view text, const std::string& display_name);

}  // namespace cfuse
