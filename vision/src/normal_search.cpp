#include "cfuse/vision/normal_search.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "normal_search_internal.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace cfuse {
namespace {

// Bilinear interpolation at (x, y), which must lie in [0, width - 1) x [0, height - 1).
inline float Bilinear(const GrayView& image, float x, float y) {
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
  const std::uint8_t* row = image.data + static_cast<std::ptrdiff_t>(y0) * image.step + x0;
  const float top = row[0] + fx * (static_cast<float>(row[1]) - row[0]);
  const float bottom =
      row[image.step] + fx * (static_cast<float>(row[image.step + 1]) - row[image.step]);
  return top + fy * (bottom - top);
}

inline bool Inside(const GrayView& image, float x, float y) {
  return x >= 0 && y >= 0 && x < static_cast<float>(image.width - 1) &&
         y < static_cast<float>(image.height - 1);
}

}  // namespace

namespace internal {

void FillProfileScalar(const GrayView& image, const Eigen::Vector2f& point,
                       const Eigen::Vector2f& normal, const Eigen::Vector2f& tangent, int h, int K,
                       int first, int last, float* profile) {
  for (int i = first; i <= last; ++i) {
    const Eigen::Vector2f centre = point + static_cast<float>(i - K - 1) * normal;
    float sum = 0;
    for (int j = -h; j <= h; ++j) {
      const Eigen::Vector2f q = centre + static_cast<float>(j) * tangent;
      sum += Bilinear(image, q.x(), q.y());
    }
    profile[i] = sum / static_cast<float>(2 * h + 1);
  }
}

#if defined(__SSE2__)
// The same profile four normal positions at a time, with the same operations in the same order
// per lane (so the same floats as the scalar loop): reading the profile is most of a tracked
// frame's time.
void FillProfile(const GrayView& image, const Eigen::Vector2f& point, const Eigen::Vector2f& normal,
                 const Eigen::Vector2f& tangent, int h, int K, int first, int last,
                 float* profile) {
  const __m128 px = _mm_set1_ps(point.x()), py = _mm_set1_ps(point.y());
  const __m128 nx = _mm_set1_ps(normal.x()), ny = _mm_set1_ps(normal.y());
  const __m128 count = _mm_set1_ps(static_cast<float>(2 * h + 1));
  const __m128i byte = _mm_set1_epi32(0xff);
  const std::uint8_t* data = image.data;
  const std::ptrdiff_t below = static_cast<std::ptrdiff_t>(image.step);
  alignas(16) std::int32_t column[4], row[4];
  for (int i = first; i <= last; i += 4) {
    // Lanes past `last` repeat it (its taps are inside the image); their values are not kept.
    const __m128 k = _mm_cvtepi32_ps(_mm_setr_epi32(i - K - 1, std::min(i + 1, last) - K - 1,
                                                    std::min(i + 2, last) - K - 1,
                                                    std::min(i + 3, last) - K - 1));
    const __m128 cx = _mm_add_ps(px, _mm_mul_ps(k, nx));
    const __m128 cy = _mm_add_ps(py, _mm_mul_ps(k, ny));
    __m128 sum = _mm_setzero_ps();
    for (int j = -h; j <= h; ++j) {
      const float fj = static_cast<float>(j);
      const __m128 x = _mm_add_ps(cx, _mm_set1_ps(fj * tangent.x()));
      const __m128 y = _mm_add_ps(cy, _mm_set1_ps(fj * tangent.y()));
      const __m128i x0 = _mm_cvttps_epi32(x), y0 = _mm_cvttps_epi32(y);
      const __m128 fx = _mm_sub_ps(x, _mm_cvtepi32_ps(x0));
      const __m128 fy = _mm_sub_ps(y, _mm_cvtepi32_ps(y0));
      _mm_store_si128(reinterpret_cast<__m128i*>(column), x0);
      _mm_store_si128(reinterpret_cast<__m128i*>(row), y0);
      // Each lane's four pixels in one word: its row's two, then the next row's two.
      std::int32_t word[4];
      for (int l = 0; l < 4; ++l) {
        const std::uint8_t* at = data + static_cast<std::ptrdiff_t>(row[l]) * below + column[l];
        std::uint16_t top, bottom;
        std::memcpy(&top, at, 2);
        std::memcpy(&bottom, at + below, 2);
        word[l] = static_cast<std::int32_t>(top | (static_cast<std::uint32_t>(bottom) << 16));
      }
      const __m128i w = _mm_setr_epi32(word[0], word[1], word[2], word[3]);
      const __m128 r00 = _mm_cvtepi32_ps(_mm_and_si128(w, byte));
      const __m128 r01 = _mm_cvtepi32_ps(_mm_and_si128(_mm_srli_epi32(w, 8), byte));
      const __m128 r10 = _mm_cvtepi32_ps(_mm_and_si128(_mm_srli_epi32(w, 16), byte));
      const __m128 r11 = _mm_cvtepi32_ps(_mm_srli_epi32(w, 24));
      const __m128 top = _mm_add_ps(r00, _mm_mul_ps(fx, _mm_sub_ps(r01, r00)));
      const __m128 bottom = _mm_add_ps(r10, _mm_mul_ps(fx, _mm_sub_ps(r11, r10)));
      sum = _mm_add_ps(sum, _mm_add_ps(top, _mm_mul_ps(fy, _mm_sub_ps(bottom, top))));
    }
    _mm_storeu_ps(profile + i, _mm_div_ps(sum, count));
  }
}
#else
void FillProfile(const GrayView& image, const Eigen::Vector2f& point, const Eigen::Vector2f& normal,
                 const Eigen::Vector2f& tangent, int h, int K, int first, int last,
                 float* profile) {
  FillProfileScalar(image, point, normal, tangent, h, K, first, last, profile);
}
#endif

}  // namespace internal

int SearchAlongNormal(const GrayView& image, const Eigen::Vector2f& point,
                      const Eigen::Vector2f& normal, float range,
                      const NormalSearchOptions& options, std::vector<ProfileHit>* hits) {
  if (!(range >= 0) || !point.allFinite() || !normal.allFinite()) return 0;
  // Profile points k = -K - 1 .. K + 1, so that D(k) exists for |k| <= K: one more than the
  // search reaches, so that a hit at the end of the range is judged against its real
  // neighbour outside it (a slope rising past the end is not a peak there).
  constexpr int kMaxReach = 256;
  const int K = std::min(kMaxReach, static_cast<int>(std::floor(range)) + 1);
  const int n = 2 * K + 3;
  // (+3: the vector fill below writes whole groups of four.)
  float profile[2 * kMaxReach + 3 + 3];
  const Eigen::Vector2f tangent(normal.y(), -normal.x());
  const int h = std::max(0, options.half_width);
  // The valid run of k around 0: every tangent sample inside the image.
  int first = 0, last = n - 1;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2f centre = point + static_cast<float>(i - K - 1) * normal;
    const Eigen::Vector2f end_a = centre - static_cast<float>(h) * tangent;
    const Eigen::Vector2f end_b = centre + static_cast<float>(h) * tangent;
    if (!Inside(image, end_a.x(), end_a.y()) || !Inside(image, end_b.x(), end_b.y())) {
      if (i <= K + 1) {
        first = i + 1;
      } else {
        last = i - 1;
        break;
      }
    }
  }
  if (first > K + 1) return 0;  // the sample point itself is off the image
  internal::FillProfile(image, point, normal, tangent, h, K, first, last, profile);
  // D(k) at profile index i is profile[i + 1] - profile[i - 1]; the search covers |k| <= range.
  const int lo = std::max(first + 1, K + 1 - static_cast<int>(std::floor(range)));
  const int hi = std::min(last - 1, K + 1 + static_cast<int>(std::floor(range)));
  if (hi < lo) return 0;
  auto d = [&](int i) { return profile[i + 1] - profile[i - 1]; };
  const float threshold = static_cast<float>(options.min_contrast);
  const int before = static_cast<int>(hits->size());
  for (int i = lo; i <= hi; ++i) {
    const float here = std::abs(d(i));
    if (here < threshold) continue;
    // A strict maximum on the left, at least as large as the right: a plateau of two equal
    // values (an ideal step between two pixels) is taken once, at its left end.
    const float left = i - 1 >= first + 1 ? std::abs(d(i - 1)) : 0.f;
    const float right = i + 1 <= last - 1 ? std::abs(d(i + 1)) : 0.f;
    if (!(here > left && here >= right)) continue;
    // The run above half the peak, within the valid profile: the hit's width.
    const float half = 0.5f * here;
    int a = i, b = i;
    while (a - 1 >= first + 1 && std::abs(d(a - 1)) >= half) --a;
    while (b + 1 <= last - 1 && std::abs(d(b + 1)) >= half) ++b;
    auto crossing = [&](int inside, int outside) {
      const float vi = std::abs(d(inside));
      const float vo = outside >= first + 1 && outside <= last - 1 ? std::abs(d(outside)) : 0.f;
      return static_cast<float>(inside) +
             (vi > vo ? (vi - half) / (vi - vo) : 0.5f) * static_cast<float>(outside - inside);
    };
    const float rise = crossing(a, a - 1), fall = crossing(b, b + 1);
    const float width = fall - rise;
    const float curvature = left - 2 * here + right;
    // A step smeared by motion is a plateau of |D|, its peak anywhere on it: the edge at mid
    // exposure is the plateau's middle. A sharp step's peak is placed by the parabola.
    const float centre =
        width > options.smeared_width
            ? 0.5f * (rise + fall)
            : static_cast<float>(i) +
                  (curvature < 0 ? std::clamp(0.5f * (left - right) / curvature, -0.5f, 0.5f)
                                 : 0.f);
    hits->push_back({centre - static_cast<float>(K + 1), d(i), width});
  }
  // The strongest first, at most max_hits.
  auto begin = hits->begin() + before;
  std::sort(begin, hits->end(), [](const ProfileHit& a, const ProfileHit& b) {
    return std::abs(a.contrast) > std::abs(b.contrast);
  });
  const int found = static_cast<int>(hits->size()) - before;
  if (found > options.max_hits) hits->resize(before + std::max(0, options.max_hits));
  return static_cast<int>(hits->size()) - before;
}

}  // namespace cfuse
