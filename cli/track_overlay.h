// A tracked frame drawn as in Lowe's figures 3-7: the image in grey, the predicted edges' 2σ
// regions shaded (where the search looked), the model at the frame's estimate in yellow when
// the frame is verified and red when it is lost, and the matched image segments in green.
// Drawn here, with OpenCV, for `cfuse track --overlay` and the demo: the tracker (track/) needs
// no OpenCV and names none of its types.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "cfuse/track/tracker.h"

namespace cfuse::cli {

struct OverlayOptions {
  bool regions = true;   // the 2σ regions of the predicted edges
  bool segments = true;  // the matched image segments
  std::string caption;   // top left, e.g. "frame 12  verified  0.9 ms"
};

// The overlay as a BGR image of the frame's size.
cv::Mat3b DrawOverlay(const GrayView& image, const ConstraintGraph& graph,
                      const Camera& camera, const TrackedFrame& frame,
                      const OverlayOptions& options = {});

}  // namespace cfuse::cli
