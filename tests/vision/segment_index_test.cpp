// The segment index (cfuse/vision/segment_index.h): its queries against brute force, the
// orientation window wrapping at π, and the queries that can find nothing.
#include "cfuse/vision/segment_index.h"

#include <catch2/catch.hpp>
#include <random>

namespace cfuse {
namespace {

ImageSegment Segment(float x, float y, float angle, float length) {
  ImageSegment s;
  s.a = Eigen::Vector2f(x, y);
  s.b = s.a + length * Eigen::Vector2f(std::cos(angle), std::sin(angle));
  return s;
}

TEST_CASE("segment index: queries return exactly what brute force does", "[vision]") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> x(0, 640), y(0, 480), len(5, 60), angle(0, 3.3f);
  std::vector<ImageSegment> segments;
  for (int i = 0; i < 2000; ++i) {
    ImageSegment s;
    s.a = Eigen::Vector2f(x(rng), y(rng));
    const float t = angle(rng), l = len(rng);
    s.b = s.a + l * Eigen::Vector2f(std::cos(t), std::sin(t));
    segments.push_back(s);
  }
  const SegmentIndex index(segments, 640, 480);
  std::vector<int> got;
  for (int q = 0; q < 500; ++q) {
    const Eigen::Vector2f centre(x(rng), y(rng));
    const float radius = std::uniform_real_distribution<float>(2, 60)(rng);
    // Orientations near 0 and π too: the window wraps.
    const float orientation = q % 5 == 0 ? 0.01f : q % 5 == 1 ? 3.13f : angle(rng);
    const float window = std::uniform_real_distribution<float>(0.02f, 0.5f)(rng);
    index.Query(centre, radius, orientation, window, &got);
    std::vector<int> expected;
    for (int i = 0; i < static_cast<int>(segments.size()); ++i) {
      const Eigen::Vector2f mid = 0.5f * (segments[i].a + segments[i].b) - centre;
      float d =
          std::fmod(std::abs(segments[i].Orientation() - orientation), static_cast<float>(M_PI));
      d = std::min(d, static_cast<float>(M_PI) - d);
      if (std::abs(mid.x()) <= radius && std::abs(mid.y()) <= radius && d <= window) {
        expected.push_back(i);
      }
    }
    REQUIRE(got == expected);
    // A small window touches few of the 40 x 30 x 18 cells: at most 3 per axis.
    if (radius < 10 && window < 0.1f) CHECK(index.last_cells_visited() <= 3 * 3 * 3);
  }
}

TEST_CASE("segment index: a direction and its reverse are one orientation", "[vision]") {
  // Three segments about (104, 104), inside one 16-px cell: nearly horizontal either way, and
  // vertical.
  const std::vector<ImageSegment> segments = {Segment(94, 104, 0.02f, 20),
                                              Segment(114, 104, static_cast<float>(M_PI), 20),
                                              Segment(104, 94, static_cast<float>(M_PI / 2), 20)};
  const SegmentIndex index(segments, 200, 200);
  std::vector<int> found = {7};  // cleared by the query
  index.Query({104, 104}, 3, 0, 0.05f, &found);
  CHECK(found == std::vector<int>{0, 1});
  index.Query({104, 104}, 3, static_cast<float>(M_PI) - 0.01f, 0.05f, &found);
  CHECK(found == std::vector<int>{0, 1});
  index.Query({104, 104}, 3, static_cast<float>(M_PI / 2), 0.05f, &found);
  CHECK(found == std::vector<int>{2});
  // A window of π/2 or more holds every orientation, and visits each of the 18 bins of the one
  // cell once.
  index.Query({104, 104}, 3, 1.0f, static_cast<float>(M_PI / 2), &found);
  CHECK(found == std::vector<int>{0, 1, 2});
  CHECK(index.last_cells_visited() == 18);
  // The midpoint window is square: 9 px off in x and in y is inside a radius of 9.
  index.Query({113, 113}, 9, static_cast<float>(M_PI / 2), 0.05f, &found);
  CHECK(found == std::vector<int>{2});
  index.Query({113.5f, 104}, 9, static_cast<float>(M_PI / 2), 0.05f, &found);
  CHECK(found.empty());
}

TEST_CASE("segment index: queries that can find nothing", "[vision]") {
  const SegmentIndex empty({}, 640, 480);
  std::vector<int> found = {1, 2};
  empty.Query({10, 10}, 100, 0, 1, &found);
  CHECK(found.empty());
  CHECK(empty.last_cells_visited() == 0);
  const SegmentIndex one({Segment(10, 10, 0, 10)}, 640, 480);
  one.Query({15, 10}, -1, 0, 1, &found);
  CHECK(found.empty());
  one.Query({15, 10}, 5, 0, -0.1f, &found);
  CHECK(found.empty());
  one.Query({15, 10}, std::nanf(""), 0, 1, &found);
  CHECK(found.empty());
  // Midpoints off the image are kept in its border cells, and still found.
  const SegmentIndex outside({Segment(-50, -40, 0, 10)}, 640, 480, 16, 18);
  outside.Query({-45, -40}, 1, 0, 0.1f, &found);
  CHECK(found == std::vector<int>{0});
  CHECK(outside.segments().size() == 1);
}

}  // namespace
}  // namespace cfuse
