// Junctions of segments (cfuse/vision/junctions.h) on segments placed by hand: an L-junction with
// a gap at its corner, and the pairs that make none (a T, a shallow angle, ends too far apart,
// a short arm).
#include "cfuse/vision/junctions.h"

#include <catch2/catch.hpp>
#include <cstdint>
#include <vector>

namespace cfuse {
namespace {

ImageSegment Segment(float ax, float ay, float bx, float by, float strength = 30) {
  ImageSegment s;
  s.a = Eigen::Vector2f(ax, ay);
  s.b = Eigen::Vector2f(bx, by);
  s.strength = strength;
  return s;
}

TEST_CASE("junctions: two segments ending near a common corner meet at their lines' crossing",
          "[vision]") {
  // A horizontal segment ending 3 px before x = 100 and a vertical one starting 2 px below y =
  // 50: the corner is (100, 50), whichever way round the segments run.
  for (const bool flip : {false, true}) {
    std::vector<ImageSegment> segments = {Segment(40, 50, 97, 50), Segment(100, 52, 100, 90)};
    if (flip) std::swap(segments[0].a, segments[0].b);
    const std::vector<Junction> j = FindJunctions(segments);
    REQUIRE(j.size() == 1);
    CHECK((j[0].corner - Eigen::Vector2d(100, 50)).norm() < 1e-9);
    const int h = j[0].segment[0] == 0 ? 0 : 1;  // the horizontal arm
    CHECK(j[0].segment[h] == 0);
    CHECK(j[0].end[h] == (flip ? 0 : 1));
    CHECK((j[0].far[h] - Eigen::Vector2d(40, 50)).norm() < 1e-9);
    CHECK((j[0].direction[h] - Eigen::Vector2d(-1, 0)).norm() < 1e-9);
    CHECK((j[0].far[1 - h] - Eigen::Vector2d(100, 90)).norm() < 1e-9);
    CHECK((j[0].direction[1 - h] - Eigen::Vector2d(0, 1)).norm() < 1e-9);
    // The lesser contrast times the shorter arm (40 px).
    CHECK(j[0].strength == Approx(30 * 40));
  }
}

TEST_CASE("junctions: a T, a shallow angle, a wide gap or a short arm make no junction",
          "[vision]") {
  // The vertical segment ends on the middle of the horizontal one: its crossing lies 30 px from
  // either end of the horizontal one.
  CHECK(FindJunctions({Segment(40, 50, 160, 50), Segment(100, 52, 100, 90)}).empty());
  // 10 degrees apart, below min_angle's 20.
  const float t = std::tan(static_cast<float>(10 * M_PI / 180));
  CHECK(FindJunctions({Segment(40, 50, 100, 50), Segment(100, 50, 160, 50 + 60 * t)}).empty());
  // Ends 9 px from the crossing, beyond max_gap's 6.
  CHECK(FindJunctions({Segment(40, 50, 91, 50), Segment(100, 59, 100, 90)}).empty());
  // ... unless the gap allowed is wider.
  JunctionOptions wide;
  wide.max_gap = 10;
  CHECK(FindJunctions({Segment(40, 50, 91, 50), Segment(100, 59, 100, 90)}, wide).size() == 1);
  // An arm of 8 px, below min_arm_length's 12.
  CHECK(FindJunctions({Segment(40, 50, 100, 50), Segment(100, 50, 100, 58)}).empty());
}

TEST_CASE("junctions: two lines crossing make none, though their pieces end at the crossing",
          "[vision]") {
  // A line detector splits crossing lines at the crossing: four pieces ending at (100, 50), each
  // pair at right angles, but every arm goes on through the corner.
  const std::vector<ImageSegment> cross = {Segment(40, 50, 99, 50), Segment(101, 50, 160, 50),
                                           Segment(100, 10, 100, 49), Segment(100, 51, 100, 90)};
  CHECK(FindJunctions(cross).empty());
  // Without the pieces beyond the crossing, an L.
  CHECK(FindJunctions({cross[0], cross[2]}).size() == 1);
}

TEST_CASE("junctions: an arm ends at its segment's far end and at corners further along it",
          "[vision]") {
  // An L at (100, 50) whose horizontal arm broke at x = 70; the edge goes on to another L at
  // (20, 50), whose horizontal arm points back along it.
  const std::vector<ImageSegment> segments = {
      Segment(70, 50, 99, 50), Segment(100, 52, 100, 90),  // the L at (100, 50)
      Segment(22, 50, 50, 50), Segment(20, 48, 20, 10),    // the L at (20, 50)
      Segment(60, 80, 60, 120), Segment(62, 80, 90, 80)};  // an L at (60, 80), off the line
  const std::vector<Junction> j = FindJunctions(segments);
  REQUIRE(j.size() == 3);
  int at = -1;
  for (size_t k = 0; k < j.size(); ++k) {
    if ((j[k].corner - Eigen::Vector2d(100, 50)).norm() < 1e-6) at = static_cast<int>(k);
  }
  REQUIRE(at >= 0);
  const int arm = j[at].segment[0] == 0 ? 0 : 1;  // the horizontal arm
  const std::vector<Eigen::Vector2d> ends = ArmEnds(j, at, arm);
  REQUIRE(ends.size() == 2);
  CHECK((ends[0] - Eigen::Vector2d(70, 50)).norm() < 1e-6);  // the segment's far end
  CHECK((ends[1] - Eigen::Vector2d(20, 50)).norm() < 1e-6);  // the next corner along the line
  // The vertical arm has no corner along it.
  CHECK(ArmEnds(j, at, 1 - arm).size() == 1);
  // At most one end when asked so.
  CHECK(ArmEnds(j, at, arm, {}, 1).size() == 1);
}

TEST_CASE("junctions: the corners of a rectangle, strongest first", "[vision]") {
  // A rectangle's four sides, each of another contrast: four junctions, ordered by the lesser
  // contrast times the shorter arm.
  const std::vector<ImageSegment> sides = {Segment(10, 10, 110, 10, 10), Segment(110, 10, 110, 60, 20),
                                           Segment(110, 60, 10, 60, 30), Segment(10, 60, 10, 10, 40)};
  const std::vector<Junction> j = FindJunctions(sides);
  REQUIRE(j.size() == 4);
  for (size_t i = 1; i < j.size(); ++i) CHECK(j[i - 1].strength >= j[i].strength);
  // The strongest: sides 2 and 3 (contrasts 30 and 40) at (10, 60), arms of 100 and 50 px.
  CHECK((j[0].corner - Eigen::Vector2d(10, 60)).norm() < 1e-9);
  CHECK(j[0].strength == Approx(30 * 50));
}

// 200 x 120 grey image: a bright block over x = 20..180 from y = 60 down, except a dark column
// over x in [gap_from, gap_from + gap) cutting its top edge.
std::vector<std::uint8_t> Block(int gap_from, int gap) {
  std::vector<std::uint8_t> pixels(200 * 120, 60);
  for (int y = 60; y < 120; ++y) {
    for (int x = 20; x <= 180; ++x) {
      if (x < gap_from || x >= gap_from + gap) pixels[y * 200 + x] = 160;
    }
  }
  return pixels;
}

TEST_CASE("junctions: an arm's end traced along the image's steps past where its segment broke",
          "[vision]") {
  // The block's top-left corner, its top edge's segment broken at x = 60.
  Junction j;
  j.corner = Eigen::Vector2d(20, 60);
  j.direction[0] = Eigen::Vector2d(1, 0);
  j.far[0] = Eigen::Vector2d(60, 60);
  j.direction[1] = Eigen::Vector2d(0, 1);
  j.far[1] = Eigen::Vector2d(20, 100);
  {
    const std::vector<std::uint8_t> pixels = Block(0, 0);
    const EdgeOrientations steps(GrayView{pixels.data(), 200, 120, 200});
    // On to the block's top-right corner, where the edge turns (the side's steps run across).
    CHECK((TracedEnd(j, 0, steps, 12) - Eigen::Vector2d(180, 60)).norm() < 3);
    // The side down from the corner ends at the image's border: its last row within the spread.
    CHECK(TracedEnd(j, 1, steps, 12).y() > 115);
    // A segment that ends near the corner already keeps its end.
    Junction near = j;
    near.far[0] = Eigen::Vector2d(178, 60);
    CHECK((TracedEnd(near, 0, steps, 12) - near.far[0]).norm() < 1e-12);
  }
  {
    // A 20 px gap in the edge stops the trace at its start with a 12 px gap allowed ...
    const std::vector<std::uint8_t> pixels = Block(100, 20);
    const EdgeOrientations steps(GrayView{pixels.data(), 200, 120, 200});
    CHECK(std::abs(TracedEnd(j, 0, steps, 12).x() - 100) < 4);
    // ... and is crossed with 30 px.
    CHECK((TracedEnd(j, 0, steps, 30) - Eigen::Vector2d(180, 60)).norm() < 3);
  }
}

}  // namespace
}  // namespace cfuse
