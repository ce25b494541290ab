// The profile a normal search reads (cfuse/vision/normal_search.h), in forms that give the same
// floats: a pixel-by-pixel loop, four normal positions at a time where SSE2 is (every x86-64),
// and eight where AVX2 is (vision/src/normal_profile.cpp). Internal to cfuse::vision (not
// installed).
#pragma once

#include <Eigen/Core>

#include "cfuse/vision/segments.h"

// The AVX2 form is compiled where the compiler can target it for one function and check the
// processor at run time.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define CFUSE_PROFILE_AVX2 1
#endif

namespace cfuse::internal {

// profile[i] = P(i - K - 1) = mean_{j = -h..h} I(point + (i - K - 1) normal + j tangent) for i in
// [first, last], bilinear; every tap must lie in [0, width - 1) x [0, height - 1). FillProfile
// takes the widest vector form this processor has; the vector forms write up to seven floats
// past profile[last].
void FillProfile(const GrayView& image, const Eigen::Vector2f& point,
                 const Eigen::Vector2f& normal, const Eigen::Vector2f& tangent, int h, int K,
                 int first, int last, float* profile);
void FillProfileScalar(const GrayView& image, const Eigen::Vector2f& point,
                       const Eigen::Vector2f& normal, const Eigen::Vector2f& tangent, int h, int K,
                       int first, int last, float* profile);
#if defined(__SSE2__)
void FillProfileSse2(const GrayView& image, const Eigen::Vector2f& point,
                     const Eigen::Vector2f& normal, const Eigen::Vector2f& tangent, int h, int K,
                     int first, int last, float* profile);  // four at a time
#endif
#if defined(CFUSE_PROFILE_AVX2)
bool Avx2Available();
void FillProfileAvx2(const GrayView& image, const Eigen::Vector2f& point,
                     const Eigen::Vector2f& normal, const Eigen::Vector2f& tangent, int h, int K,
                     int first, int last, float* profile);  // eight at a time, where available
#endif

// The run [first, last] of profile indices 0..n-1 (n = 2K + 3) around the sample point (index
// K + 1) whose taps all lie in [0, width - 1) x [0, height - 1): point by point, and the same
// decided from the profile's four corners when they lie well inside (the taps are a
// parallelogram's points, and the image's interior is convex), as most searches are.
void ProfileRunScalar(const GrayView& image, const Eigen::Vector2f& point,
                      const Eigen::Vector2f& normal, const Eigen::Vector2f& tangent, int h, int K,
                      int* first, int* last);
void ProfileRun(const GrayView& image, const Eigen::Vector2f& point, const Eigen::Vector2f& normal,
                const Eigen::Vector2f& tangent, int h, int K, int* first, int* last);

}  // namespace cfuse::internal
