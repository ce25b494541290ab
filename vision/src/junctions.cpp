#include "cfuse/vision/junctions.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace cfuse {
namespace {

Eigen::Vector2d End(const ImageSegment& s, int end) {
  return (end == 0 ? s.a : s.b).cast<double>();
}

// Where the lines through p1 along d1 and p2 along d2 cross; false when they are parallel.
bool Crossing(const Eigen::Vector2d& p1, const Eigen::Vector2d& d1, const Eigen::Vector2d& p2,
              const Eigen::Vector2d& d2, Eigen::Vector2d* x) {
  const double det = d1.x() * d2.y() - d1.y() * d2.x();
  if (std::abs(det) < 1e-12) return false;
  const Eigen::Vector2d r = p2 - p1;
  const double t = (r.x() * d2.y() - r.y() * d2.x()) / det;
  *x = p1 + t * d1;
  return true;
}

// Whether a segment other than `arm` and `other` ends within `gap` of `corner`, runs within 5
// degrees of `arm`'s direction, lies within 2 px of the corner along its line, and leaves the
// corner away from `away` (the arm's direction from the corner).
template <typename Grid, typename Key>
bool PassesThrough(const std::vector<ImageSegment>& segments,
                   const std::vector<Eigen::Vector2d>& direction, const Grid& grid, const Key& key,
                   double cell, const Eigen::Vector2d& corner, int arm, int other,
                   const Eigen::Vector2d& away, double gap) {
  const double max_sine = std::sin(5 * M_PI / 180);
  const long cx = std::lround(std::floor(corner.x() / cell));
  const long cy = std::lround(std::floor(corner.y() / cell));
  for (long dx = -1; dx <= 1; ++dx) {
    for (long dy = -1; dy <= 1; ++dy) {
      const auto found = grid.find(key(cx + dx, cy + dy));
      if (found == grid.end()) continue;
      for (const int e : found->second) {
        const int k = e / 2, end = e % 2;
        if (k == arm || k == other) continue;
        const Eigen::Vector2d p = End(segments[k], end);
        if ((p - corner).norm() > gap) continue;
        const Eigen::Vector2d& d = direction[k];
        if (std::abs(d.x() * away.y() - d.y() * away.x()) > max_sine) continue;
        // The corner on the segment's line, and the segment leaving it the other way.
        const Eigen::Vector2d r = corner - p;
        if (std::abs(r.x() * d.y() - r.y() * d.x()) > 2) continue;
        if ((End(segments[k], 1 - end) - corner).dot(away) < 0) return true;
      }
    }
  }
  return false;
}

}  // namespace

std::vector<Junction> FindJunctions(const std::vector<ImageSegment>& segments,
                                    const JunctionOptions& options) {
  std::vector<Junction> out;
  const double gap = options.max_gap;
  if (!(gap > 0)) return out;
  // The segments' ends in cells of 2 x gap: two ends of one junction lie at most 2 x gap apart,
  // so in the same cell or a neighbouring one.
  const double cell = 2 * gap;
  auto key = [](long cx, long cy) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(cx)) << 32) |
           static_cast<std::uint32_t>(cy);
  };
  std::unordered_map<std::uint64_t, std::vector<int>> grid;  // ends: 2 x segment + end
  std::vector<Eigen::Vector2d> direction(segments.size());
  for (size_t i = 0; i < segments.size(); ++i) {
    const ImageSegment& s = segments[i];
    const double length = s.Length();
    if (!(length >= options.min_arm_length) || !s.a.allFinite() || !s.b.allFinite()) continue;
    direction[i] = (s.b - s.a).cast<double>() / length;
    for (int end = 0; end < 2; ++end) {
      const Eigen::Vector2d p = End(s, end);
      grid[key(std::lround(std::floor(p.x() / cell)), std::lround(std::floor(p.y() / cell)))]
          .push_back(static_cast<int>(2 * i + end));
    }
  }
  const double min_sin = std::sin(options.min_angle);
  for (const auto& [k, ends] : grid) {
    for (const int e1 : ends) {
      const int i = e1 / 2, end_i = e1 % 2;
      const Eigen::Vector2d p1 = End(segments[i], end_i);
      const long cx = std::lround(std::floor(p1.x() / cell));
      const long cy = std::lround(std::floor(p1.y() / cell));
      for (long dx = -1; dx <= 1; ++dx) {
        for (long dy = -1; dy <= 1; ++dy) {
          const auto found = grid.find(key(cx + dx, cy + dy));
          if (found == grid.end()) continue;
          for (const int e2 : found->second) {
            const int j = e2 / 2, end_j = e2 % 2;
            if (j <= i) continue;  // each pair once
            const Eigen::Vector2d p2 = End(segments[j], end_j);
            const double sine = std::abs(direction[i].x() * direction[j].y() -
                                         direction[i].y() * direction[j].x());
            if (sine < min_sin) continue;
            Eigen::Vector2d x;
            if (!Crossing(p1, direction[i], p2, direction[j], &x)) continue;
            if ((x - p1).norm() > gap || (x - p2).norm() > gap) continue;
            Junction junction;
            junction.corner = x;
            const int seg[2] = {i, j}, end[2] = {end_i, end_j};
            bool arms = true;
            for (int a = 0; a < 2; ++a) {
              junction.segment[a] = seg[a];
              junction.end[a] = end[a];
              junction.far[a] = End(segments[seg[a]], 1 - end[a]);
              const Eigen::Vector2d arm = junction.far[a] - x;
              arms = arms && arm.norm() >= options.min_arm_length;
              junction.direction[a] = arm.normalized();
            }
            if (!arms) continue;
            // An arm that goes on through the corner (a collinear segment starting there on the
            // other side) is a line crossing another, or passing behind it: no vertex.
            bool through = false;
            for (int a = 0; a < 2 && !through; ++a) {
              through = PassesThrough(segments, direction, grid, key, cell, x, seg[a], seg[1 - a],
                                      junction.direction[a], gap);
            }
            if (through) continue;
            junction.strength =
                std::min(segments[i].strength, segments[j].strength) *
                std::min((junction.far[0] - x).norm(), (junction.far[1] - x).norm());
            out.push_back(junction);
          }
        }
      }
    }
  }
  // Strongest first; ties by position, so that the order does not depend on the hash map's.
  std::sort(out.begin(), out.end(), [](const Junction& a, const Junction& b) {
    if (a.strength != b.strength) return a.strength > b.strength;
    if (a.corner.x() != b.corner.x()) return a.corner.x() < b.corner.x();
    return a.corner.y() < b.corner.y();
  });
  return out;
}

std::vector<Eigen::Vector2d> ArmEnds(const std::vector<Junction>& junctions, int j, int arm,
                                     const JunctionOptions& options, int max_ends) {
  const Junction& from = junctions[j];
  const Eigen::Vector2d& c = from.corner;
  const Eigen::Vector2d& e = from.direction[arm];
  const double back = std::cos(0.5 * options.min_angle);
  std::vector<std::pair<double, Eigen::Vector2d>> corners;  // by distance along the arm
  for (size_t k = 0; k < junctions.size(); ++k) {
    if (static_cast<int>(k) == j) continue;
    const Eigen::Vector2d v = junctions[k].corner - c;
    const double along = v.dot(e);
    const double across = std::abs(v.x() * e.y() - v.y() * e.x());
    if (along < options.min_arm_length || across > options.max_gap) continue;
    if (junctions[k].direction[0].dot(e) > -back && junctions[k].direction[1].dot(e) > -back) {
      continue;
    }
    corners.emplace_back(along, junctions[k].corner);
  }
  std::sort(corners.begin(), corners.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Eigen::Vector2d> out = {from.far[arm]};
  for (const auto& [along, p] : corners) {
    if (static_cast<int>(out.size()) >= max_ends) break;
    bool known = false;  // the same point twice (two junctions at one corner)
    for (const Eigen::Vector2d& q : out) known = known || (q - p).norm() < 2;
    if (!known) out.push_back(p);
  }
  return out;
}

}  // namespace cfuse
