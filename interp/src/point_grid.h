// Measurements binned on a uniform grid, for the interpretation's "is there a measurement near
// this predicted place" queries. Internal to interp: not installed.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

namespace cfuse::internal {

// Measurements binned on a uniform grid over their bounding box, for "is there one within r
// of x" queries (r at most a cell): the 27 (or 9) cells around x, each a contiguous run.
class Grid {
 public:
  Grid(double cell, int dims, const std::vector<std::pair<Eigen::Vector3d, int>>& points)
      : cell_(cell), dims_(dims) {
    Eigen::AlignedBox3d box;
    for (const auto& [x, id] : points) box.extend(x);
    origin_ = box.isEmpty() ? Eigen::Vector3d::Zero() : box.min();
    const Eigen::Vector3d sizes =
        box.isEmpty() ? Eigen::Vector3d(Eigen::Vector3d::Zero()) : Eigen::Vector3d(box.sizes());
    for (int a = 0; a < 3; ++a) {
      // At most 64 cells a side: a finer grid only costs memory.
      cells_[a] = std::clamp(static_cast<int>(sizes[a] / cell_) + 1, 1, 64);
      size_[a] = std::max(cell_, sizes[a] / cells_[a] + 1e-12);
    }
    std::vector<std::vector<std::pair<Eigen::Vector3d, int>>> bins(static_cast<size_t>(cells_[0]) *
                                                                   cells_[1] * cells_[2]);
    for (const auto& p : points) bins[Index(Cell(p.first))].push_back(p);
    start_.push_back(0);
    for (const auto& bin : bins) {
      entries_.insert(entries_.end(), bin.begin(), bin.end());
      start_.push_back(static_cast<int>(entries_.size()));
    }
  }
  // Whether a point not in `exclude` lies within r (<= a cell) of x.
  bool AnyWithin(const Eigen::Vector3d& x, double r, const std::vector<int>& exclude) const {
    const Eigen::Vector3i c = Cell(x);
    const int dz = dims_ == 3 ? 1 : 0;
    for (int i = std::max(c.x() - 1, 0); i <= std::min(c.x() + 1, cells_[0] - 1); ++i) {
      for (int j = std::max(c.y() - 1, 0); j <= std::min(c.y() + 1, cells_[1] - 1); ++j) {
        for (int k = std::max(c.z() - dz, 0); k <= std::min(c.z() + dz, cells_[2] - 1); ++k) {
          const size_t b = Index({i, j, k});
          for (int e = start_[b]; e < start_[b + 1]; ++e) {
            const auto& [y, id] = entries_[e];
            if ((y - x).squaredNorm() <= r * r &&
                std::find(exclude.begin(), exclude.end(), id) == exclude.end()) {
              return true;
            }
          }
        }
      }
    }
    return false;
  }

 private:
  // The cell of x, clamped to the grid (a point outside is at least as far from every
  // measurement as the border cell's neighbours are).
  Eigen::Vector3i Cell(const Eigen::Vector3d& x) const {
    Eigen::Vector3i c;
    for (int a = 0; a < 3; ++a) {
      const double v = std::floor((x[a] - origin_[a]) / size_[a]);
      c[a] = static_cast<int>(std::clamp(v, -1.0, static_cast<double>(cells_[a])));
    }
    return c;
  }
  size_t Index(const Eigen::Vector3i& c) const {
    return (static_cast<size_t>(std::clamp(c.z(), 0, cells_[2] - 1)) * cells_[1] +
            std::clamp(c.y(), 0, cells_[1] - 1)) *
               cells_[0] +
           std::clamp(c.x(), 0, cells_[0] - 1);
  }
  double cell_;
  int dims_;
  Eigen::Vector3d origin_;
  std::array<int, 3> cells_{1, 1, 1};
  Eigen::Vector3d size_;
  std::vector<std::pair<Eigen::Vector3d, int>> entries_;  // bin by bin
  std::vector<int> start_;                                // per bin: its first entry
};

}  // namespace cfuse::internal
