#include "cfuse/vision/segment_index.h"

#include <algorithm>
#include <cmath>

namespace cfuse {
namespace {

constexpr float kPi = static_cast<float>(M_PI);

// |a - b| modulo π, in [0, π/2].
float OrientationDistance(float a, float b) {
  float d = std::fmod(std::abs(a - b), kPi);
  return std::min(d, kPi - d);
}

}  // namespace

SegmentIndex::SegmentIndex(std::vector<ImageSegment> segments, int width, int height, float cell,
                           int orientation_bins)
    : segments_(std::move(segments)),
      cell_(std::max(cell, 1.f)),
      nx_(std::max(1, static_cast<int>(std::ceil(std::max(width, 1) / cell_)))),
      ny_(std::max(1, static_cast<int>(std::ceil(std::max(height, 1) / cell_)))),
      nbins_(std::max(1, orientation_bins)) {
  const int n = static_cast<int>(segments_.size());
  std::vector<int> cell_of(n);
  start_.assign(static_cast<size_t>(nx_) * ny_ * nbins_ + 1, 0);
  for (int i = 0; i < n; ++i) {
    const ImageSegment& s = segments_[i];
    orientation_.push_back(s.Orientation());
    midpoint_.push_back(0.5f * (s.a + s.b));
    cell_of[i] = (Bin(orientation_[i]) * ny_ + CellY(midpoint_[i].y())) * nx_ +
                 CellX(midpoint_[i].x());
    ++start_[cell_of[i] + 1];
  }
  for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
  ids_.resize(n);
  std::vector<int> fill(start_.begin(), start_.end() - 1);
  for (int i = 0; i < n; ++i) ids_[fill[cell_of[i]]++] = i;
}

int SegmentIndex::CellX(float x) const {
  return std::clamp(static_cast<int>(std::floor(x / cell_)), 0, nx_ - 1);
}
int SegmentIndex::CellY(float y) const {
  return std::clamp(static_cast<int>(std::floor(y / cell_)), 0, ny_ - 1);
}
int SegmentIndex::Bin(float orientation) const {
  float o = std::fmod(orientation, kPi);
  if (o < 0) o += kPi;
  return std::clamp(static_cast<int>(o / kPi * static_cast<float>(nbins_)), 0, nbins_ - 1);
}

void SegmentIndex::Query(const Eigen::Vector2f& centre, float radius, float orientation,
                         float angle, std::vector<int>* out) const {
  out->clear();
  last_cells_ = 0;
  if (segments_.empty() || !(radius >= 0) || !(angle >= 0)) return;
  const int x0 = CellX(centre.x() - radius), x1 = CellX(centre.x() + radius);
  const int y0 = CellY(centre.y() - radius), y1 = CellY(centre.y() + radius);
  // Orientation bins overlapping [orientation - angle, orientation + angle], modulo π.
  std::vector<int> bins;
  if (angle >= kPi / 2) {
    for (int b = 0; b < nbins_; ++b) bins.push_back(b);
  } else {
    const float width = kPi / static_cast<float>(nbins_);
    const int first = static_cast<int>(std::floor((orientation - angle) / width));
    const int last = static_cast<int>(std::floor((orientation + angle) / width));
    for (int b = first; b <= last && static_cast<int>(bins.size()) < nbins_; ++b) {
      bins.push_back(((b % nbins_) + nbins_) % nbins_);
    }
  }
  for (int b : bins) {
    for (int cy = y0; cy <= y1; ++cy) {
      const int row = (b * ny_ + cy) * nx_;
      for (int c = row + x0; c <= row + x1; ++c) {
        ++last_cells_;
        for (int k = start_[c]; k < start_[c + 1]; ++k) {
          const int i = ids_[k];
          const Eigen::Vector2f d = midpoint_[i] - centre;
          if (std::abs(d.x()) <= radius && std::abs(d.y()) <= radius &&
              OrientationDistance(orientation_[i], orientation) <= angle) {
            out->push_back(i);
          }
        }
      }
    }
  }
  std::sort(out->begin(), out->end());
  out->erase(std::unique(out->begin(), out->end()), out->end());
}

}  // namespace cfuse
