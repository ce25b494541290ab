// The Hough vote behind the normal search's lines (track/src/edge_evidence.cpp): the hits found
// along a predicted piece's normals, and the line through most of them. Internal to
// cfuse::track (not installed).
#pragma once

#include <vector>

namespace cfuse::internal {

// A search along the piece's normal at `s` px from its start, and its hits.
struct Sample {
  double s = 0;              // px along the piece from a
  int first = 0, count = 0;  // its hits in the piece's hit list
};

struct Hit {
  float offset = 0, contrast = 0, width = 0;  // px along the normal, grey levels, px
  bool used = false;                          // taken by a line already
};

// A line d(s) = c0 + c1 (s - centre) across the piece (d along the normal, px), fitted to one
// hit per sample.
struct Line {
  double c0 = 0, c1 = 0, centre = 0;
  double Offset(double s) const { return c0 + c1 * (s - centre); }
};

// std::lround's value (halves away from zero) for |v| < 2^31, without its call: the conversion
// truncates, and the fraction v - t is exact, so the test against one half is too.
inline int RoundHalfAway(double v) {
  const int t = static_cast<int>(v);
  const double f = v - t;
  return t + (f >= 0.5) - (f <= -0.5);
}

// The vote's work space, kept by the caller across pieces.
struct VotePoints {
  std::vector<double> offset, from_centre;  // the unused hits, in two contiguous arrays
  std::vector<int> cell;                    // each one's cell at the slope being counted
  std::vector<int> votes;                   // the cells' votes
};

// The line through the most unused hits of a piece `length` px long (within a 3-px band), over
// slopes |c1| <= max_slope in steps that move the piece's ends by a pixel and offsets within
// `reach` px plus what the slope adds. Ties go to the first slope met from the steepest
// negative one up, then to the smallest offset. False when no band holds three hits.
bool Vote(const std::vector<Sample>& samples, const std::vector<Hit>& hits, double length,
          double max_slope, double reach, VotePoints* work, Line* line);

}  // namespace cfuse::internal
