// The spread orientation map (cfuse/vision/edge_orientations.h) on a drawn step: where a step of
// which orientation is found, what the spread reaches, what chance is, and the bins.
#include "cfuse/vision/edge_orientations.h"

#include <catch2/catch.hpp>
#include <vector>

#include "cfuse/kernel/error.h"

namespace cfuse {
namespace {

// 80 x 60 grey image, `left` grey levels left of x = 40 and `right` from it on.
std::vector<std::uint8_t> Step(int left, int right) {
  std::vector<std::uint8_t> pixels(80 * 60);
  for (int y = 0; y < 60; ++y) {
    for (int x = 0; x < 80; ++x) pixels[y * 80 + x] = static_cast<std::uint8_t>(x < 40 ? left : right);
  }
  return pixels;
}

TEST_CASE("edge orientations: a vertical step is found where it is, across the spread only",
          "[vision]") {
  const std::vector<std::uint8_t> pixels = Step(60, 140);
  const EdgeOrientations map(GrayView{pixels.data(), 80, 60, 80});
  const int across = EdgeOrientations::Bin(Eigen::Vector2d(1, 0));  // the step's normal
  const int along = EdgeOrientations::Bin(Eigen::Vector2d(0, 1));
  CHECK(across != along);
  // One column of steps (non-maximum suppression), on one side of x = 39.5.
  CHECK(map.steps() >= 56);
  CHECK(map.steps() <= 60);
  for (double x = 37.5; x <= 41.5; x += 1) {
    CAPTURE(x);
    CHECK(map.Has(x, 30, EdgeOrientations::Tolerant(across)));
    CHECK_FALSE(map.Has(x, 30, EdgeOrientations::Tolerant(along)));
  }
  // The spread is 2 px: 4 px from the step nothing is found.
  CHECK_FALSE(map.Has(35, 30, EdgeOrientations::Tolerant(across)));
  CHECK_FALSE(map.Has(44, 30, EdgeOrientations::Tolerant(across)));
  // Outside the image, never.
  CHECK_FALSE(map.Has(-3, 30, 0xff));
  CHECK_FALSE(map.Has(39, 70, 0xff));
  // Chance: the share of pixels where a sample would be supported, 5 columns of 80.
  CHECK(map.Chance(across) == Approx(5.0 / 80).margin(1.0 / 80));
  CHECK(map.Chance(along) == 0);
}

TEST_CASE("edge orientations: a step below the contrast is not one", "[vision]") {
  const std::vector<std::uint8_t> faint = Step(100, 108);  // 8 grey levels, below 12
  CHECK(EdgeOrientations(GrayView{faint.data(), 80, 60, 80}).steps() == 0);
  EdgeOrientationOptions lower;
  lower.min_contrast = 5;
  CHECK(EdgeOrientations(GrayView{faint.data(), 80, 60, 80}, lower).steps() >= 56);
}

TEST_CASE("edge orientations: bins of normals either way round, and their tolerance", "[vision]") {
  CHECK(EdgeOrientations::Bin(Eigen::Vector2d(1, 0)) == EdgeOrientations::Bin(Eigen::Vector2d(-1, 0)));
  CHECK(EdgeOrientations::Bin(Eigen::Vector2d(1, 1)) == EdgeOrientations::Bin(Eigen::Vector2d(-2, -2)));
  for (int bin = 0; bin < kOrientationBins; ++bin) {
    const std::uint8_t t = EdgeOrientations::Tolerant(bin);
    CHECK(t & (1u << bin));
    CHECK(t & (1u << ((bin + 1) % kOrientationBins)));
    CHECK(t & (1u << ((bin + kOrientationBins - 1) % kOrientationBins)));
    CHECK(__builtin_popcount(t) == 3);
  }
}

TEST_CASE("edge orientations: an empty image is refused", "[vision]") {
  CHECK_THROWS_AS(EdgeOrientations(GrayView{}), InputError);
}

}  // namespace
}  // namespace cfuse
