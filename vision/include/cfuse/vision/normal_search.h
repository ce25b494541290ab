// Edge evidence by one-dimensional searches across a predicted edge (Harris's RAPiD, 1992; the
// moving edges of ViSP's tracker, Bouthemy 1989): where a model edge is predicted, the image is
// read along the edge's normal, a few pixels either way, and every place where the grey level
// steps across that normal is a hit. Only the pixels near the predicted edges are read, so a
// frame costs what the model's outline costs, not what the image holds: a real close-up full of
// texture costs no more than a rendered box on a plain background.
//
// The profile at a sample point p with unit normal n (tangent τ, n rotated by -90 degrees) is
//   P(k) = mean_{j = -h..h} I(p + k n + j τ),   k integer (bilinear interpolation),
// an average along the edge that suppresses texture at other orientations (like ViSP's
// oriented masks), and the step across the normal at k is the central difference
//   D(k) = P(k + 1) - P(k - 1)   (grey levels; an ideal step of contrast C gives D = C).
// A hit is a local maximum of |D| of at least `min_contrast`, placed by the parabola through |D|
// at k - 1, k, k + 1 (an ideal step between pixels k and k + 1 is found at k + 0.5). Its width
// is that of |D| above half its peak: about 2 px for a sharp step, 2 to 4 for a real edge, the
// motion for a step smeared by motion blur (whose |D| is a plateau: where on it the peak falls
// is noise, which the tracker counts in the edge's error, cfuse/track/edge_evidence.h). (Placing a
// wide step at its plateau's centroid was tried: it follows the shaded side of real edges,
// whose profiles are not symmetric, and moved a real close-up's track by 10 mm.) The run's width is
// the hit's: about 2 px for a sharp step, the motion for a blurred one. Its polarity is the sign
// of D: positive where the image is brighter on the side the normal points to.
//
// Coordinates: pixels, x right, y down, pixel centres at integer coordinates (camera.h).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/vision/segments.h"

namespace cfuse {

struct NormalSearchOptions {
  double min_contrast = 10;  // grey levels: |D| a hit needs
  int half_width = 2;        // px averaged either side along the edge (5 px in all)
  int max_hits = 4;          // the strongest hits kept per search
  // px: a hit wider than this at half its peak is a step smeared by motion (real edges are 2 to
  // 4 px wide), placed at its run's middle rather than at its peak.
  float smeared_width = 7;
};

struct ProfileHit {
  float offset = 0;    // px along the normal from the sample point
  float contrast = 0;  // D at the hit: signed, positive when brighter along +normal
  float width = 0;     // px: |D|'s width at half its peak
};

// The hits within `range` px of `point` along `normal` (unit), strongest first, at most
// `options.max_hits`, appended to `hits` (which is not cleared). Profile points whose tangent
// average leaves the image end the search on that side. Returns the number appended.
int SearchAlongNormal(const GrayView& image, const Eigen::Vector2f& point,
                      const Eigen::Vector2f& normal, float range,
                      const NormalSearchOptions& options, std::vector<ProfileHit>* hits);

}  // namespace cfuse
