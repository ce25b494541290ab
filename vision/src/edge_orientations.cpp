#include "cfuse/vision/edge_orientations.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "cfuse/kernel/error.h"

namespace cfuse {
namespace {

// Sobel gradients of `image` smoothed by a Gaussian of `sigma`.
void Gradients(const cv::Mat& image, double sigma, cv::Mat* gx, cv::Mat* gy) {
  cv::Mat smooth;
  image.convertTo(smooth, CV_32F);
  cv::GaussianBlur(smooth, smooth, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
  cv::Sobel(smooth, *gx, CV_32F, 1, 0, 3, 1, 0, cv::BORDER_REPLICATE);
  cv::Sobel(smooth, *gy, CV_32F, 0, 1, 3, 1, 0, cv::BORDER_REPLICATE);
}

// The gradient magnitude an ideal step of one grey level gives at its steepest, with the same
// filters: the thresholds then read as contrasts.
double StepResponse(double sigma) {
  cv::Mat step(32, 32, CV_8U, cv::Scalar(0));
  step.colRange(16, 32).setTo(100);
  cv::Mat gx, gy;
  Gradients(step, sigma, &gx, &gy);
  double most = 0;
  cv::minMaxLoc(cv::abs(gx), nullptr, &most);
  return most / 100;
}

}  // namespace

int EdgeOrientations::Bin(const Eigen::Vector2d& normal) {
  double angle = std::atan2(normal.y(), normal.x());
  if (angle < 0) angle += M_PI;
  if (angle >= M_PI) angle -= M_PI;  // atan2 gives π for a normal along -x
  int bin = static_cast<int>(angle / (M_PI / kOrientationBins));
  return std::clamp(bin, 0, kOrientationBins - 1) % kOrientationBins;
}

std::uint8_t EdgeOrientations::Tolerant(int bin) {
  const int n = kOrientationBins;
  return static_cast<std::uint8_t>((1u << bin) | (1u << ((bin + 1) % n)) |
                                   (1u << ((bin + n - 1) % n)));
}

EdgeOrientations::EdgeOrientations(const GrayView& image, const EdgeOrientationOptions& options) {
  if (image.data == nullptr || image.width <= 0 || image.height <= 0) {
    throw InputError(SourceLocation(), "an empty image has no edges to score");
  }
  width_ = image.width;
  height_ = image.height;
  const cv::Mat view(height_, width_, CV_8U, const_cast<std::uint8_t*>(image.data),
                     static_cast<size_t>(image.step));
  cv::Mat gx, gy;
  Gradients(view, options.sigma, &gx, &gy);
  const double threshold = options.min_contrast * StepResponse(options.sigma);
  const float t2 = static_cast<float>(threshold * threshold);
  cv::Mat magnitude2 = gx.mul(gx) + gy.mul(gy);

  // Steps: local maxima of the magnitude across the step, binned by their normal's direction.
  std::vector<std::uint8_t> steps(static_cast<size_t>(width_) * height_, 0);
  for (int y = 1; y + 1 < height_; ++y) {
    const float* m = magnitude2.ptr<float>(y);
    const float* up = magnitude2.ptr<float>(y - 1);
    const float* down = magnitude2.ptr<float>(y + 1);
    const float* dx = gx.ptr<float>(y);
    const float* dy = gy.ptr<float>(y);
    for (int x = 1; x + 1 < width_; ++x) {
      if (m[x] < t2) continue;
      // The two neighbours across the step, its normal rounded to 45 degrees.
      const float ax = std::abs(dx[x]), ay = std::abs(dy[x]);
      float n1, n2;
      if (ay <= 0.414f * ax) {
        n1 = m[x - 1], n2 = m[x + 1];
      } else if (ax <= 0.414f * ay) {
        n1 = up[x], n2 = down[x];
      } else if ((dx[x] > 0) == (dy[x] > 0)) {
        n1 = up[x - 1], n2 = down[x + 1];
      } else {
        n1 = up[x + 1], n2 = down[x - 1];
      }
      if (m[x] < n1 || m[x] <= n2) continue;
      steps[static_cast<size_t>(y) * width_ + x] =
          static_cast<std::uint8_t>(1u << Bin(Eigen::Vector2d(dx[x], dy[x])));
      ++steps_;
    }
  }
  // Spread over (2 r + 1)² pixels, rows then columns.
  const int r = std::max(0, options.spread);
  std::vector<std::uint8_t> rows(steps.size(), 0);
  for (int y = 0; y < height_; ++y) {
    const std::uint8_t* in = &steps[static_cast<size_t>(y) * width_];
    std::uint8_t* out = &rows[static_cast<size_t>(y) * width_];
    for (int x = 0; x < width_; ++x) {
      if (in[x] == 0) continue;
      for (int k = std::max(0, x - r); k <= std::min(width_ - 1, x + r); ++k) out[k] |= in[x];
    }
  }
  bits_.assign(steps.size(), 0);
  for (int y = 0; y < height_; ++y) {
    const std::uint8_t* in = &rows[static_cast<size_t>(y) * width_];
    for (int k = std::max(0, y - r); k <= std::min(height_ - 1, y + r); ++k) {
      std::uint8_t* out = &bits_[static_cast<size_t>(k) * width_];
      for (int x = 0; x < width_; ++x) out[x] |= in[x];
    }
  }
  std::array<long, kOrientationBins> count{};
  for (const std::uint8_t b : bits_) {
    if (b == 0) continue;
    for (int bin = 0; bin < kOrientationBins; ++bin) count[bin] += (b & Tolerant(bin)) != 0;
  }
  for (int bin = 0; bin < kOrientationBins; ++bin) {
    chance_[bin] = static_cast<double>(count[bin]) / static_cast<double>(bits_.size());
  }
}

}  // namespace cfuse
