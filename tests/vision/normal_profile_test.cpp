// The profile a normal search reads (vision/src/normal_profile.cpp): each vector form this
// processor runs gives the scalar loop's floats, at random places and up to the image's first
// and last bytes (with a page that may not be read beside them), and the profile's valid run
// decided from its corners is the one found point by point.
#include <sys/mman.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

#include "normal_search_internal.h"

namespace cfuse {
namespace {

// The vector forms of the profile this processor runs, FillProfile's choice among them first.
using Fill = void (*)(const GrayView&, const Eigen::Vector2f&, const Eigen::Vector2f&,
                      const Eigen::Vector2f&, int, int, int, int, float*);
std::vector<std::pair<const char*, Fill>> VectorForms() {
  std::vector<std::pair<const char*, Fill>> forms = {{"chosen", &internal::FillProfile}};
#if defined(__SSE2__)
  forms.emplace_back("SSE2", &internal::FillProfileSse2);
#endif
#if defined(CFUSE_PROFILE_AVX2)
  if (internal::Avx2Available()) forms.emplace_back("AVX2", &internal::FillProfileAvx2);
#endif
  return forms;
}

TEST_CASE("normal profile: every vector form is the pixel-by-pixel loop", "[vision]") {
  // Noise over a few steps, read at random places, directions, ranges and widths (up to the
  // image's border, and runs of every length mod 4): every profile value the same float. (A
  // build that fuses multiply-adds may round the two forms apart: a thousandth of a grey level.)
  std::mt19937 random(7);
  std::vector<std::uint8_t> pixels(123 * 77);
  std::uniform_int_distribution<int> grey(0, 255);
  for (int y = 0; y < 77; ++y)
    for (int x = 0; x < 123; ++x)
      pixels[y * 123 + x] = static_cast<std::uint8_t>(x < 40   ? grey(random) / 4
                                                      : x < 80 ? 200
                                                               : grey(random));
  const GrayView image{pixels.data(), 123, 77, 123};
  std::uniform_real_distribution<float> along(0, 1);
  int compared = 0, apart = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const float angle = 2 * static_cast<float>(M_PI) * along(random);
    const Eigen::Vector2f normal(std::cos(angle), std::sin(angle)),
        tangent(normal.y(), -normal.x());
    const int h = trial % 4, K = 1 + trial % 23;
    const Eigen::Vector2f point(h + 1 + K + along(random) * (121 - 2 * (h + 1 + K)),
                                h + 1 + K + along(random) * (75 - 2 * (h + 1 + K)));
    const int last = 2 * K + 2;
    std::vector<float> scalar(last + 8, -1);
    internal::FillProfileScalar(image, point, normal, tangent, h, K, 0, last, scalar.data());
    for (const auto& [form, fill] : VectorForms()) {
      std::vector<float> vector(last + 8, -1);
      fill(image, point, normal, tangent, h, K, 0, last, vector.data());
      for (int i = 0; i <= last; ++i) {
        ++compared;
        apart += scalar[i] != vector[i];
        INFO(form);
        REQUIRE(vector[i] == Approx(scalar[i]).margin(1e-3));
      }
    }
  }
  CHECK(compared > 40000 * static_cast<int>(VectorForms().size()));
#if !defined(__FMA__)
  CHECK(apart == 0);
#endif
}

TEST_CASE("normal profile: the vector forms read nothing outside the image", "[vision]") {
  // Taps reach the first and the last pixels, where a vector read before the first byte or
  // past the last would leave the image. The image lies against a page that may not be read
  // (a read there ends the test with a fault; sanitizers do not see a gather's reads), first
  // ending at it, then starting after one: each form reads the same values as the
  // pixel-by-pixel loop, over the valid run that the border leaves.
  const auto page = static_cast<size_t>(sysconf(_SC_PAGESIZE));
  auto* pages = static_cast<std::uint8_t*>(
      mmap(nullptr, 3 * page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0));
  REQUIRE(pages != MAP_FAILED);
  REQUIRE(mprotect(pages, page, PROT_NONE) == 0);
  REQUIRE(mprotect(pages + 2 * page, page, PROT_NONE) == 0);
  std::mt19937 random(13);
  std::uniform_int_distribution<int> grey(0, 255);
  for (const auto& [width, height, at_end] :
       {std::tuple{37, 23, true}, std::tuple{64, 48, true}, std::tuple{37, 23, false}}) {
    const size_t bytes = static_cast<size_t>(width) * height;
    REQUIRE(bytes <= page);
    std::uint8_t* data = at_end ? pages + 2 * page - bytes : pages + page;
    for (size_t b = 0; b < bytes; ++b) data[b] = static_cast<std::uint8_t>(grey(random));
    const GrayView image{data, width, height, width};
    std::uniform_real_distribution<float> unit(0, 1);
    int full = 0;
    for (int trial = 0; trial < 3000; ++trial) {
      const float angle = 2 * static_cast<float>(M_PI) * unit(random);
      const Eigen::Vector2f normal(std::cos(angle), std::sin(angle)),
          tangent(normal.y(), -normal.x());
      const int h = trial % 3, K = 1 + trial % 9;
      const Eigen::Vector2f corner =
          at_end ? Eigen::Vector2f(width - 1.001f, height - 1.001f) : Eigen::Vector2f(0, 0);
      const float inwards = at_end ? -6 : 6;
      const Eigen::Vector2f point = corner + inwards * Eigen::Vector2f(unit(random), unit(random));
      int first = 0, last = 0;
      internal::ProfileRunScalar(image, point, normal, tangent, h, K, &first, &last);
      if (first > last) continue;
      full += first == 0 && last == 2 * K + 2;
      std::vector<float> scalar(2 * K + 12, -1);
      internal::FillProfileScalar(image, point, normal, tangent, h, K, first, last, scalar.data());
      for (const auto& [form, fill] : VectorForms()) {
        std::vector<float> vector(2 * K + 12, -1);
        fill(image, point, normal, tangent, h, K, first, last, vector.data());
        INFO(form << ", trial " << trial);
        for (int i = first; i <= last; ++i) REQUIRE(vector[i] == Approx(scalar[i]).margin(1e-3));
      }
    }
    CHECK(full > 100);  // some whole profiles among the cut ones
  }
  munmap(pages, 3 * page);
}

TEST_CASE("normal profile: the valid run from the corners is the point-by-point one", "[vision]") {
  // Random places, directions, reaches and widths, many of them across the border (the
  // shortcut must not apply there) and many just inside it (where it may): the same run.
  const std::vector<std::uint8_t> pixels(64 * 48, 100);
  const GrayView image{pixels.data(), 64, 48, 64};
  std::mt19937 random(11);
  std::uniform_real_distribution<float> unit(0, 1);
  int inside = 0, cut = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const float angle = 2 * static_cast<float>(M_PI) * unit(random);
    const Eigen::Vector2f normal(std::cos(angle), std::sin(angle)),
        tangent(normal.y(), -normal.x());
    const int h = trial % 4, K = trial % 17;
    // Within the profile's size of the border, or beyond it.
    const float size = static_cast<float>(h + K + 2);
    const Eigen::Vector2f point(-size + unit(random) * (63 + 2 * size),
                                -size + unit(random) * (47 + 2 * size));
    int first = -1, last = -1, first_ref = -1, last_ref = -1;
    internal::ProfileRun(image, point, normal, tangent, h, K, &first, &last);
    internal::ProfileRunScalar(image, point, normal, tangent, h, K, &first_ref, &last_ref);
    INFO("trial " << trial);
    REQUIRE(first == first_ref);
    REQUIRE(last == last_ref);
    (first == 0 && last == 2 * K + 2 ? inside : cut) += 1;
  }
  CHECK(inside > 2000);  // both kinds met often
  CHECK(cut > 2000);
}

}  // namespace
}  // namespace cfuse
