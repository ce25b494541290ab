// Synthetic camera images of a model with their ground truth, for the detector's tests and
// benchmarks and the tracker's test sequences (`cfuse render`).
//
// The scene: a background of random grey levels with clutter (straight lines of 1-3 px and
// filled ellipses) drawn in dark greys (20-110), then every front face of the model filled
// with a z-buffer (each pixel takes the nearest face: parts hide each other), in light greys
// (140-240): a Lambertian shade under a light from the upper left, times an albedo that
// alternates between neighbouring faces so that every edge between two faces shows, as
// on a printed box. Then a Gaussian blur and Gaussian noise.
//
// The truth: each visible model edge (model_edges.h) sampled every half pixel against the
// z-buffer; the runs where it is the front surface, and where the image shows it (a contrast
// across it), are the visible segments. The camera must
// be a pinhole without distortion, or orthographic (the faces are filled as straight-sided
// polygons).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "constraints/graph.h"
#include "kernel/measurements/camera.h"
#include "vision/model_edges.h"

namespace cfuse::vision {

struct RenderOptions {
  unsigned seed = 1;
  int clutter_lines = 30;
  int clutter_blobs = 12;
  double blur = 0.8;   // px, the Gaussian's sigma (0: none)
  double noise = 2.0;  // grey levels, the noise's sigma
  // Grey levels: a stretch of edge shows (and is true) where the image differs by this much
  // either side of it.
  double min_contrast = 15;
  // Polygons (pixels) drawn in front of everything in a dark grey: occluders, which hide the
  // edges behind them from the truth too.
  std::vector<std::vector<Eigen::Vector2d>> occluders;
  int occluder_grey = 45;
};

struct TruthSegment {
  int edge = -1;  // index into ModelEdges()
  Eigen::Vector2d a, b;
};

struct Rendering {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;  // row-major, 8-bit grey
  std::vector<TruthSegment> truth;   // the visible parts of the model's edges
};

// Throws std::invalid_argument for a camera without a size, over 2^28 pixels, or with distortion.
Rendering Render(const ConstraintGraph& graph, const Values& values, const Camera& camera,
                 const RenderOptions& options = {});

// The PNG bytes of an 8-bit grey image.
std::vector<std::uint8_t> EncodePng(const std::vector<std::uint8_t>& pixels, int width, int height);

}  // namespace cfuse::vision
