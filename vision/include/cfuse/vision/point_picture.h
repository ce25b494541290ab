// A picture of 3D points and a fitted model, for people: two orthographic views side by side,
// along the model's principal axes (the view onto its largest spread, and a side view), with
// measurements coloured by what the interpretation made of them. Encoded as PNG bytes, so
// that the caller writes the file atomically.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace cfuse {

struct PictureMarker {
  enum class Kind {
    kClutter,     // a measurement left unmatched that is clutter (grey dot)
    kMatched,     // a measurement matched to its true model point (green ring)
    kWrong,       // a measurement matched wrongly, or a real one left unmatched (red cross)
    kModelPoint,  // a fitted model point (orange dot)
    kOccluded,    // a fitted model point with no measurement (orange ring)
  };
  Eigen::Vector3d xyz;
  Kind kind;
  std::string label;  // drawn next to model points when not empty
};

struct PictureSegment {
  Eigen::Vector3d a, b;  // a line of the fitted model (orange)
};

// PNG bytes of a width x height picture with `title` on top and a legend below.
std::string PointPicturePng(const std::vector<PictureMarker>& markers,
                            const std::vector<PictureSegment>& segments, const std::string& title,
                            int width = 1200, int height = 640);

}  // namespace cfuse
