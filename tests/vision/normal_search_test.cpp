// One-dimensional searches across an edge (cfuse/vision/normal_search.h) on images drawn pixel
// by pixel: a step placed to a fraction of a pixel as worked out by hand, its contrast and
// polarity, the strongest hits first, a smeared step placed at its middle, and the range, the
// image's border and bad arguments.
#include "cfuse/vision/normal_search.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <vector>

namespace cfuse {
namespace {

// A 200 x 100 image whose grey level is `level(x)` in every row.
struct Columns {
  template <typename Level>
  explicit Columns(Level level) : pixels(200 * 100) {
    for (int y = 0; y < 100; ++y)
      for (int x = 0; x < 200; ++x) pixels[y * 200 + x] = static_cast<std::uint8_t>(level(x));
  }
  GrayView view() const { return {pixels.data(), 200, 100, 200}; }
  std::vector<std::uint8_t> pixels;
};

// Dark (50) up to column 99, bright (150) from column 100: the step lies at x = 99.5.
const Columns kStep([](int x) { return x < 100 ? 50 : 150; });

std::vector<ProfileHit> Search(const Columns& image, Eigen::Vector2f point, Eigen::Vector2f normal,
                               float range, const NormalSearchOptions& options = {}) {
  std::vector<ProfileHit> hits;
  const int n = SearchAlongNormal(image.view(), point, normal, range, options, &hits);
  CHECK(n == static_cast<int>(hits.size()));
  return hits;
}

TEST_CASE("normal search: a step is placed to a fraction of a pixel", "[vision]") {
  // From x = 97.3 the profile reads 50 at k <= 1, 80 at k = 2 (x = 99.3, interpolated), 150
  // beyond; D = 30, 100, 70 at k = 1, 2, 3: the parabola's peak is at 2 + 0.5 (30 - 70) / (30 -
  // 200 + 70) = 2.2, the step's place 99.5 - 97.3. |D| is above half its peak from 1 + 20/70
  // to 3 + 20/70: 2 px wide.
  const std::vector<ProfileHit> hits = Search(kStep, {97.3f, 50}, {1, 0}, 10);
  REQUIRE(hits.size() == 1);
  CHECK(hits[0].offset == Approx(2.2).margin(1e-5));
  CHECK(hits[0].contrast == Approx(100).margin(1e-3));
  CHECK(hits[0].width == Approx(2).margin(1e-5));
  // Searched the other way: the same step, brighter behind the normal.
  const std::vector<ProfileHit> back = Search(kStep, {97.3f, 50}, {-1, 0}, 10);
  REQUIRE(back.size() == 1);
  CHECK(back[0].offset == Approx(-2.2).margin(1e-5));
  CHECK(back[0].contrast == Approx(-100).margin(1e-3));
  // On a slant, averaged along the edge: the step at 99.5 lies (99.5 - 90) cos 30° along n.
  const float c = std::cos(static_cast<float>(M_PI) / 6),
              s = std::sin(static_cast<float>(M_PI) / 6);
  const std::vector<ProfileHit> slant = Search(kStep, {90, 50}, {c, s}, 20);
  REQUIRE(slant.size() == 1);
  CHECK(slant[0].offset == Approx(9.5 / c).margin(0.1));
}

TEST_CASE("normal search: the range, the contrast needed and the strongest hits first",
          "[vision]") {
  // The step 2.2 px off: outside a range of 1.5 (the rising |D| at its end is no peak), inside
  // one of 2.5.
  CHECK(Search(kStep, {97.3f, 50}, {1, 0}, 1.5f).empty());
  const std::vector<ProfileHit> within = Search(kStep, {97.3f, 50}, {1, 0}, 2.5f);
  REQUIRE(within.size() == 1);
  CHECK(within[0].offset == Approx(2.2).margin(1e-5));
  NormalSearchOptions strict;
  strict.min_contrast = 101;
  CHECK(Search(kStep, {97.3f, 50}, {1, 0}, 10, strict).empty());
  // Steps of 20, 60 and 30 grey levels at x = 79.5, 99.5 and 119.5.
  const Columns stairs([](int x) { return x < 80 ? 40 : x < 100 ? 60 : x < 120 ? 120 : 90; });
  const std::vector<ProfileHit> all = Search(stairs, {100, 50}, {1, 0}, 30);
  REQUIRE(all.size() == 3);
  CHECK(all[0].contrast == Approx(60).margin(1e-3));
  CHECK(all[0].offset == Approx(-0.5).margin(1e-5));
  CHECK(all[1].contrast == Approx(-30).margin(1e-3));
  CHECK(all[1].offset == Approx(19.5).margin(1e-5));
  CHECK(all[2].contrast == Approx(20).margin(1e-3));
  CHECK(all[2].offset == Approx(-20.5).margin(1e-5));
  NormalSearchOptions two;
  two.max_hits = 2;
  const std::vector<ProfileHit> strongest = Search(stairs, {100, 50}, {1, 0}, 30, two);
  REQUIRE(strongest.size() == 2);
  CHECK(strongest[1].contrast == Approx(-30).margin(1e-3));
  // Hits are appended: what the vector held stays.
  std::vector<ProfileHit> hits(1);
  CHECK(SearchAlongNormal(stairs.view(), {100, 50}, {1, 0}, 30, two, &hits) == 2);
  CHECK(hits.size() == 3);
}

TEST_CASE("normal search: a step smeared by motion is placed at its middle", "[vision]") {
  // A ramp from 50 to 170 over columns 90-110: |D| a plateau of 12 over 20 px, peaking anywhere
  // on it; the hit is the plateau's middle, x = 100, and as wide as the ramp.
  const Columns ramp([](int x) { return x <= 90 ? 50 : x >= 110 ? 170 : 50 + 6 * (x - 90); });
  const std::vector<ProfileHit> hits = Search(ramp, {95, 50}, {1, 0}, 30);
  REQUIRE(hits.size() == 1);
  CHECK(hits[0].offset == Approx(5).margin(0.01));
  CHECK(hits[0].width == Approx(20).margin(0.6));
}

TEST_CASE("normal search: the border ends the profile; bad arguments find nothing", "[vision]") {
  // A step 3.5 px from the image's left border, searched from x = 10 towards it (30 px, 20
  // of them off the image): found 6.5 px along the normal, brighter that way.
  const Columns near_border([](int x) { return x < 4 ? 200 : 20; });
  const std::vector<ProfileHit> hits = Search(near_border, {10, 50}, {-1, 0}, 30);
  REQUIRE(hits.size() == 1);
  CHECK(hits[0].offset == Approx(6.5).margin(1e-5));
  CHECK(hits[0].contrast == Approx(180).margin(1e-3));
  CHECK(Search(kStep, {-5, 50}, {1, 0}, 10).empty());  // the sample point off the image
  CHECK(Search(kStep, {97.3f, 50}, {1, 0}, -1).empty());
  CHECK(Search(kStep, {std::nanf(""), 50}, {1, 0}, 10).empty());
  CHECK(Search(kStep, {97.3f, 50}, {std::nanf(""), 0}, 10).empty());
}

}  // namespace
}  // namespace cfuse
