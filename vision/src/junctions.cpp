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

// The segments' ends (2 x segment + end) in square cells: the ends near a point are those of its
// cell and the eight around it, when the cell is at least as wide as the distance asked.
class EndGrid {
 public:
  explicit EndGrid(double cell) : cell_(cell) {}
  void Add(const Eigen::Vector2d& p, int end) { cells_[Key(Cell(p.x()), Cell(p.y()))].push_back(end); }
  // Calls f(end) for every end in the cells about `p`.
  template <typename F>
  void ForEachNear(const Eigen::Vector2d& p, F&& f) const {
    const long cx = Cell(p.x()), cy = Cell(p.y());
    for (long dx = -1; dx <= 1; ++dx) {
      for (long dy = -1; dy <= 1; ++dy) {
        const auto found = cells_.find(Key(cx + dx, cy + dy));
        if (found == cells_.end()) continue;
        for (const int end : found->second) f(end);
      }
    }
  }

 private:
  long Cell(double x) const { return std::lround(std::floor(x / cell_)); }
  static std::uint64_t Key(long cx, long cy) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(cx)) << 32) |
           static_cast<std::uint32_t>(cy);
  }
  double cell_;
  std::unordered_map<std::uint64_t, std::vector<int>> cells_;
};

// Whether a segment other than `arm` and `other` ends within `gap` of `corner`, runs within 5
// degrees of `arm`'s direction, lies within 2 px of the corner along its line, and leaves the
// corner away from `away` (the arm's direction from the corner).
bool PassesThrough(const std::vector<ImageSegment>& segments,
                   const std::vector<Eigen::Vector2d>& direction, const EndGrid& grid,
                   const Eigen::Vector2d& corner, int arm, int other, const Eigen::Vector2d& away,
                   double gap) {
  const double max_sine = std::sin(5 * M_PI / 180);
  bool through = false;
  grid.ForEachNear(corner, [&](int e) {
    const int k = e / 2, end = e % 2;
    if (through || k == arm || k == other) return;
    const Eigen::Vector2d p = End(segments[k], end);
    if ((p - corner).norm() > gap) return;
    const Eigen::Vector2d& d = direction[k];
    if (std::abs(d.x() * away.y() - d.y() * away.x()) > max_sine) return;
    // The corner on the segment's line, and the segment leaving it the other way.
    const Eigen::Vector2d r = corner - p;
    if (std::abs(r.x() * d.y() - r.y() * d.x()) > 2) return;
    through = (End(segments[k], 1 - end) - corner).dot(away) < 0;
  });
  return through;
}

}  // namespace

std::vector<Junction> FindJunctions(const std::vector<ImageSegment>& segments,
                                    const JunctionOptions& options) {
  std::vector<Junction> out;
  const double gap = options.max_gap;
  if (!(gap > 0)) return out;
  // The segments' ends in cells of 2 x gap: two ends of one junction lie at most 2 x gap apart,
  // so in the same cell or a neighbouring one.
  EndGrid grid(2 * gap);
  std::vector<int> ends;  // in the order added
  std::vector<Eigen::Vector2d> direction(segments.size());
  for (size_t i = 0; i < segments.size(); ++i) {
    const ImageSegment& s = segments[i];
    const double length = s.Length();
    if (!(length >= options.min_arm_length) || !s.a.allFinite() || !s.b.allFinite()) continue;
    direction[i] = (s.b - s.a).cast<double>() / length;
    for (int end = 0; end < 2; ++end) {
      grid.Add(End(s, end), static_cast<int>(2 * i + end));
      ends.push_back(static_cast<int>(2 * i + end));
    }
  }
  const double min_sin = std::sin(options.min_angle);
  for (const int e1 : ends) {
    const int i = e1 / 2, end_i = e1 % 2;
    const Eigen::Vector2d p1 = End(segments[i], end_i);
    grid.ForEachNear(p1, [&](int e2) {
      const int j = e2 / 2, end_j = e2 % 2;
      if (j <= i) return;  // each pair once
      const Eigen::Vector2d p2 = End(segments[j], end_j);
      const double sine = std::abs(direction[i].x() * direction[j].y() -
                                   direction[i].y() * direction[j].x());
      if (sine < min_sin) return;
      Eigen::Vector2d x;
      if (!Crossing(p1, direction[i], p2, direction[j], &x)) return;
      if ((x - p1).norm() > gap || (x - p2).norm() > gap) return;
      Junction junction;
      junction.corner = x;
      const int seg[2] = {i, j}, end[2] = {end_i, end_j};
      for (int a = 0; a < 2; ++a) {
        junction.segment[a] = seg[a];
        junction.end[a] = end[a];
        junction.far[a] = End(segments[seg[a]], 1 - end[a]);
        const Eigen::Vector2d arm = junction.far[a] - x;
        if (arm.norm() < options.min_arm_length) return;
        junction.direction[a] = arm.normalized();
      }
      // An arm that goes on through the corner (a collinear segment starting there on the other
      // side) is a line crossing another, or passing behind it: no vertex.
      for (int a = 0; a < 2; ++a) {
        if (PassesThrough(segments, direction, grid, x, seg[a], seg[1 - a], junction.direction[a],
                          gap)) {
          return;
        }
      }
      junction.strength = std::min(segments[i].strength, segments[j].strength) *
                          std::min((junction.far[0] - x).norm(), (junction.far[1] - x).norm());
      out.push_back(junction);
    });
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

Eigen::Vector2d TracedEnd(const Junction& junction, int arm, const EdgeOrientations& steps,
                          double max_gap) {
  const Eigen::Vector2d& c = junction.corner;
  const Eigen::Vector2d& d = junction.direction[arm];
  const auto bin = static_cast<std::uint8_t>(1u << EdgeOrientations::Bin({-d.y(), d.x()}));
  const double from = (junction.far[arm] - c).norm();
  double last = from;  // px from the corner
  for (double s = from + 1;; s += 1) {
    const Eigen::Vector2d p = c + s * d;
    if (p.x() < 0 || p.y() < 0 || p.x() > steps.width() - 1 || p.y() > steps.height() - 1) break;
    if (steps.Has(p.x(), p.y(), bin)) {
      last = s;
    } else if (s - last > max_gap) {
      break;
    }
  }
  return last > from + 4 ? Eigen::Vector2d(c + last * d) : junction.far[arm];
}

}  // namespace cfuse
