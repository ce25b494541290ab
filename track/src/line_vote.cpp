#include "line_vote.h"

#include <algorithm>
#include <cmath>

namespace cfuse::internal {
namespace {

// One slope's count: every hit's cell (offset - slope * from_centre, rounded), the cells' votes,
// and the fullest three-cell band's votes. The loops without a store through an index
// vectorise, and are compiled also for AVX2, chosen at run time by the processor (without FMA:
// a fused product would round some cells differently).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
__attribute__((target_clones("avx2", "default")))
#endif
int CountSlope(VotePoints* work, double slope, int origin, int bins) {
  const int n = static_cast<int>(work->offset.size());
  const double* offset = work->offset.data();
  const double* from_centre = work->from_centre.data();
  int* cell = work->cell.data();
  int* votes = work->votes.data();
  for (int i = 0; i < n; ++i) cell[i] = origin + RoundHalfAway(offset[i] - slope * from_centre[i]);
  std::fill(votes, votes + bins, 0);
  for (int i = 0; i < n; ++i) {
    if (cell[i] >= 0 && cell[i] < bins) ++votes[cell[i]];
  }
  int top = 0;
  for (int b = 1; b + 1 < bins; ++b) top = std::max(top, votes[b - 1] + votes[b] + votes[b + 1]);
  return top;
}

}  // namespace

bool Vote(const std::vector<Sample>& samples, const std::vector<Hit>& hits, double length,
          double max_slope, double reach, VotePoints* work, Line* line) {
  const double centre = 0.5 * length;
  work->offset.clear();
  work->from_centre.clear();
  for (const Sample& k : samples) {
    for (int h = k.first; h < k.first + k.count; ++h) {
      if (hits[h].used) continue;
      work->offset.push_back(hits[h].offset);
      work->from_centre.push_back(k.s - centre);
    }
  }
  // Three votes are needed, and a band can hold no more votes than there are hits.
  const int most = static_cast<int>(work->offset.size());
  if (most < 3) return false;
  work->cell.resize(most);
  double step = 2.0 / std::max(length, 1.0);
  int half = static_cast<int>(std::ceil(max_slope / step));
  if (half > 30) {
    half = 30;
    step = max_slope / half;
  }
  const double extent = reach + max_slope * 0.5 * length + 2;
  const int bins = 2 * static_cast<int>(std::ceil(extent)) + 1;
  const int origin = bins / 2;
  work->votes.resize(bins);
  const int* v = work->votes.data();
  int best = 0;
  for (int j = -half; j <= half && best < most; ++j) {
    const double slope = j * step;
    const int top = CountSlope(work, slope, origin, bins);
    if (top <= best) continue;
    best = top;
    for (int b = 1; b + 1 < bins; ++b) {
      if (v[b - 1] + v[b] + v[b + 1] == top) {
        *line = Line{static_cast<double>(b - origin), slope, centre};
        break;
      }
    }
  }
  return best >= 3;
}

}  // namespace cfuse::internal
