#include "cfuse/kernel/measurements/camera_checks.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "cfuse/kernel/check.h"

namespace cfuse {
namespace {

constexpr const char* kMatrixShape = "a camera matrix is [fx 0 cx; 0 fy cy; 0 0 1]";

// "nan" whatever its sign bit (OpenCV reads its `.Nan` as -nan), "inf", "-inf".
std::string NonFinite(double v) { return std::isnan(v) ? "nan" : fmt::format("{}", v); }

}  // namespace

std::optional<CameraProblem> CameraMatrixProblem(std::span<const double> K) {
  CFUSE_CHECK(K.size() == 9);
  for (int i = 0; i < 9; ++i) {
    if (!std::isfinite(K[i])) {
      return CameraProblem{
          i, fmt::format("K[{}][{}] must be finite, got {}", i / 3, i % 3, NonFinite(K[i]))};
    }
  }
  if (!(K[0] > 0))
    return CameraProblem{0, fmt::format("fx = K[0][0] must be positive, got {}", K[0])};
  if (!(K[4] > 0))
    return CameraProblem{4, fmt::format("fy = K[1][1] must be positive, got {}", K[4])};
  // Zero to rounding: a skew of 1e-9 fx moves no point by a visible amount.
  if (std::abs(K[1]) > 1e-9 * K[0]) {
    return CameraProblem{1, fmt::format("the skew K[0][1] must be 0, got {}: cfuse's camera has no "
                                        "skew term",
                                        K[1])};
  }
  for (int i : {3, 6, 7}) {
    if (std::abs(K[i]) > 1e-9 * (i == 3 ? K[4] : 1.0)) {
      return CameraProblem{
          i, fmt::format("K[{}][{}] must be 0, got {}: {}", i / 3, i % 3, K[i], kMatrixShape)};
    }
  }
  if (std::abs(K[8] - 1) > 1e-9) {
    return CameraProblem{8, fmt::format("K[2][2] must be 1, got {}: {}", K[8], kMatrixShape)};
  }
  return std::nullopt;
}

const char* DistortionName(int i) {
  static constexpr const char* kNames[] = {"k1", "k2", "p1", "p2", "k3", "k4",    "k5",
                                           "k6", "s1", "s2", "s3", "s4", "tau_x", "tau_y"};
  CFUSE_CHECK(i >= 0 && i < 14);
  return kNames[i];
}

std::optional<CameraProblem> DistortionProblem(std::span<const double> d) {
  const int n = static_cast<int>(d.size());
  if (n != 0 && n != 4 && n != 5 && n != 8 && n != 12 && n != 14) {
    return CameraProblem{-1, fmt::format("has {} coefficients; OpenCV's model takes 4, 5, 8, 12 or "
                                         "14 (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [tau_x "
                                         "tau_y]]]])",
                                         n)};
  }
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(d[i])) {
      return CameraProblem{i, fmt::format("coefficient {} ({}) must be finite, got {}", i + 1,
                                          DistortionName(i), NonFinite(d[i]))};
    }
  }
  if (n == 14 && (d[12] != 0 || d[13] != 0)) {
    return CameraProblem{
        d[12] != 0 ? 12 : 13,
        fmt::format("has the tilted-sensor coefficients tau_x = {}, tau_y = {} (13th and 14th): "
                    "cfuse's camera has no tilt, they must be 0",
                    d[12], d[13])};
  }
  return std::nullopt;
}

std::optional<CameraProblem> PrincipalPointProblem(double cx, double cy, int width, int height) {
  CFUSE_CHECK(width >= 1 && height >= 1);
  const double c[2] = {cx, cy};
  const int side[2] = {width, height};
  for (int i = 0; i < 2; ++i) {
    if (!(c[i] >= -side[i] && c[i] <= 2.0 * side[i])) {
      return CameraProblem{
          i, fmt::format("the principal point {} = {} is outside [{}, {}], a whole image beyond "
                         "the {} x {} image: is the camera matrix for another image size?",
                         i == 0 ? "cx" : "cy", c[i], -side[i], 2 * side[i], width, height)};
    }
  }
  return std::nullopt;
}

bool IsImageSide(double pixels) {
  return pixels >= 1 && pixels <= 1e6 && pixels == std::floor(pixels);
}

Camera PinholeCamera(std::span<const double> K, std::span<const double> coefficients, int width,
                     int height) {
  CFUSE_CHECK(!CameraMatrixProblem(K) && !DistortionProblem(coefficients));
  Camera camera;
  camera.model = Camera::Model::kPinhole;
  camera.fx = K[0];
  camera.fy = K[4];
  camera.cx = K[2];
  camera.cy = K[5];
  camera.width = width;
  camera.height = height;
  std::copy_n(coefficients.begin(), std::min<size_t>(coefficients.size(), 12),
              camera.distortion.begin());
  CFUSE_CHECK(!PrincipalPointProblem(camera.cx, camera.cy, width, height));
  return camera;
}

}  // namespace cfuse
