// Reading measurement files (docs/formats.md): JSON, or the same structure in YAML.
//
//   {"camera": {"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640, "height": 480,
//               "dist": [0, 0, 0, 0, 0]},
//    "points": [{"xyz": [0.1, 0.2, 1.5], "sigma": 0.002, "label": "p3"},
//               {"uv": [321.5, 200.25], "cov": [[1, 0], [0, 1]], "label": "box.c000"}]}
//
// Every problem (a missing key, a wrong length, a covariance that is not positive definite,
// NaN or infinity, a 2D point without a camera) is an InputError naming the file, the line
// and column, and the entry (e.g. "points[3]").
#pragma once

#include <string>
#include <string_view>

#include "cfuse/kernel/measurement_set.h"

namespace cfuse {

inline constexpr size_t kMaxMeasurementFileBytes = 64u << 20;
inline constexpr int kMaxMeasuredPoints = 1000000;

MeasurementSet ReadMeasurements(const std::string& path);
MeasurementSet ReadMeasurementsFromString(std::string_view text, const std::string& display_name);

// A camera file (docs/formats.md "Cameras"): cfuse's camera object, at the top or under
// `camera`, or a ROS camera_info YAML (image_width, image_height, camera_matrix {rows, cols,
// data}, distortion_model plumb_bob or rational_polynomial, distortion_coefficients; the
// rectification and projection matrices checked for shape, not used). The checks of
// cfuse/kernel/measurements/camera_checks.h apply to both, located at file:line:column. OpenCV's
// FileStorage files are read by cfuse/vision/camera_file.h; the CLI picks the reader.
Camera ReadCameraFile(const std::string& path);
Camera ReadCameraFromString(std::string_view text, const std::string& display_name);

}  // namespace cfuse
