// What every command shares: the error tiers turned into messages and exit statuses, model
// files of any supported format, and files written whole or not at all.
#pragma once

#include <functional>
#include <ostream>
#include <string>

#include "constraints/graph.h"
#include "kernel/measurements/camera.h"

namespace cfuse::cli {

// Runs a command: InputError -> its message, status 2; InternalError and anything unexpected
// -> "cfuse: ..." and status 3; otherwise the body's status.
int Guarded(std::ostream& err, const std::function<int()>& body);

// A model from a file, by its extension: .yaml/.yml (the DSL, whose `include:` reads .urdf
// and .cao files too), .urdf (importers/urdf.h) or .cao (importers/cao.h).
ConstraintGraph LoadAnyModel(const std::string& path);

// A camera from a file of any supported format (docs/formats.md "Cameras"): an OpenCV
// FileStorage calibration (vision/camera_file.h, recognised by its first bytes), else cfuse's
// camera object or a ROS camera_info YAML (dsl/measurement_reader.h).
Camera LoadAnyCamera(const std::string& path);

// Writes `content` to `path` through a temporary file in the same directory, so that a
// failure never leaves a half-written file.
void WriteFileAtomically(const std::string& path, const std::string& content);

}  // namespace cfuse::cli
