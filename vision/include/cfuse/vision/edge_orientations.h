// Where an image has grey-level steps and which way they run, spread over a few pixels, for
// scoring many pose hypotheses cheaply: a model edge drawn at a hypothesis is supported at a
// sample when a step of about its orientation lies within `spread` px (the response maps of
// Hinterstoisser et al.'s LINE-2D, here for a score along projected edges rather than templates).
//
// Steps: the image smoothed by a Gaussian of σ = `sigma`, Sobel gradients, kept where the
// gradient's magnitude is a local maximum across the step (non-maximum suppression) and the step
// at least `min_contrast` grey levels. A step's orientation is its normal's direction modulo π,
// quantised into kOrientationBins bins. Each pixel holds a bit per bin set when a step of that bin
// lies within `spread` px (Chebyshev distance).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "cfuse/vision/segments.h"

namespace cfuse {

inline constexpr int kOrientationBins = 8;

struct EdgeOrientationOptions {
  double sigma = 1.0;         // px
  double min_contrast = 12;   // grey levels of an ideal step
  int spread = 2;             // px
};

class EdgeOrientations {
 public:
  EdgeOrientations() = default;
  // Throws InputError (its location left to the caller) for an empty image.
  EdgeOrientations(const GrayView& image, const EdgeOrientationOptions& options = {});

  int width() const { return width_; }
  int height() const { return height_; }

  // The bin of an edge whose normal points along `normal` (any length, either sign).
  static int Bin(const Eigen::Vector2d& normal);
  // Bits of bin and its two neighbours: an edge matches a step within 1.5 bins (34 degrees).
  static std::uint8_t Tolerant(int bin);

  // Whether a step of a bin in `mask` lies within the spread of pixel (x, y); false outside.
  bool Has(double x, double y, std::uint8_t mask) const {
    const int ix = static_cast<int>(x + 0.5), iy = static_cast<int>(y + 0.5);
    if (x < -0.5 || y < -0.5 || ix >= width_ || iy >= height_) return false;
    return (bits_[static_cast<size_t>(iy) * width_ + ix] & mask) != 0;
  }
  // The share of the image's pixels where a sample with Tolerant(bin) would be supported: what
  // chance gives a model edge of that orientation drawn anywhere.
  double Chance(int bin) const { return chance_[bin]; }
  // Steps found (before the spread), for tests and figures.
  int steps() const { return steps_; }


 private:
  int width_ = 0, height_ = 0, steps_ = 0;
  std::vector<std::uint8_t> bits_;
  std::array<double, kOrientationBins> chance_{};
};

}  // namespace cfuse
