#include "cfuse/vision/segment_score.h"

#include <algorithm>
#include <cmath>

namespace cfuse {
namespace {

// Whether point p, on a line of direction `dir` (unit), lies within `distance` of segment
// s (between its ends extended by `distance`) and s is within `angle` of `dir`.
bool Near(const Eigen::Vector2d& p, const Eigen::Vector2d& dir, const Eigen::Vector2d& a,
          const Eigen::Vector2d& b, double distance, double angle) {
  const Eigen::Vector2d d = b - a;
  const double length = d.norm();
  if (length == 0) return false;
  const Eigen::Vector2d u = d / length;
  if (std::abs(u.x() * dir.y() - u.y() * dir.x()) > std::sin(angle)) return false;
  const Eigen::Vector2d r = p - a;
  const double along = r.dot(u);
  if (along < -distance || along > length + distance) return false;
  return std::abs(r.x() * u.y() - r.y() * u.x()) <= distance;
}

}  // namespace

Coverage CoverTruth(const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>& truth,
                    const std::vector<ImageSegment>& detected, const CoverageOptions& options) {
  Coverage c;
  c.detected = static_cast<int>(detected.size());
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> found;
  for (const ImageSegment& s : detected) found.emplace_back(s.a.cast<double>(), s.b.cast<double>());
  for (size_t t = 0; t < truth.size(); ++t) {
    const auto& [a, b] = truth[t];
    const double length = (b - a).norm();
    if (length < options.min_truth_length || length == 0) continue;
    const Eigen::Vector2d dir = (b - a) / length;
    const int n = std::max(2, static_cast<int>(std::ceil(2 * length)) + 1);
    int counted = 0, covered = 0;
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(k) / (n - 1));
      // Two model edges at one place (a hinge's two sides) are one edge in the image.
      const bool repeated = std::any_of(truth.begin(), truth.begin() + t, [&](const auto& u) {
        return Near(p, dir, u.first, u.second, 0.5, options.max_angle);
      });
      if (repeated) continue;
      ++counted;
      covered += std::any_of(found.begin(), found.end(), [&](const auto& s) {
        return Near(p, dir, s.first, s.second, options.max_distance, options.max_angle);
      });
    }
    c.truth_length += length * counted / n;
    c.covered_length += length * covered / n;
  }
  for (const auto& [a, b] : found) {
    const double length = (b - a).norm();
    if (length == 0) continue;
    const Eigen::Vector2d dir = (b - a) / length, mid = 0.5 * (a + b);
    const bool real = std::any_of(truth.begin(), truth.end(), [&](const auto& t) {
      return Near(mid, dir, t.first, t.second, options.max_distance, options.max_angle);
    });
    c.clutter += real ? 0 : 1;
  }
  return c;
}

}  // namespace cfuse
