// The interpretation's measurement grid against a brute-force search.
#include <catch2/catch.hpp>

#include <random>

#include "point_grid.h"

namespace cfuse::internal {
namespace {

bool BruteAnyWithin(const std::vector<std::pair<Eigen::Vector3d, int>>& points,
                    const Eigen::Vector3d& x, double r, const std::vector<int>& exclude) {
  for (const auto& [y, id] : points) {
    if ((y - x).norm() <= r && std::find(exclude.begin(), exclude.end(), id) == exclude.end()) {
      return true;
    }
  }
  return false;
}

TEST_CASE("point grid: near queries agree with a brute-force search", "[interp][grid]") {
  std::mt19937 rng(7);
  for (const int dims : {2, 3}) {
    std::uniform_real_distribution<double> coordinate(-1.0, 2.0);
    std::vector<std::pair<Eigen::Vector3d, int>> points;
    for (int i = 0; i < 300; ++i) {
      points.push_back({Eigen::Vector3d(coordinate(rng), coordinate(rng),
                                        dims == 3 ? coordinate(rng) : 0.0),
                        i});
    }
    const double cell = 0.2;
    const Grid grid(cell, dims, points);
    // Queries inside, on the border and well outside the points' box; radii up to a cell.
    std::uniform_real_distribution<double> query(-1.5, 2.5), radius(0.0, cell);
    int agree = 0, hits = 0;
    for (int q = 0; q < 2000; ++q) {
      const Eigen::Vector3d x(query(rng), query(rng), dims == 3 ? query(rng) : 0.0);
      const double r = radius(rng);
      const std::vector<int> exclude = {q % 300, (q * 7) % 300};
      const bool expected = BruteAnyWithin(points, x, r, exclude);
      agree += grid.AnyWithin(x, r, exclude) == expected ? 1 : 0;
      hits += expected ? 1 : 0;
    }
    CAPTURE(dims, hits);
    CHECK(agree == 2000);
    CHECK(hits > 50);  // the queries test both answers
    CHECK(hits < 1950);
  }
}

TEST_CASE("point grid: an excluded point is not found, the next one is", "[interp][grid]") {
  const std::vector<std::pair<Eigen::Vector3d, int>> points = {
      {Eigen::Vector3d(0, 0, 0), 4}, {Eigen::Vector3d(0.15, 0, 0), 9}};
  const Grid grid(0.2, 3, points);
  CHECK(grid.AnyWithin(Eigen::Vector3d(0.01, 0, 0), 0.05, {}));
  CHECK_FALSE(grid.AnyWithin(Eigen::Vector3d(0.01, 0, 0), 0.05, {4}));
  CHECK(grid.AnyWithin(Eigen::Vector3d(0.01, 0, 0), 0.2, {4}));
  CHECK_FALSE(grid.AnyWithin(Eigen::Vector3d(0.01, 0, 0), 0.2, {4, 9}));
  // An empty grid answers no.
  const Grid empty(0.2, 3, {});
  CHECK_FALSE(empty.AnyWithin(Eigen::Vector3d::Zero(), 0.2, {}));
}

}  // namespace
}  // namespace cfuse::internal
