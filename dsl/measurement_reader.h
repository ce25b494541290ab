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

#include "kernel/measurement_set.h"

namespace cfuse::dsl {

inline constexpr size_t kMaxMeasurementFileBytes = 64u << 20;
inline constexpr int kMaxMeasuredPoints = 1000000;

MeasurementSet ReadMeasurements(const std::string& path);
MeasurementSet ReadMeasurementsFromString(std::string_view text, const std::string& display_name);

// The camera object alone (also used by commands that take a camera file).
Camera ReadCameraFile(const std::string& path);

}  // namespace cfuse::dsl
