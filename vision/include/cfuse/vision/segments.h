// Straight line segments from a grey image: Lowe's detector (Lowe 1987; 1992, "Real-time line
// detection") and two alternatives behind one interface, for the tracker's matching.
//
// Lowe's detector, stage by stage (the stages are timed separately, StageTimes):
//  1. smoothing: the image in float, a Gaussian of σ = 1.2 px, then the 3 x 3 Laplacian
//     (together the Laplacian of Gaussian, LoG);
//  2. edges: a zero crossing wherever the LoG changes sign between two 4-neighbours; the
//     edge pixel is the one of the two nearer the crossing, placed at the crossing itself to
//     sub-pixel precision (linear interpolation of the LoG), and its strength is the LoG's
//     slope across it, which is proportional to the smoothed image's gradient there. Strengths
//     are expressed as the contrast (grey levels) of the ideal step edge that has them, so the
//     thresholds read as edge contrasts. Hysteresis: crossings of at least `high_contrast` seed
//     edges, which grow through 8-connected crossings of at least `low_contrast`;
//  3. linking: the kept edge pixels traced into chains through their 8-neighbours, a chain
//     ending where it meets no unvisited neighbour (so junctions split chains);
//  4. subdivision: each chain split recursively at its point farthest from the chord; a piece's
//     significance is its length over that deviation (at least `min_deviation`), and a piece
//     is replaced by its sub-pieces when one of them is more significant than it is (Lowe 1987:
//     the most significant level of the subdivision tree). Each kept piece becomes a segment
//     by a least-squares line through its points, ended by projecting its end points on it.
//     Pieces shorter than `min_length` are dropped.
// Canny: cv::Canny on the Gaussian-smoothed image (thresholds on the gradient magnitude, from the
// same contrasts), then the same linking and subdivision on whole pixels. LSD: OpenCV's line
// segment detector (von Gioi et al.), as it comes (its whole run timed as `edges`).
//
// Coordinates: pixels, x right, y down, pixel centres at integer coordinates.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace cfuse {

// A grey image in memory, 8 bits per pixel, rows `step` bytes apart (not owned).
struct GrayView {
  const std::uint8_t* data = nullptr;
  int width = 0, height = 0;
  int step = 0;
};

// A rectangle of pixels: columns [x, x + width), rows [y, y + height).
struct PixelRect {
  int x = 0, y = 0, width = 0, height = 0;
};

struct ImageSegment {
  Eigen::Vector2f a = Eigen::Vector2f::Zero(), b = Eigen::Vector2f::Zero();
  float strength = 0;  // mean edge contrast along it (grey levels); LSD: OpenCV's width

  float Length() const { return (b - a).norm(); }
  // Direction in [0, π): a segment has no arrow.
  float Orientation() const;
};

enum class SegmentDetector { kLowe, kCanny, kLsd };
const char* DetectorName(SegmentDetector detector);
std::optional<SegmentDetector> ParseDetector(const std::string& name);

struct SegmentOptions {
  SegmentDetector detector = SegmentDetector::kLowe;
  double sigma = 1.2;            // px: the Gaussian of the LoG (and of Canny's smoothing)
  double high_contrast = 20;     // grey levels: an edge this strong starts a chain
  double low_contrast = 8;       // grey levels: an edge this strong continues one
  double min_length = 8;         // px: shorter segments are dropped
  double min_deviation = 0.75;   // px: the floor of a piece's deviation in its significance
  std::optional<PixelRect> roi;  // only this window is processed
};

// Milliseconds per stage of the last detection.
struct StageTimes {
  double smoothing = 0, edges = 0, linking = 0, subdivision = 0;
  double Total() const { return smoothing + edges + linking + subdivision; }
};

// The segments of `image`. Throws InputError (its location left to the caller, who knows the file)
// for an empty image or a region of interest not inside it (the CLI reports both as bad input);
// detector parameters out of range are the caller's mistake and fail a CFUSE_CHECK.
std::vector<ImageSegment> DetectSegments(const GrayView& image, const SegmentOptions& options,
                                         StageTimes* times = nullptr);

// Lowe's subdivision alone, on an ordered chain of points: the segments of its most significant
// level (exposed for tests).
std::vector<ImageSegment> SubdivideChain(const std::vector<Eigen::Vector2f>& chain,
                                         double min_deviation, double min_length);

}  // namespace cfuse
