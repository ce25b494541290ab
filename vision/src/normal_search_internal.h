// The profile a normal search reads (cfuse/vision/normal_search.h), in two forms that give the
// same floats: a pixel-by-pixel loop, and four normal positions at a time where SSE2 is (every
// x86-64). Internal to cfuse::vision (not installed).
#pragma once

#include <Eigen/Core>

#include "cfuse/vision/segments.h"

namespace cfuse::internal {

// profile[i] = P(i - K - 1) = mean_{j = -h..h} I(point + (i - K - 1) normal + j tangent) for i in
// [first, last], bilinear; every tap must lie in [0, width - 1) x [0, height - 1). The vector
// form writes up to three floats past profile[last].
void FillProfileScalar(const GrayView& image, const Eigen::Vector2f& point,
                       const Eigen::Vector2f& normal, const Eigen::Vector2f& tangent, int h,
                       int K, int first, int last, float* profile);
void FillProfile(const GrayView& image, const Eigen::Vector2f& point,
                 const Eigen::Vector2f& normal, const Eigen::Vector2f& tangent, int h, int K,
                 int first, int last, float* profile);

}  // namespace cfuse::internal
