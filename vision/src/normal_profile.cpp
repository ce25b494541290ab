// The profile a normal search reads (normal_search_internal.h): where it lies inside the image,
// and its values, pixel by pixel or several normal positions at a time, the same floats either
// way. Reading the profile is most of a tracked frame's time.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "normal_search_internal.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(CFUSE_PROFILE_AVX2)
#include <immintrin.h>
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
// per lane (so the same floats as the scalar loop).
void FillProfileSse2(const GrayView& image, const Eigen::Vector2f& point,
                     const Eigen::Vector2f& normal, const Eigen::Vector2f& tangent, int h, int K,
                     int first, int last, float* profile) {
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
#endif

#if defined(CFUSE_PROFILE_AVX2)
bool Avx2Available() {
  static const bool available = __builtin_cpu_supports("avx2");
  return available;
}

// Eight normal positions at a time, each lane's four pixels read by two gathers, with the same
// operations in the same order per lane as the scalar loop (no FMA: the same floats).
__attribute__((target("avx2"))) void FillProfileAvx2(const GrayView& image,
                                                     const Eigen::Vector2f& point,
                                                     const Eigen::Vector2f& normal,
                                                     const Eigen::Vector2f& tangent, int h, int K,
                                                     int first, int last, float* profile) {
  const __m256 px = _mm256_set1_ps(point.x()), py = _mm256_set1_ps(point.y());
  const __m256 nx = _mm256_set1_ps(normal.x()), ny = _mm256_set1_ps(normal.y());
  const __m256 count = _mm256_set1_ps(static_cast<float>(2 * h + 1));
  const __m256i byte = _mm256_set1_epi32(0xff);
  const __m256i below = _mm256_set1_epi32(image.step);
  const auto* data = reinterpret_cast<const int*>(image.data);
  // A tap's row: 4 bytes from its pixel (the two wanted first). The next row's: 4 bytes ending
  // with its two, so that neither read passes the image's last byte (a tap lies in
  // [0, width - 1) x [0, height - 1), so the row's read ends at most at the last row, and the
  // next row's starts at least two bytes into the image).
  const __m256i back = _mm256_set1_epi32(2);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i k_last = _mm256_set1_epi32(last - K - 1);
  for (int i = first; i <= last; i += 8) {
    // Lanes past `last` repeat it (its taps are inside the image); their values are not kept.
    const __m256 k = _mm256_cvtepi32_ps(
        _mm256_min_epi32(_mm256_add_epi32(_mm256_set1_epi32(i - K - 1), lane), k_last));
    const __m256 cx = _mm256_add_ps(px, _mm256_mul_ps(k, nx));
    const __m256 cy = _mm256_add_ps(py, _mm256_mul_ps(k, ny));
    __m256 sum = _mm256_setzero_ps();
    for (int j = -h; j <= h; ++j) {
      const float fj = static_cast<float>(j);
      const __m256 x = _mm256_add_ps(cx, _mm256_set1_ps(fj * tangent.x()));
      const __m256 y = _mm256_add_ps(cy, _mm256_set1_ps(fj * tangent.y()));
      const __m256i x0 = _mm256_cvttps_epi32(x), y0 = _mm256_cvttps_epi32(y);
      const __m256 fx = _mm256_sub_ps(x, _mm256_cvtepi32_ps(x0));
      const __m256 fy = _mm256_sub_ps(y, _mm256_cvtepi32_ps(y0));
      const __m256i at = _mm256_add_epi32(_mm256_mullo_epi32(y0, below), x0);
      const __m256i top = _mm256_i32gather_epi32(data, at, 1);
      const __m256i next =
          _mm256_i32gather_epi32(data, _mm256_sub_epi32(_mm256_add_epi32(at, below), back), 1);
      const __m256 r00 = _mm256_cvtepi32_ps(_mm256_and_si256(top, byte));
      const __m256 r01 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(top, 8), byte));
      const __m256 r10 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(next, 16), byte));
      const __m256 r11 = _mm256_cvtepi32_ps(_mm256_srli_epi32(next, 24));
      const __m256 t = _mm256_add_ps(r00, _mm256_mul_ps(fx, _mm256_sub_ps(r01, r00)));
      const __m256 b = _mm256_add_ps(r10, _mm256_mul_ps(fx, _mm256_sub_ps(r11, r10)));
      sum = _mm256_add_ps(sum, _mm256_add_ps(t, _mm256_mul_ps(fy, _mm256_sub_ps(b, t))));
    }
    _mm256_storeu_ps(profile + i, _mm256_div_ps(sum, count));
  }
}
#endif

void FillProfile(const GrayView& image, const Eigen::Vector2f& point, const Eigen::Vector2f& normal,
                 const Eigen::Vector2f& tangent, int h, int K, int first, int last,
                 float* profile) {
#if defined(CFUSE_PROFILE_AVX2)
  // (Byte offsets in 32 bits: any image under 2 GB.)
  if (Avx2Available() && static_cast<double>(image.height) * image.step <
                             static_cast<double>(std::numeric_limits<int>::max())) {
    FillProfileAvx2(image, point, normal, tangent, h, K, first, last, profile);
    return;
  }
#endif
#if defined(__SSE2__)
  FillProfileSse2(image, point, normal, tangent, h, K, first, last, profile);
#else
  FillProfileScalar(image, point, normal, tangent, h, K, first, last, profile);
#endif
}

void ProfileRunScalar(const GrayView& image, const Eigen::Vector2f& point,
                      const Eigen::Vector2f& normal, const Eigen::Vector2f& tangent, int h, int K,
                      int* first, int* last) {
  const int n = 2 * K + 3;
  *first = 0;
  *last = n - 1;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2f centre = point + static_cast<float>(i - K - 1) * normal;
    const Eigen::Vector2f end_a = centre - static_cast<float>(h) * tangent;
    const Eigen::Vector2f end_b = centre + static_cast<float>(h) * tangent;
    if (!Inside(image, end_a.x(), end_a.y()) || !Inside(image, end_b.x(), end_b.y())) {
      if (i <= K + 1) {
        *first = i + 1;
      } else {
        *last = i - 1;
        break;
      }
    }
  }
}

void ProfileRun(const GrayView& image, const Eigen::Vector2f& point, const Eigen::Vector2f& normal,
                const Eigen::Vector2f& tangent, int h, int K, int* first, int* last) {
  // The corners a hundredth of a pixel inside: far more than the taps' rounding (a few
  // millionths of a pixel at these coordinates), so no tap of the point-by-point test fails.
  constexpr float kMargin = 0.01f;
  const float right = static_cast<float>(image.width - 1) - kMargin;
  const float bottom = static_cast<float>(image.height - 1) - kMargin;
  const auto well_inside = [&](const Eigen::Vector2f& q) {
    return q.x() >= kMargin && q.y() >= kMargin && q.x() < right && q.y() < bottom;
  };
  const Eigen::Vector2f reach = static_cast<float>(K + 1) * normal;
  const Eigen::Vector2f across = static_cast<float>(h) * tangent;
  if (well_inside(point - reach - across) && well_inside(point - reach + across) &&
      well_inside(point + reach - across) && well_inside(point + reach + across)) {
    *first = 0;
    *last = 2 * K + 2;
    return;
  }
  ProfileRunScalar(image, point, normal, tangent, h, K, first, last);
}

}  // namespace internal

}  // namespace cfuse
