// The Hough vote behind the normal search's lines (track/src/line_vote.cpp): its rounding is
// std::lround's, and its line is the plain vote's (every slope, every band, std::lround), over
// random pieces with shared hits, ties and hits outside the bands.
#include "line_vote.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace cfuse::internal {
namespace {

// The vote as first written: every slope, every band, the first strictly fuller one kept.
bool PlainVote(const std::vector<Sample>& samples, const std::vector<Hit>& hits, double length,
               double max_slope, double reach, Line* line) {
  const double centre = 0.5 * length;
  double step = 2.0 / std::max(length, 1.0);
  int half = static_cast<int>(std::ceil(max_slope / step));
  if (half > 30) {
    half = 30;
    step = max_slope / half;
  }
  const double extent = reach + max_slope * 0.5 * length + 2;
  const int bins = 2 * static_cast<int>(std::ceil(extent)) + 1;
  const int origin = bins / 2;
  int best = 0;
  std::vector<int> votes;
  for (int j = -half; j <= half; ++j) {
    const double slope = j * step;
    votes.assign(bins, 0);
    for (const Sample& k : samples) {
      for (int h = k.first; h < k.first + k.count; ++h) {
        if (hits[h].used) continue;
        const int b =
            origin + static_cast<int>(std::lround(hits[h].offset - slope * (k.s - centre)));
        if (b >= 0 && b < bins) ++votes[b];
      }
    }
    for (int b = 1; b + 1 < bins; ++b) {
      const int v = votes[b - 1] + votes[b] + votes[b + 1];
      if (v > best) {
        best = v;
        *line = Line{static_cast<double>(b - origin), slope, centre};
      }
    }
  }
  return best >= 3;
}

TEST_CASE("line vote: rounding is std::lround's, halves away from zero", "[track]") {
  for (double v : {0.0, -0.0, 0.5, -0.5, 1.5, -1.5, 2.5, -2.5, 0.49999999999999994,
                   -0.49999999999999994, 1e9 + 0.5, -1e9 - 0.5, 3.4999999, -3.5000001}) {
    CAPTURE(v);
    CHECK(RoundHalfAway(v) == std::lround(v));
  }
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> any(-300, 300);
  std::uniform_int_distribution<int> whole(-300, 300);
  for (int trial = 0; trial < 100000; ++trial) {
    // Random values, and values a few units in the last place around every half.
    const double half = whole(rng) + 0.5;
    const double v = trial % 2 ? any(rng) : std::nextafter(half, trial % 4 == 0 ? 1e9 : -1e9);
    CAPTURE(v);
    REQUIRE(RoundHalfAway(v) == std::lround(v));
    REQUIRE(RoundHalfAway(half) == std::lround(half));
  }
}

TEST_CASE("line vote: the same line as the plain vote on random pieces", "[track]") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0, 1);
  VotePoints work;
  int found = 0, empty = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const double length = 5 + 400 * unit(rng);
    const double reach = 4 + 20 * unit(rng);
    const double max_slope = 0.5 * unit(rng);
    // A line of random offset and slope, hit at most samples, and clutter; offsets on a
    // half-pixel grid in a third of the trials (ties and halves everywhere).
    const double c0 = (2 * unit(rng) - 1) * reach, c1 = (2 * unit(rng) - 1) * max_slope;
    const bool grid = trial % 3 == 0;
    std::vector<Sample> samples;
    std::vector<Hit> hits;
    const int n = 2 + static_cast<int>(length / 5);
    for (int k = 0; k < n; ++k) {
      Sample sample{length * k / (n - 1), static_cast<int>(hits.size()), 0};
      const int count = static_cast<int>(5 * unit(rng));
      for (int h = 0; h < count; ++h) {
        double offset = h == 0 && unit(rng) < 0.8
                            ? c0 + c1 * (sample.s - 0.5 * length) + 0.7 * (unit(rng) - 0.5)
                            : (2 * unit(rng) - 1) * (reach + 5);
        if (grid) offset = 0.5 * std::round(2 * offset);
        hits.push_back({static_cast<float>(offset), 20, 2, unit(rng) < 0.2});
        ++sample.count;
      }
      samples.push_back(sample);
    }
    Line plain, fast;
    const bool a = PlainVote(samples, hits, length, max_slope, reach, &plain);
    const bool b = Vote(samples, hits, length, max_slope, reach, &work, &fast);
    CAPTURE(trial);
    REQUIRE(a == b);
    if (!a) {
      ++empty;
      continue;
    }
    ++found;
    REQUIRE(fast.c0 == plain.c0);
    REQUIRE(fast.c1 == plain.c1);
    REQUIRE(fast.centre == plain.centre);
  }
  // Both outcomes met many times.
  CHECK(found > 2000);
  CHECK(empty > 20);
}

TEST_CASE("line vote: fewer than three unused hits find no line", "[track]") {
  const std::vector<Sample> samples = {{0, 0, 1}, {50, 1, 1}, {100, 2, 1}};
  std::vector<Hit> hits = {{1, 20, 2, false}, {1, 20, 2, false}, {1, 20, 2, false}};
  VotePoints work;
  Line line;
  // (Level lines only: a 3-px band holds the three at the steepest slope already.)
  REQUIRE(Vote(samples, hits, 100, 0, 5, &work, &line));
  CHECK(line.c0 == 0);  // the first band that holds all three, cells -1 to 1
  CHECK(line.c1 == 0);
  CHECK(line.centre == 50);
  hits[1].used = true;
  CHECK_FALSE(Vote(samples, hits, 100, 0, 5, &work, &line));
}

}  // namespace
}  // namespace cfuse::internal
