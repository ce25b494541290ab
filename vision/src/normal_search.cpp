#include "cfuse/vision/normal_search.h"

#include <algorithm>
#include <cmath>

#include "normal_search_internal.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace cfuse {

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
  // (+7: the vector fill below writes whole groups of up to eight.)
  float profile[2 * kMaxReach + 3 + 7];
  const Eigen::Vector2f tangent(normal.y(), -normal.x());
  const int h = std::max(0, options.half_width);
  // The valid run of k around 0: every tangent sample inside the image.
  int first = 0, last = n - 1;
  internal::ProfileRun(image, point, normal, tangent, h, K, &first, &last);
  if (first > K + 1) return 0;  // the sample point itself is off the image
  internal::FillProfile(image, point, normal, tangent, h, K, first, last, profile);
  // D(k) at profile index i is profile[i + 1] - profile[i - 1]; the search covers |k| <= range.
  const int lo = std::max(first + 1, K + 1 - static_cast<int>(std::floor(range)));
  const int hi = std::min(last - 1, K + 1 + static_cast<int>(std::floor(range)));
  if (hi < lo) return 0;
  auto d = [&](int i) { return profile[i + 1] - profile[i - 1]; };
  // |D| over the valid run, 0 at its two ends (where D does not exist), computed once in a loop
  // the compiler vectorises: the peak test and the hits' widths below read it.
  float magnitude[2 * kMaxReach + 3];
  magnitude[first] = magnitude[last] = 0.f;
  for (int i = first + 1; i <= last - 1; ++i) magnitude[i] = std::abs(d(i));
  const float threshold = static_cast<float>(options.min_contrast);
  const int before = static_cast<int>(hits->size());
  // A hit at profile index i: |D| at least the threshold, a strict maximum on the left and at
  // least as large as the right (a plateau of two equal values, an ideal step between two
  // pixels, is taken once, at its left end).
  auto hit = [&](int i) {
    const float here = magnitude[i];
    const float left = magnitude[i - 1], right = magnitude[i + 1];
    // The run above half the peak, within the valid profile: the hit's width.
    const float half = 0.5f * here;
    int a = i, b = i;
    while (a - 1 >= first + 1 && magnitude[a - 1] >= half) --a;
    while (b + 1 <= last - 1 && magnitude[b + 1] >= half) ++b;
    auto crossing = [&](int inside, int outside) {
      const float vi = magnitude[inside];
      const float vo = outside >= first + 1 && outside <= last - 1 ? magnitude[outside] : 0.f;
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
  };
  int i = lo;
#if defined(__SSE2__)
  // Four indices tested at once, the hits among them taken in order (most indices are none).
  const __m128 at_least = _mm_set1_ps(threshold);
  for (; i + 3 <= hi; i += 4) {
    const __m128 here = _mm_loadu_ps(magnitude + i);
    const __m128 peak = _mm_and_ps(_mm_and_ps(_mm_cmpge_ps(here, at_least),
                                              _mm_cmpgt_ps(here, _mm_loadu_ps(magnitude + i - 1))),
                                   _mm_cmpge_ps(here, _mm_loadu_ps(magnitude + i + 1)));
    for (int mask = _mm_movemask_ps(peak); mask != 0; mask &= mask - 1) {
      hit(i + __builtin_ctz(mask));
    }
  }
#endif
  for (; i <= hi; ++i) {
    const float here = magnitude[i];
    if (here >= threshold && here > magnitude[i - 1] && here >= magnitude[i + 1]) hit(i);
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
