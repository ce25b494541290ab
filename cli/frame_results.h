// The results of the image commands for one tracked or detected frame (docs/formats.md,
// "Detections"): the poses with their covariances, the joints, the fit of the matched edges and
// the verification of the outline; and a whole detection, as `cfuse detect` writes it.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "cfuse/constraints/graph.h"
#include "cfuse/track/detector.h"
#include "cfuse/track/tracker.h"

namespace cfuse::cli {

nlohmann::json FrameJson(const ConstraintGraph& graph, const TrackedFrame& frame);

// `image`: what the image is called in the result (its file).
nlohmann::json DetectionJson(const ConstraintGraph& graph, const Detection& detection,
                             const std::string& image);

}  // namespace cfuse::cli
